"""The `r2p` host CLI against a running emulated robot (`r2p-emu demo --realtime`, reached over
socketcand on 127.0.0.1), against traces (candump logs and pcap files), and its trace tools:
conversion (checked by tshark when installed) and replay into a bus."""
from __future__ import annotations

import hashlib
import json
import re
import shutil
import struct
import time
from pathlib import Path

import pytest

from conftest import ROOT, SocketcandProcess, free_port, run

FIRMWARE = ROOT / "firmware"
DEBUG = FIRMWARE / "target" / "debug"
R2P, EMU, CANLINK = DEBUG / "r2p", DEBUG / "r2p-emu", DEBUG / "r2p-canlink"
DEMO_NODES = {"psu", "motor", "control"}


@pytest.fixture(scope="module")
def built() -> None:
    p = run(["cargo", "build", "-q", "-p", "r2p-cli", "-p", "r2p-emu", "-p", "r2p-canlink"], cwd=FIRMWARE,
            timeout=900)
    assert p.returncode == 0, p.stdout


@pytest.fixture(scope="module")
def demo(built):
    """One emulated demo robot for the tests that do not change it."""
    emu = SocketcandProcess([str(EMU), "demo", "--realtime"], "r2p-emu")
    try:
        time.sleep(0.5)  # the boards start heartbeating at once; motor publishes from 200 ms
        yield emu
    finally:
        emu.kill()


def r2p(emu, *args: str, timeout: float = 60):
    """Runs r2p against `emu` with a generous bus timeout (the machine may be loaded)."""
    return run([str(R2P), "--socketcand", f"127.0.0.1:{emu.port}", "--timeout", "2", *args], timeout=timeout)


@pytest.fixture(scope="module")
def trace(built, tmp_path_factory) -> Path:
    """One second of the demo robot in virtual time: a deterministic candump log."""
    path = tmp_path_factory.mktemp("trace") / "demo.log"
    p = run([str(EMU), "demo", "--seconds", "1", "--log", str(path)], timeout=60)
    assert p.returncode == 0, p.stdout
    return path


def test_help_everywhere(built):
    top = run([str(R2P), "--help"], timeout=30)
    assert top.returncode == 0
    for word in ("monitor", "nodes", "topics", "echo", "pub", "param", "replay", "convert", "--socketcand",
                 "--socketcan", "--trace", "127.0.0.1:29536"):
        assert word in top.stdout, word
    for sub in (["monitor"], ["nodes"], ["topics"], ["echo"], ["pub"], ["param"], ["param", "get"],
                ["param", "set"], ["replay"], ["convert"]):
        p = run([str(R2P), *sub, "--help"], timeout=30)
        assert p.returncode == 0 and "Usage: r2p" in p.stdout, (sub, p.stdout)
    p = run([str(R2P), "frobnicate"], timeout=30)
    assert p.returncode == 2 and "unrecognized subcommand" in p.stdout


