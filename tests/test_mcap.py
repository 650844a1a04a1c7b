"""MCAP recordings (issue 23): `r2p sim ROBOT --seconds N --log x.mcap` and `r2p record` write
the bus's topics decoded, one channel per topic with its type's JSON Schema, read back here by
the format authors' Python reader (PyPI `mcap`), independent of the CLI's Rust writer."""
from __future__ import annotations

import json

import pytest
from mcap.reader import make_reader

from conftest import ROOT, SocketcandProcess, run

FIRMWARE = ROOT / "firmware"
R2P = FIRMWARE / "target" / "debug" / "r2p"
TRISKAR2 = ROOT / "robots" / "triskar2.toml"


@pytest.fixture(scope="module")
def built() -> None:
    p = run(["cargo", "build", "-q", "-p", "r2p-cli"], cwd=FIRMWARE, timeout=900)
    assert p.returncode == 0, p.stdout


def read(path):
    """(summary, [(topic, schema, log_time, sequence, value)]) of an MCAP file."""
    with open(path, "rb") as f:
        r = make_reader(f)
        summary = r.get_summary()
        rows = [(c.topic, s, m.log_time, m.sequence, json.loads(m.data))
                for s, c, m in r.iter_messages(log_time_order=False)]
    return summary, rows


@pytest.fixture(scope="module")
def triskar2(built, tmp_path_factory):
    """Triskar2's first 3 s recorded by `r2p sim` as MCAP, and the same run as pcap."""
    d = tmp_path_factory.mktemp("mcap")
    for name in ("run.mcap", "again.mcap", "run.pcap"):
        p = run([str(R2P), "sim", str(TRISKAR2), "--seconds", "3", "--log", str(d / name)], timeout=120)
        assert p.returncode == 0, p.stdout
    return d


def test_a_sim_run_is_recorded_one_channel_per_topic_with_its_types_schema(triskar2):
    summary, rows = read(triskar2 / "run.mcap")
    channels = {c.topic: c for c in summary.channels.values()}
    # The topics that cross Triskar2's bus: the wheels' setpoints (HRT) and states, the
    # ranges and the obstacle event, the battery and the supply's state.
    for n in (1, 2, 3):
        assert f"motor{n}/setpoint" in channels and f"motor{n}/state" in channels, sorted(channels)
    assert {"proximity/ranges", "proximity/obstacle", "psu/battery"} <= set(channels)
    for c in channels.values():
        schema = summary.schemas[c.schema_id]
        assert (c.message_encoding, schema.encoding) == ("json", "jsonschema")
        assert c.metadata["r2p_type_hash"].startswith("0x")
    setpoint = channels["motor1/setpoint"]
    assert setpoint.metadata["r2p_class"].startswith("HRT")
    assert summary.schemas[setpoint.schema_id].name == "WheelSetpoint"

    by_topic: dict[str, list] = {}
    for topic, schema, t, seq, value in rows:
        by_topic.setdefault(topic, []).append((t, seq, value))
        # Every message is an object with exactly its schema's fields, of their JSON types.
        props = json.loads(schema.data)["properties"]
        assert set(value) == set(props), (topic, value, props)
        for k, v in value.items():
            want = props[k]["type"]
            kinds = {"integer": int, "boolean": bool, "array": list}
            if want == "integer":
                assert isinstance(v, int) and not isinstance(v, bool), (topic, k, v)
            elif isinstance(want, list):
                assert isinstance(v, (int, float, str)), (topic, k, v)
            else:
                assert isinstance(v, kinds[want]), (topic, k, v)
    # Sequence numbers count each channel's messages, log times rise on it.
    for topic, msgs in by_topic.items():
        assert [s for _, s, _ in msgs] == list(range(len(msgs))), topic
        assert all(a[0] < b[0] for a, b in zip(msgs, msgs[1:])), topic
    # A setpoint every 10 ms cycle from its grant on (measured: the first at about 0.5 s).
    sp = by_topic["motor1/setpoint"]
    assert 200 <= len(sp) <= 300, len(sp)
    # (The frame's start on the bus: the slot grid, within the slaves' clock corrections.)
    gaps = [b[0] - a[0] for a, b in zip(sp, sp[1:])]
    assert all(abs(g - 10_000_000) <= 10_000 for g in gaps), (min(gaps), max(gaps))
    assert all(v["mode"] == 1 for _, _, v in sp), "velocity mode"
    # The battery as the robot file's pack says: 12 lead-acid cells, full (2.1-2.15 V each).
    volts = [v for _, _, v in by_topic["psu/battery"]]
    assert volts and all(25.0 < b["voltage"] < 25.9 for b in volts), volts[:3]


def test_recordings_of_the_emulated_robot_are_reproducible_byte_for_byte(triskar2):
    assert (triskar2 / "run.mcap").read_bytes() == (triskar2 / "again.mcap").read_bytes()


def test_record_over_a_trace_gives_the_sims_messages(triskar2):
    out = triskar2 / "from-trace.mcap"
    p = run([str(R2P), "--trace", str(triskar2 / "run.pcap"), "record", str(out), "--passive", "--json"],
            timeout=120)
    assert p.returncode == 0, p.stdout
    stats = json.loads(p.stdout.strip().splitlines()[-1])
    assert stats["messages"] > 1000 and stats["undecodable"] == 0, stats
    _, sim = read(triskar2 / "run.mcap")
    _, rec = read(out)
    # The pcap keeps microseconds: the same topics and values, in the same order per topic.
    assert [(r[0], r[4]) for r in rec] == [(r[0], r[4]) for r in sim]
    assert [r[2] // 1000 for r in rec] == [r[2] // 1000 for r in sim]


def test_record_on_a_live_robot(built, tmp_path):
    sim = SocketcandProcess([str(R2P), "sim", str(TRISKAR2), "--realtime"], "r2p sim")
    try:
        out = tmp_path / "live.mcap"
        p = run([str(R2P), "--socketcand", f"127.0.0.1:{sim.port}", "--timeout", "2", "record",
                 str(out), "--seconds", "3"], timeout=60)
        assert p.returncode == 0, p.stdout
        summary, rows = read(out)
        topics = {c.topic for c in summary.channels.values()}
        assert "motor1/setpoint" in topics, topics
        assert sum(1 for r in rows if r[0] == "motor1/setpoint") > 100
    finally:
        sim.kill()


def test_bad_requests_are_refused_with_what_to_do_instead(built, tmp_path):
    p = run([str(R2P), "--trace", "/dev/null", "record", str(tmp_path / "x.pcap")], timeout=60)
    assert p.returncode != 0 and "writes MCAP; name the file FILE.mcap" in p.stdout, p.stdout
    assert not (tmp_path / "x.pcap").exists()
    p = run([str(R2P), "sim", str(TRISKAR2), "--realtime", "--log", str(tmp_path / "y.mcap")], timeout=60)
    assert p.returncode != 0 and "r2p record FILE.mcap" in p.stdout, p.stdout
