"""The Wireshark dissector (scripts/wireshark/r2p.lua, docs/wireshark.md) on a pcap of the emulated
Triskar2: tshark's decoded fields are checked frame by frame against what the robot sent, read
here independently of the dissector — identifiers split by the spec's layout, messages
reassembled by r2ptools.rtcan_fragment (the spec's reassembler in Python), management messages
decoded from docs/middleware.md's table, payloads by r2ptools.msgs, type hashes from the
firmware's generated.rs."""
from __future__ import annotations

import math
import re
import shutil
import struct

import pytest

from conftest import ROOT, run
from r2ptools import msgs, rtcan_fragment

FIRMWARE = ROOT / "firmware"
R2P = FIRMWARE / "target" / "debug" / "r2p"
TRISKAR2 = ROOT / "robots" / "triskar2.toml"
DISSECTOR = ROOT / "scripts" / "wireshark" / "r2p.lua"
GENERATED = FIRMWARE / "crates" / "r2p-msgs" / "src" / "generated.rs"
TYPES = msgs.load()


def _tshark_with_lua() -> str | None:
    """Why the tests cannot run, or None."""
    if shutil.which("tshark") is None:
        return "tshark not installed (scripts/setup installs it)"
    p = run(["tshark", "-v"])
    if "with Lua" not in p.stdout:
        return "this tshark was built without Lua: the dissector cannot load"
    return None


pytestmark = pytest.mark.skipif(_tshark_with_lua() is not None, reason=str(_tshark_with_lua()))


@pytest.fixture(scope="module")
def pcap(tmp_path_factory):
    p = run(["cargo", "build", "-q", "-p", "r2p-cli"], cwd=FIRMWARE, timeout=900)
    assert p.returncode == 0, p.stdout
    out = tmp_path_factory.mktemp("ws") / "triskar2.pcap"
    p = run([str(R2P), "sim", str(TRISKAR2), "--seconds", "2", "--log", str(out)], timeout=120)
    assert p.returncode == 0, p.stdout
    return out


def read_pcap(path) -> list[tuple[float, int, bytes]]:
    """(time, 29-bit ID, data) per frame: pcap with LINKTYPE_CAN_SOCKETCAN (227), ID big-endian."""
    b = path.read_bytes()
    assert struct.unpack_from("<I", b, 0)[0] == 0xA1B2C3D4 and struct.unpack_from("<I", b, 20)[0] == 227
    out, at = [], 24
    while at < len(b):
        sec, usec, incl, _ = struct.unpack_from("<IIII", b, at)
        pkt = b[at + 16:at + 16 + incl]
        raw = struct.unpack_from(">I", pkt, 0)[0]
        assert raw & 0x8000_0000, "R2P frames are extended"
        out.append((sec + usec / 1e6, raw & 0x1FFF_FFFF, pkt[8:8 + pkt[4]]))
        at += 16 + incl
    return out


def tshark_fields(pcap, fields: list[str], display_filter: str | None = None,
                  two_pass: bool = False) -> dict[int, dict[str, str]]:
    """frame number -> {field: tshark's text} (every occurrence, comma-separated)."""
    cmd = ["tshark", *(["-2"] if two_pass else []), "-r", str(pcap), "-X", f"lua_script:{DISSECTOR}", "-T", "fields",
           "-E", "separator=\t", "-E", "occurrence=a", "-E", "aggregator=,", "-e", "frame.number"]
    for f in fields:
        cmd += ["-e", f]
    if display_filter:
        cmd += ["-Y", display_filter]
    p = run(cmd, timeout=300)
    assert p.returncode == 0, p.stdout
    assert "Lua" not in p.stdout or "Error" not in p.stdout, p.stdout[:2000]
    rows = {}
    for line in p.stdout.splitlines():
        if line.startswith("Running as user"):
            continue
        cols = line.split("\t")
        if not cols[0].isdigit():
            continue
        rows[int(cols[0])] = dict(zip(fields, cols[1:] + [""] * (len(fields) + 1 - len(cols))))
    return rows


def number(text: str) -> float:
    return int(text, 16) if text.startswith("0x") else float(text)


def close(text: str, value) -> bool:
    got = number(text)
    if isinstance(value, float) and math.isnan(value):
        return math.isnan(got)
    # tshark prints a float32 with 6 significant digits (FLT_DIG): half a unit of the 6th.
    return math.isclose(got, float(value), rel_tol=1e-5, abs_tol=1e-30)