def test_flash_builds_the_probe_rs_commands_and_says_what_is_missing(built, tmp_path):
    # A stand-in probe-rs that finds no probe (the machines running the tests have none).
    fake = tmp_path / "probe-rs"
    fake.write_text("#!/bin/sh\ncase \"$1\" in\n  --version) echo 'probe-rs 0.32.0';;\n"
                    "  list) echo 'No debug probes were found.';;\n  *) exit 3;;\nesac\n")
    fake.chmod(0o755)
    p = run([str(R2P), "flash", "motor", "--probe-rs", str(fake)], timeout=30)
    assert p.returncode == 1 and p.stdout.startswith("r2p: error: no debug probe found"), p.stdout
    assert "docs/flashing.md" in p.stdout
    # The gateway's image is for its F407, behind the F407's bootloader: the bootloader first.
    p = run([str(R2P), "flash", "gateway", "--probe-rs", str(fake), "--dry-run"], timeout=30)
    assert p.returncode == 0 and p.stdout.splitlines() == [
        f"{fake} download --chip STM32F407VG --verify {ROOT}/firmware/images/bootloader-f407.elf",
        f"{fake} download --chip STM32F407VG --verify {ROOT}/firmware/images/gateway.elf",
        f"{fake} reset --chip STM32F407VG"], p.stdout
    # F103 modules behind their bootloader (slot = "active" in modules.toml): bootloader-f103 first.
    for module in ("motor", "proximity", "psu"):
        p = run([str(R2P), "flash", module, "--probe-rs", str(fake), "--dry-run"], timeout=30)
        assert p.returncode == 0 and p.stdout.splitlines() == [
            f"{fake} download --chip STM32F103CB --verify {ROOT}/firmware/images/bootloader-f103.elf",
            f"{fake} download --chip STM32F103CB --verify {ROOT}/firmware/images/{module}.elf",
            f"{fake} reset --chip STM32F103CB"], p.stdout
    # The IMU out of a slot (docs/flashing.md, "The IMU's flash"): its image alone, at the base.
    p = run([str(R2P), "flash", "imu", "--probe-rs", str(fake), "--dry-run"], timeout=30)
    assert p.returncode == 0 and p.stdout.splitlines() == [
        f"{fake} download --chip STM32F103CB --verify {ROOT}/firmware/images/imu.elf",
        f"{fake} reset --chip STM32F103CB"], p.stdout
    p = run([str(R2P), "flash"], timeout=30)
    assert p.returncode == 2 and "<MODULE>" in p.stdout


def test_keygen_and_sign_make_images_only_their_key_verifies(built, tmp_path):
    # A key of one's own, outside the repository; the signed image is the image then its trailer,
    # whose ed25519 signature checks with that key (Python's independent `hashlib` for SHA-512;
    # the signature itself is checked by r2p-boot's tests against ed25519-dalek).
    key = tmp_path / "keys" / "lab.key"
    p = run([str(R2P), "keygen", str(key)], timeout=30)
    assert p.returncode == 0, p.stdout
    assert (key.stat().st_mode & 0o777) == 0o600, "the secret key is readable by its owner only"
    public = (tmp_path / "keys" / "lab.key.pub").read_text().splitlines()[-1]
    assert re.fullmatch(r"[0-9a-f]{64}", public)
    p = run([str(R2P), "keygen", str(key)], timeout=30)
    assert p.returncode == 1 and "not overwritten" in p.stdout, p.stdout
    p = run([str(R2P), "keygen", str(ROOT / "firmware" / "keys" / "mine.key")], timeout=30)
    assert p.returncode == 1 and "inside the R2P repository" in p.stdout, p.stdout
    assert not (ROOT / "firmware" / "keys" / "mine.key").exists()

    out = tmp_path / "motor.signed.bin"
    p = run([str(R2P), "sign", "motor", "--version", "1.2.3", "--key", str(key), "-o", str(out)], timeout=30)
    assert p.returncode == 0, p.stdout
    image = (ROOT / "firmware" / "images" / "motor.bin").read_bytes()
    signed = out.read_bytes()
    assert signed[:len(image)] == image and len(signed) == len(image) + 128
    trailer = signed[len(image):]
    assert trailer[:5] == b"R2PI\x01" and int.from_bytes(trailer[8:12], "little") == len(image)
    assert trailer[12:16] == bytes([3, 0, 2, 1]) and trailer[16:21] == b"motor"
    assert trailer[32:43] == b"STM32F103CB"
    assert trailer[48:56] == hashlib.sha512(bytes.fromhex(public)).digest()[:8], "the key id names lab.key"
    assert f"key {trailer[48:56].hex()}" in p.stdout

    # Without --key: the public development key, said loudly.
    p = run([str(R2P), "sign", "motor", "--version", "1.2.3", "-o", str(tmp_path / "dev.bin")], timeout=30)
    assert p.returncode == 0 and p.stdout.startswith("warning: signed with the public development key"), p.stdout
    for args, msg in [(["sign", "motor", "--version", "1.2"], "expected MAJOR.MINOR.PATCH"),
                      (["sign", str(out), "--version", "1.0.0", "--key", str(key)], "a file needs --kind"),
                      (["sign", str(out), "--kind", "motor", "--version", "1.0.0", "--key", str(key), "-o", str(tmp_path / "x")], "already signed"),
                      (["sign", "servo", "--version", "1.0.0"], "no module named \"servo\"")]:
        p = run([str(R2P), *args], timeout=30)
        assert p.returncode == 1 and msg in p.stdout, (args, p.stdout)