class Mgmt:
    """docs/middleware.md "Messages", read with struct: only what the test compares."""

    def __init__(self, b: bytes):
        self.b, self.at, self.type = b, 1, b[0]

    def take(self, fmt: str):
        v = struct.unpack_from("<" + fmt, self.b, self.at)
        self.at += struct.calcsize("<" + fmt)
        return v[0] if len(v) == 1 else v

    def string(self) -> str:
        n = self.b[self.at]
        s = self.b[self.at + 1:self.at + 1 + n].decode("ascii")
        self.at += 1 + n
        return s


def reference(frames):
    """frame number (1-based) -> (message ID, payload) of each message completed on that frame."""
    r = rtcan_fragment.Reassembler(slots=256, buffer=rtcan_fragment.MAX_MESSAGE_LEN, timeout_us=10**12)
    done = {}
    for n, (t, raw, data) in enumerate(frames, 1):
        lax, mid, frag = rtcan_fragment.split(raw)
        if lax == 0 and frag <= 15 and mid < 0x100:
            continue                       # sync frames (the sender's rank in `frag`) are not messages
        msg = r.accept(raw, data, int(t * 1e6), None)
        if msg is not None:
            done[n] = (mid, msg)
    assert r.stats["bad_crc"] == 0 and r.stats["foreign"] == 0, r.stats
    return done


def test_identifier_fields_and_sync_frames(pcap):
    frames = read_pcap(pcap)
    rows = tshark_fields(pcap, ["r2p.id", "r2p.laxity", "r2p.class", "r2p.message_id", "r2p.node",
                                "r2p.stream", "r2p.fragment", "r2p.sync.cycle", "r2p.sync.epoch",
                                "r2p.sync.reservations", "r2p.sync.slot", "r2p.sync.sender"])
    assert len(rows) == len(frames) > 1000
    syncs = []
    for n, (t, raw, data) in enumerate(frames, 1):
        row = rows[n]
        lax, mid, frag = rtcan_fragment.split(raw)
        assert number(row["r2p.id"]) == raw
        assert int(row["r2p.laxity"]) == lax
        assert int(row["r2p.class"]) == (0 if lax == 0 else 2 if lax == 63 else 1), (n, row)
        assert number(row["r2p.message_id"]) == mid
        if lax == 0 and frag <= 15 and mid < 0x100:
            syncs.append((t, n))
            assert int(row["r2p.sync.cycle"]) == mid
            assert int(row["r2p.sync.sender"]) == frag
            word = int.from_bytes(data, "little")
            assert int(row["r2p.sync.epoch"]) == word & 1
            assert number(row["r2p.sync.reservations"]) == word | 1    # bit 0 reported set
            slots = [k for k in range(1, 64) if word >> k & 1]
            assert [int(s) for s in row["r2p.sync.slot"].split(",") if s] == slots
        else:
            assert row["r2p.sync.cycle"] == ""
            assert (int(row["r2p.node"]), int(row["r2p.stream"])) == (mid >> 8, mid & 0xFF)
            assert int(row["r2p.fragment"]) == frag
    # One sync per 10 ms cycle (robots/triskar2.toml cycle_us), its counter up by 1 each.
    cycles = [int(rows[n]["r2p.sync.cycle"]) for _, n in syncs]
    assert len(cycles) >= 195
    assert all(b == (a + 1) % 256 for a, b in zip(cycles, cycles[1:])), cycles[:20]
    gaps = [b[0] - a[0] for a, b in zip(syncs, syncs[1:])]
    assert all(abs(g - 0.010) < 0.0002 for g in gaps), (min(gaps), max(gaps))


def _rust_hashes() -> dict[int, tuple[str, int]]:
    body = re.search(r"pub const ALL: &\[\(&str, u32, usize\)\] = &\[(.*?)\];", GENERATED.read_text(), re.S).group(1)
    return {int(h.replace("_", ""), 16): (name, int(size))
            for name, h, size in re.findall(r'\("(\w+)",\s*(0x[0-9A-F_]+),\s*(\d+)\)', body)}


MGMT_FIELDS = ["r2p.message.length", "r2p.mgmt.type", "r2p.mgmt.name", "r2p.mgmt.state",
               "r2p.mgmt.uptime_s", "r2p.mgmt.topic", "r2p.mgmt.type_hash", "r2p.mgmt.type_name",
               "r2p.mgmt.size", "r2p.mgmt.index", "r2p.mgmt.class", "r2p.mgmt.target",
               "r2p.mgmt.message_id", "r2p.mgmt.hrt_period_cycles", "r2p.mgmt.offset", "r2p.mgmt.slot",
               "r2p.mgmt.hrt_result", "r2p.mgmt.start_us", "r2p.mgmt.len_us", "r2p.mgmt.subscribe_result", "r2p.mgmt.kind", "r2p.mgmt.version",
               "r2p.topic", "r2p.type"]