def test_nodes_lists_the_demo_boards(demo):
    p = r2p(demo, "nodes")
    assert p.returncode == 0, p.stdout
    lines = p.stdout.splitlines()
    assert lines[0].split()[:4] == ["NODE", "NAME", "UNIQUE", "ID"]
    rows = {line.split()[1]: line.split() for line in lines[1:]}
    assert set(rows) == DEMO_NODES, p.stdout
    assert rows["psu"][2] == "000000000000000000000001" and rows["psu"][3] == "running"
    assert all(re.fullmatch(r"\d+s", r[4]) for r in rows.values())
    j = [json.loads(line) for line in r2p(demo, "nodes", "--json").stdout.splitlines()]
    assert {n["name"] for n in j} == DEMO_NODES and all(1 <= n["node"] <= 254 for n in j)


def test_topics_shows_setpoint_and_scan(demo):
    p = r2p(demo, "topics")
    assert p.returncode == 0, p.stdout
    rows = {line.split()[0]: line for line in p.stdout.splitlines()[1:]}
    assert set(rows) == {"scan", "setpoint"}, p.stdout
    assert re.search(r"scan\s+uint32\[4\]\s+16\s+\d+ \(motor\)\s+0x[0-9A-F]{4}\s+SRT deadline 20000 us", rows["scan"])
    assert re.search(r"setpoint\s+uint32\s+4\s+\d+ \(motor\)\s+0x[0-9A-F]{2}01\s+HRT every 2 cycles", rows["setpoint"])
    j = {t["topic"]: t for t in map(json.loads, r2p(demo, "topics", "--json").stdout.splitlines())}
    assert j["scan"]["node_name"] == "motor" and j["scan"]["class"] == {"class": "SRT", "deadline_us": 20000}


def test_echo_scan_prints_the_published_values(demo):
    p = r2p(demo, "echo", "scan", "--count", "5")
    assert p.returncode == 0, p.stdout
    values = [json.loads(line) for line in p.stdout.splitlines()]
    assert len(values) == 5 and all(len(v) == 4 and len(set(v)) == 1 for v in values), p.stdout
    # motor publishes [k, k, k, k] with k counting up every 10 ms; a few may be missed.
    firsts = [v[0] for v in values]
    assert all(0 < b - a <= 10 for a, b in zip(firsts, firsts[1:])), firsts
    j = [json.loads(line) for line in r2p(demo, "echo", "scan", "--count", "2", "--json").stdout.splitlines()]
    assert [set(x) for x in j] == [{"topic", "node", "type", "value"}] * 2 and j[0]["type"] == "uint32[4]"


def test_monitor_decodes_syncs_and_heartbeats(demo):
    p = r2p(demo, "monitor", "--count", "300")
    assert p.returncode == 0, p.stdout
    lines = p.stdout.splitlines()
    assert len(lines) == 300
    syncs = [line for line in lines if " sync cycle=" in line]
    assert syncs and all(" HRT lax=0 " in line and "next cycle reserves slots" in line for line in syncs)
    beats = [line for line in lines if "| HEARTBEAT name=" in line]
    assert {re.search(r"name=(\w+)", line)[1] for line in beats} == DEMO_NODES, "\n".join(beats)
    assert all(" NRT lax=63 " in line and " mgmt " in line for line in beats)
    scans = [line for line in lines if " SRT lax=" in line]
    assert scans and all(re.search(r"SRT lax=\d+\(>=[\d.]+(ms|us)\) msg=[0-9A-F]{2}02 frag=\d+ ", s) for s in scans)

    j = [json.loads(line) for line in r2p(demo, "monitor", "--count", "1200", "--json", "--announce").stdout.splitlines()]
    assert any(f["kind"] == "sync" and f["laxity"] == 0 and "cycle" in f["sync"] for f in j)
    hb = [f["management"] for f in j if f.get("management", {}).get("type") == "HEARTBEAT"]
    assert {h["name"] for h in hb} == DEMO_NODES
    # --announce makes motor advertise again: its topic frames are then named and decoded.
    named = [f for f in j if f.get("topic") == "scan" and "value" in f]
    assert named and all(len(f["value"]) == 4 for f in named)


def test_param_get_on_a_node_without_parameters_reports_the_fault(demo):
    p = r2p(demo, "param", "get", "motor", "0")
    assert p.returncode == 1
    assert re.search(r"r2p: error: node \d+ \(motor\) refused PARAM_GET of parameter 0: unknown parameter index",
                     p.stdout), p.stdout
    p = r2p(demo, "param", "set", "psu", "3", "u32:5")
    assert p.returncode == 1 and "refused PARAM_SET of parameter 3: unknown parameter index" in p.stdout, p.stdout
    p = r2p(demo, "param", "get", "gripper", "0")
    assert p.returncode == 1 and 'unknown node "gripper": no heartbeat from it' in p.stdout, p.stdout
    assert all(n in p.stdout for n in DEMO_NODES)


def test_an_unknown_topic_lists_the_topics_seen(demo):
    p = r2p(demo, "echo", "odometry")
    assert p.returncode == 1
    assert 'unknown topic "odometry": no module advertised it' in p.stdout, p.stdout
    assert re.search(r"topics seen: scan \(node \d+ \(motor\), uint32\[4\]\), setpoint", p.stdout), p.stdout