def test_messages_reassembled_and_management_decoded(pcap):
    frames = read_pcap(pcap)
    done = reference(frames)
    rows = tshark_fields(pcap, MGMT_FIELDS)
    ended = {n for n, row in rows.items() if row["r2p.message.length"]}
    assert ended == set(done), sorted(ended ^ set(done))[:10]
    hashes = _rust_hashes()
    seen, names, grants, advertised = {}, set(), [], {}
    for n, (mid, payload) in done.items():
        row = rows[n]
        assert int(row["r2p.message.length"]) == len(payload)
        if mid & 0xFF:
            continue
        m = Mgmt(payload)
        assert number(row["r2p.mgmt.type"]) == m.type, (n, row)
        seen[m.type] = seen.get(m.type, 0) + 1
        if m.type == 0x11:                                              # HEARTBEAT
            m.take("12s")
            name = m.string()
            assert row["r2p.mgmt.name"] == name
            assert int(row["r2p.mgmt.state"]) == m.take("B")
            assert int(row["r2p.mgmt.uptime_s"]) == m.take("I")
            names.add(name)
        elif m.type == 0x21:                                            # ADVERTISE
            topic, (h, size, index, cls, arg) = m.string(), m.take("IHBBI")
            assert (row["r2p.mgmt.topic"], number(row["r2p.mgmt.type_hash"]), int(row["r2p.mgmt.size"]),
                    int(row["r2p.mgmt.index"]), int(row["r2p.mgmt.class"])) == (topic, h, size, index, cls)
            name, rust_size = hashes[h]                                 # the firmware's type hash
            assert (row["r2p.mgmt.type_name"], size) == (name, rust_size)
            advertised[topic] = name
        elif m.type == 0x25:                                            # HRT_GRANT
            g = m.take("HHBBB")
            start, length = m.take("HH")
            assert (number(row["r2p.mgmt.message_id"]), int(row["r2p.mgmt.hrt_period_cycles"]),
                    int(row["r2p.mgmt.offset"]), int(row["r2p.mgmt.slot"]), int(row["r2p.mgmt.hrt_result"])) == g
            assert (int(row["r2p.mgmt.start_us"]), int(row["r2p.mgmt.len_us"])) == (start, length)
            # Where the reservation lies: the emulated robot runs on the slot grid, where the slot
            # is the reservation and a grant carries no position.
            assert (start, length) == (0, 0), g
            grants.append((n, g))
        elif m.type == 0x23:                                            # SUBSCRIBE_RESPONSE
            target, topic = m.take("B"), m.string()
            result, msg_id = m.take("BH")
            assert (int(row["r2p.mgmt.target"]), row["r2p.mgmt.topic"], int(row["r2p.mgmt.subscribe_result"]),
                    number(row["r2p.mgmt.message_id"])) == (target, topic, result, msg_id)
        elif m.type == 0x15:                                            # FIRMWARE
            assert number(row["r2p.mgmt.version"]) == m.take("I")
            m.take("8s")
            assert row["r2p.mgmt.kind"] == m.string()
    assert {"psu", "proximity", "gateway", "motor1", "motor2", "motor3"} <= names, names
    assert {0x11, 0x15, 0x21, 0x22, 0x23, 0x24, 0x25} <= set(seen), seen
    assert advertised["motor1/setpoint"] == "WheelSetpoint" and advertised["psu/battery"] == "Battery"
    # Each granted slot is then reserved in the sync frames (the master's calendar). Three
    # grants, each repeated unchanged by the master's calendar beacon (one table entry per
    # heartbeat, docs/rtcan.md "Master failover"); a repetition may come before another's answer.
    assert len({g for _, g in grants}) == 3 and all(g[4] == 0 for _, g in grants), grants
    answers = {g: n for n, g in reversed(grants)}                    # each grant's first frame
    last = max(answers.values())
    later = [int.from_bytes(d, "little") for k, (_, raw, d) in enumerate(frames, 1)
             if k > last + 200 and raw < 0x100 << 7 and raw & 0x7F == 0]
    assert later and all(w >> g[3] & 1 for w in later for _, g in grants)