def test_pub_reaches_an_echo_on_the_bus(demo):
    """Two host nodes through the emulated bus's socketcand server: pub advertises, echo
    subscribes by the advertised type, pub publishes once a subscriber is there."""
    import subprocess
    # Generous bus timeouts: both are real-time processes on a possibly loaded machine (a CI run
    # once saw pub give up after 5 s); a working bus meets them within a second.
    echo = subprocess.Popen([str(R2P), "--socketcand", f"127.0.0.1:{demo.port}", "--timeout", "20", "echo",
                             "wheel", "--count", "1", "--json"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)
    try:
        time.sleep(0.3)
        p = r2p(demo, "pub", "wheel", "--type", "WheelSetpoint", "mode=1", "value=-2.5", "--timeout", "20")
        assert p.returncode == 0, p.stdout
        assert re.search(r"published 1 message\(s\) of type WheelSetpoint on \"wheel\" to node\(s\) \d+", p.stdout), \
            p.stdout
        out, err = echo.communicate(timeout=30)
    finally:
        echo.kill()
    assert echo.returncode == 0, err
    assert json.loads(out) == {"topic": "wheel", "node": json.loads(out)["node"], "type": "WheelSetpoint",
                               "value": {"mode": 1, "value": -2.5}}


def test_malformed_fields_and_types_are_refused_before_sending(demo):
    p = r2p(demo, "pub", "wheel", "--type", "WheelSetpoint", "mode=300")
    assert p.returncode == 1 and "field mode: 300 does not fit uint8 (0 to 255)" in p.stdout, p.stdout
    p = r2p(demo, "pub", "wheel", "--type", "WheelSetpoint", "speed=1")
    assert p.returncode == 1 and 'has no field "speed"; its fields: mode=uint8 value=float32' in p.stdout
    p = r2p(demo, "pub", "wheel", "--type", "Wheel", "1")
    assert p.returncode == 1 and 'unknown type "Wheel"' in p.stdout
    p = r2p(demo, "pub", "nobody_has_this", "1")
    assert p.returncode == 1 and "so its type is unknown: give --type" in p.stdout


def test_an_unreachable_endpoint_is_a_clear_error(built):
    port = free_port()
    p = run([str(R2P), "--socketcand", f"127.0.0.1:{port}", "nodes"], timeout=30)
    assert p.returncode == 1
    assert f"cannot reach socketcand at 127.0.0.1:{port}: connection refused (nothing listens there)" in p.stdout
    assert "r2p-emu demo --realtime --socketcand" in p.stdout
    p = run([str(R2P), "--socketcand", "nowhere", "nodes"], timeout=30)
    assert p.returncode == 1 and "expected HOST:PORT" in p.stdout


def test_a_wrong_channel_is_a_clear_error(demo):
    p = run([str(R2P), "--socketcand", f"127.0.0.1:{demo.port}", "--channel", "can7", "nodes"], timeout=30)
    assert p.returncode == 1 and 'has no bus named "can7"' in p.stdout, p.stdout


def test_traces_decode_offline(trace):
    r = lambda *a: run([str(R2P), "--trace", str(trace), *a], timeout=60)  # noqa: E731
    nodes = r("nodes")
    assert nodes.returncode == 0 and {l.split()[1] for l in nodes.stdout.splitlines()[1:]} == DEMO_NODES
    topics = r("topics")
    assert topics.returncode == 0 and {l.split()[0] for l in topics.stdout.splitlines()[1:]} == {"scan", "setpoint"}
    echo = r("echo", "scan")
    values = [json.loads(line) for line in echo.stdout.splitlines()]
    # Virtual time: motor publishes [k]*4 every 10 ms from 200 ms, control subscribed: all of them.
    assert [v[0] for v in values] == list(range(len(values))) and len(values) >= 70, echo.stdout[-300:]
    mon = r("monitor", "--json")
    frames = [json.loads(line) for line in mon.stdout.splitlines()]
    assert len(frames) == len(trace.read_text().splitlines())
    assert r("echo", "odometry").returncode == 1
    pub = r("pub", "x", "--type", "uint8", "1")
    assert pub.returncode == 1 and "needs a live bus, not the trace" in pub.stdout


def test_candump_and_pcap_convert_both_ways_byte_for_byte(trace, tmp_path):
    pcap, back = tmp_path / "demo.pcap", tmp_path / "back.log"
    assert run([str(R2P), "convert", str(trace), str(pcap)], timeout=60).returncode == 0
    assert run([str(R2P), "convert", str(pcap), str(back)], timeout=60).returncode == 0
    assert back.read_bytes() == trace.read_bytes()
    pcap2 = tmp_path / "again.pcap"
    run([str(R2P), "convert", str(back), str(pcap2)], timeout=60)
    assert pcap2.read_bytes() == pcap.read_bytes(), "the same frames give the same pcap"

    # The pcap layout, record by record, against the candump log (LINKTYPE_CAN_SOCKETCAN).
    data = pcap.read_bytes()
    magic, major, minor, _, _, _, link = struct.unpack("<IHHiIII", data[:24])
    assert (magic, major, minor, link) == (0xA1B2C3D4, 2, 4, 227)
    records, at = [], 24
    while at < len(data):
        secs, usecs, incl, orig = struct.unpack("<IIII", data[at:at + 16])
        can_id, length = struct.unpack(">IB", data[at + 16:at + 21])
        assert incl == orig == 16 and data[at + 21:at + 24] == b"\0\0\0"
        records.append((f"({secs}.{usecs:06d})", can_id, data[at + 24:at + 24 + length]))
        at += 16 + incl
    lines = [line.split() for line in trace.read_text().splitlines()]
    assert len(records) == len(lines)
    for (t, can_id, payload), (lt, _, frame) in zip(records, lines):
        ident, hexdata = frame.split("#")
        assert t == lt and can_id == 0x80000000 | int(ident, 16) and payload == bytes.fromhex(hexdata)


@pytest.mark.skipif(shutil.which("tshark") is None, reason="tshark not installed (scripts/setup installs it)")
def test_tshark_decodes_the_pcap_as_can(trace, tmp_path):
    pcap = tmp_path / "demo.pcap"
    assert run([str(R2P), "convert", str(trace), str(pcap)], timeout=60).returncode == 0
    # AUTOSAR NM's heuristic would claim the frames with ID 0 (syncs of cycle 0): keep every
    # payload as plain data.
    p = run(["tshark", "-r", str(pcap), "--disable-protocol", "autosar-nm", "-T", "fields", "-E", "separator=,",
             "-e", "frame.protocols",
             "-e", "can.id", "-e", "can.flags.xtd", "-e", "can.len", "-e", "data.data"], timeout=120)
    assert p.returncode == 0, p.stdout
    rows = [line.split(",") for line in p.stdout.splitlines() if line.count(",") == 4]
    lines = [line.split()[2].split("#") for line in trace.read_text().splitlines()]
    assert len(rows) == len(lines)
    for (protocols, can_id, xtd, length, data), (ident, hexdata) in zip(rows, lines):
        assert protocols.startswith("can"), protocols
        assert int(can_id) == int(ident, 16) and xtd in ("1", "True")
        assert int(length) == len(hexdata) // 2 and data.upper() == hexdata


def test_replay_puts_a_trace_on_a_bus_in_order_with_its_spacing(built, tmp_path):
    """Into `r2p-canlink serve` (its log records what the hub carried, stamped on arrival)."""
    sent = tmp_path / "sent.log"
    frames = ["1F808003#1100000000000000", "00002280#0600000000000000", "123#01", "0A900080#030000003F"]
    sent.write_text("".join(f"(1700000000.{i * 150_000:06d}) vcan0 {f}\n" for i, f in enumerate(frames)))
    pcap = tmp_path / "sent.pcap"
    run([str(R2P), "convert", str(sent), str(pcap)], timeout=60)
    for source, extra in ((sent, []), (pcap, ["--fast"])):
        log = tmp_path / f"hub-{source.suffix[1:]}.log"
        link = SocketcandProcess([str(CANLINK), "serve", "--log", str(log)], "r2p-canlink")
        try:
            p = run([str(R2P), "--socketcand", f"127.0.0.1:{link.port}", "replay", str(source), *extra], timeout=60)
            assert p.returncode == 0 and f"replayed 4 frames from {source}" in p.stdout, p.stdout
            time.sleep(0.3)
            link.stop()
        finally:
            link.kill()
        got = [line.split() for line in log.read_text().splitlines()]
        assert [g[2] for g in got] == frames
        if not extra:
            # The recorded spacing (150 ms, 450 ms in all) is kept: the replay cannot end sooner.
            # (Arrival stamps at the hub carry the machine's scheduling jitter: not compared.)
            took = float(re.search(r"in ([\d.]+) s", p.stdout)[1])
            assert took >= 0.45, p.stdout


def test_replay_into_the_emulated_bus(built, tmp_path):
    trace = tmp_path / "one.log"
    trace.write_text("(1.000000) vcan0 1FFFFF00#C0FFEE\n(1.001000) vcan0 1FFFFF01#\n")
    emu = SocketcandProcess([str(EMU), "demo", "--realtime"], "r2p-emu")
    try:
        p = run([str(R2P), "--socketcand", f"127.0.0.1:{emu.port}", "replay", str(trace)], timeout=60)
        assert p.returncode == 0, p.stdout
        time.sleep(0.3)
        err = emu.stop()
    finally:
        emu.kill()
    assert re.search(r"2 injected from tools \(2 sent on the virtual bus\)", err), err


def test_the_wrapper_builds_and_runs_r2p():
    p = run([str(ROOT / "scripts" / "r2p"), "--version"], timeout=900)
    assert p.returncode == 0 and p.stdout.strip().startswith("r2p "), p.stdout