def test_two_passes_link_each_frame_to_its_message(pcap):
    """As in the GUI (tshark -2): a message's earlier frames say where it was reassembled."""
    frames = read_pcap(pcap)
    rows = tshark_fields(pcap, ["r2p.message.frame", "r2p.reassembled_in", "r2p.mgmt.type"], "r2p", two_pass=True)
    messages = 0
    for n, row in rows.items():
        if not row["r2p.message.frame"]:
            continue
        members = [int(k) for k in row["r2p.message.frame"].split(",")]
        first = frames[members[0] - 1][1]
        assert members[-1] == n and len(members) == first & 0x7F          # counters F … 1
        assert {frames[k - 1][1] >> 7 & 0xFFFF for k in members} == {first >> 7 & 0xFFFF}
        assert all(rows[k]["r2p.reassembled_in"] == str(n) for k in members[:-1])
        messages += 1
    assert messages > 300


def test_topic_payloads_decoded_by_type(pcap):
    frames = read_pcap(pcap)
    done = reference(frames)
    fields = [f"r2p.{t.name}.{f.name}" for t in TYPES.values() for f in t.fields]
    rows = tshark_fields(pcap, ["r2p.topic", "r2p.type", "r2p.type_hash"] + fields, "r2p.topic")
    types_seen, checked, setpoints = set(), 0, []
    for n, (mid, payload) in done.items():
        if not mid & 0xFF:
            continue
        row = rows[n]                    # every topic message is decoded (its ADVERTISE came first)
        t = TYPES[row["r2p.type"]]
        assert number(row["r2p.type_hash"]) == t.type_hash
        values = t.decode(payload)
        for f in t.fields:
            got = row[f"r2p.{t.name}.{f.name}"].split(",")
            want = values[f.name] if f.count else [values[f.name]]
            assert len(got) == len(want) and all(close(g, float(w)) for g, w in zip(got, want)), \
                (n, row["r2p.topic"], f.name, got, want)
            checked += 1
        types_seen.add(t.name)
        if t.name == "WheelSetpoint":
            setpoints.append(values["value"])
    assert {"WheelSetpoint", "WheelState", "Battery", "Proximity", "PsuState"} <= types_seen, types_seen
    assert checked > 2000
    # The base controller drives: setpoints leave 0 rad/s once it runs.
    assert len(setpoints) > 400 and any(abs(v) > 1.0 for v in setpoints)


def write_pcap(path, frames: list[tuple[int, bytes]]) -> None:
    """A pcap as firmware/host/canlink/src/pcap.rs writes it: LINKTYPE_CAN_SOCKETCAN, ID big-endian
    with the EFF flag, length, 3 reserved bytes, data padded to 8."""
    out = bytearray(struct.pack("<IHHiIII", 0xA1B2C3D4, 2, 4, 0, 0, 65535, 227))
    for k, (raw, data) in enumerate(frames):
        pkt = struct.pack(">I", raw | 0x8000_0000) + bytes([len(data), 0, 0, 0]) + data.ljust(8, b"\0")
        out += struct.pack("<IIII", 1_700_000_000, k * 100, len(pkt), len(pkt)) + pkt
    path.write_bytes(out)


NRT = 63


def mgmt_frames(node: int, payload: bytes) -> list[tuple[int, bytes]]:
    return rtcan_fragment.fragments(NRT, node << 8, payload)


# docs/middleware.md "Messages": every type the emulated robot does not send in 2 s, and two
# malformed ones. (the message's bytes, field -> expected text)
UID = bytes(range(1, 13))
CRAFTED = [
    (b"\x11" + UID + b"\x05motor\x01" + struct.pack("<IBBH", 3600, 2, 0, 7),        # the doc's example
     {"r2p.mgmt.name": "motor", "r2p.mgmt.state": "1", "r2p.mgmt.uptime_s": "3600",
      "r2p.mgmt.tx_errors": "2", "r2p.mgmt.dropped": "7", "r2p.message.length": "28",
      "r2p.message.frames": "4"}),
    (bytes.fromhex("13 12"), {"r2p.mgmt.type": "0x13", "r2p.mgmt.target": "18"}),
    (bytes.fromhex("14 0B 61 2E 72 73 3A 37 3A 31 3A 20 78"), {"r2p.mgmt.panic": "a.rs:7:1: x"}),
    (b"\x15" + struct.pack("<I", 0x01020103) + bytes(range(8)) + b"\x03psu\x01",
     {"r2p.mgmt.version_text": "1.2.259", "r2p.mgmt.kind": "psu", "r2p.mgmt.on_trial": "1"}),
    (b"\x51\x22\x03abc", {"r2p.mgmt.target": "34", "r2p.mgmt.update_len": "3",
                          "r2p.mgmt.update_data": "616263"}),
    (bytes.fromhex("24 01 7f 04 00 01"), {"r2p.mgmt.message_id": "0x7f01", "r2p.mgmt.hrt_period_cycles": "4",
                                          "r2p.mgmt.frames": "1"}),
    (bytes.fromhex("25 01 7f 04 00 00 00 01"), {"r2p.mgmt.hrt_result": "1", "r2p.mgmt.slot": "0"}),
    (bytes.fromhex("41 05 0300"), {"r2p.mgmt.target": "5", "r2p.mgmt.param": "3"}),
    (bytes.fromhex("42 05 0300 03") + struct.pack("<f", 2.5), {"r2p.mgmt.value_type": "3",
                                                                "r2p.mgmt.value_f32": "2.5"}),
    (bytes.fromhex("43 0300 02") + struct.pack("<i", -7), {"r2p.mgmt.value_i32": "-7"}),
    (bytes.fromhex("43 0400 00 01000000"), {"r2p.mgmt.value_bool": "1"}),
    (bytes.fromhex("44 0300 01"), {"r2p.mgmt.fault": "1"}),
    (b"\x22\x07\x0bmotor1/spx\x00" + struct.pack("<IB", 0x06AD21EE, 4),
     {"r2p.mgmt.target": "7", "_expert": "bad string"}),                             # NUL in a topic
    (bytes.fromhex("13 12 00"), {"r2p.mgmt.target": "18", "_expert": "trailing bytes"}),
]


def test_every_management_type_and_malformed_ones(tmp_path):
    frames = [(0x45 << 7 | 3, bytes.fromhex("07 00 00 00 00 00 00 00"))]       # sync from rank 3, slots 1-2, epoch 1
    ends = []
    for payload, _ in CRAFTED:
        frames += mgmt_frames(0x2A, payload)
        ends.append(len(frames))
    bad = bytearray(b"".join(d for _, d in rtcan_fragment.fragments(NRT, 0x2A00, CRAFTED[0][0])))
    frames += mgmt_frames(0x2A, CRAFTED[0][0])[:-1] + [(rtcan_fragment.identifier(NRT, 0x2A00, 1),
                                                        bytes(bad[24:27]) + b"\x00")]  # CRC broken
    path = tmp_path / "crafted.pcap"
    write_pcap(path, frames)
    wanted = sorted({k for _, w in CRAFTED for k in w if not k.startswith("_")})
    rows = tshark_fields(path, ["r2p.sync.cycle", "r2p.sync.epoch", "r2p.sync.slot", "r2p.sync.reservations",
                                "r2p.sync.sender", "r2p.mgmt.type", "_ws.expert.message"] + wanted)
    assert (rows[1]["r2p.sync.cycle"], rows[1]["r2p.sync.epoch"], rows[1]["r2p.sync.slot"],
            rows[1]["r2p.sync.reservations"], rows[1]["r2p.sync.sender"]) == ("69", "1", "1,2", "0x0000000000000007", "3")
    for (payload, want), n in zip(CRAFTED, ends):
        row = rows[n]
        assert number(row["r2p.mgmt.type"]) == payload[0], (n, row)
        for k, v in want.items():
            if k == "_expert":
                assert v in row["_ws.expert.message"], row
            else:
                assert row[k] == v, (payload.hex(), k, row[k], v)
        if "_expert" not in want:
            assert "Malformed" not in row["_ws.expert.message"], row
    assert "does not match" in rows[len(frames)]["_ws.expert.message"]
    assert rows[len(frames)]["r2p.mgmt.type"] == ""                              # never decoded


def test_install_command_puts_the_dissector_where_wireshark_loads_it(pcap, tmp_path):
    """scripts/wireshark/install, as docs/wireshark.md gives it, with HOME in a temporary folder:
    tshark then decodes R2P with no -X option; --uninstall takes it away again."""
    env = {"HOME": str(tmp_path)}
    install = ROOT / "scripts" / "wireshark" / "install"
    p = run([str(install)], env=env)
    assert p.returncode == 0, p.stdout
    plugin = tmp_path / ".local" / "lib" / "wireshark" / "plugins" / "r2p"
    assert (plugin / "r2p.lua").resolve() == DISSECTOR and (plugin / "r2p_types.lua").is_file()
    p = run(["tshark", "-r", str(pcap), "-T", "fields", "-e", "r2p.mgmt.name", "-Y", "r2p.mgmt.type == 0x11"],
            env=env, timeout=300)
    assert p.returncode == 0 and "psu" in p.stdout.split(), p.stdout[:500]
    assert run([str(install), "--uninstall"], env=env).returncode == 0
    assert not plugin.exists()
    p = run(["tshark", "-G", "protocols"], env=env)
    assert "\tr2p\n" not in p.stdout
