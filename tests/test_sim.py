"""`r2p sim`: a robot file on emulated boards, in virtual time (deterministic traces) and in real
time with CAN tools joined over socketcand (python-can and the r2p CLI itself)."""
from __future__ import annotations

import json
import math
import time

import pytest

from conftest import ROOT, SocketcandProcess, run

FIRMWARE = ROOT / "firmware"
R2P = FIRMWARE / "target" / "debug" / "r2p"
TRISKAR2 = ROOT / "robots" / "triskar2.toml"
BOARDS = {"psu", "motor1", "motor2", "motor3", "proximity", "gateway"}


@pytest.fixture(scope="module")
def built() -> None:
    p = run(["cargo", "build", "-q", "-p", "r2p-cli"], cwd=FIRMWARE, timeout=900)
    assert p.returncode == 0, p.stdout


@pytest.fixture(scope="module")
def robot(built):
    sim = SocketcandProcess([str(R2P), "sim", str(TRISKAR2), "--realtime"], "r2p sim")
    try:
        yield sim
    finally:
        sim.kill()


def r2p(sim, *args: str):
    return run([str(R2P), "--socketcand", f"127.0.0.1:{sim.port}", "--timeout", "2", *args], timeout=60)


def test_virtual_time_runs_write_identical_traces(built, tmp_path):
    outs = []
    for name in ("a.pcap", "b.pcap"):
        p = run([str(R2P), "sim", str(TRISKAR2), "--seconds", "3", "--log", str(tmp_path / name)], timeout=120)
        assert p.returncode == 0, p.stdout
        assert "3.0 s of virtual time" in p.stdout and "frames written" in p.stdout
        outs.append((tmp_path / name).read_bytes())
    assert outs[0] == outs[1], "same robot file, same seed: the same trace byte for byte"
    assert len(outs[0]) > 24 + 1000 * 32, "a pcap of more than a thousand frames"
    log = tmp_path / "c.log"
    p = run([str(R2P), "sim", str(TRISKAR2), "--seconds", "1", "--seed", "7", "--log", str(log)], timeout=120)
    assert p.returncode == 0 and log.read_text().startswith("(1700000000."), p.stdout


def test_timing_measures_the_cycle_in_a_trace(built, tmp_path):
    """`r2p --trace FILE timing` on the emulated Triskar2's trace: the syncs' period and where
    each HRT stream starts in its cycle, from the frames' end stamps and their exact lengths.
    On the emulator every HRT frame starts 2 µs after its slot (the emulated path against the
    lead) and every cycle is 10 ms long, to the trace's µs."""
    log = tmp_path / "t.log"
    p = run([str(R2P), "sim", str(TRISKAR2), "--seconds", "3", "--log", str(log)], timeout=120)
    assert p.returncode == 0, p.stdout
    p = run([str(R2P), "--trace", str(log), "--json", "timing"], timeout=60)
    assert p.returncode == 0, p.stdout
    t = json.loads(p.stdout.splitlines()[-1])
    assert t["syncs"] >= 290 and t["gaps"] == 0 and t["median_period_us"] == 10_000.0, t
    assert t["period"]["min_us"] >= 9_999.0 and t["period"]["max_us"] <= 10_001.0, t
    slot_us = 10_000 / 60  # the Triskar2's cycle: 10 ms, 60 slots
    assert len(t["hrt"]) == 3, t  # the three wheels' setpoints
    for s in t["hrt"]:
        o = s["offset"]
        assert o["n"] >= 250 and o["min_us"] == o["max_us"], s
        late = o["min_us"] - math.ceil(round(o["min_us"] / slot_us) * slot_us)
        assert 0 <= late <= 2, s
    text = run([str(R2P), "--trace", str(log), "timing"], timeout=60).stdout
    assert "one every 10000.0 µs (median)" in text and "HRT 0x7F02 frame 0:" in text, text
    # Without a trace it says what it needs.
    p = run([str(R2P), "timing"], timeout=60)
    assert p.returncode != 0 and "give one with --trace FILE" in p.stdout, p.stdout


def test_python_can_sees_the_robot_within_a_second(robot):
    bus = robot.bus()
    try:
        t0 = time.monotonic()
        frames = []
        while time.monotonic() - t0 < 1.0:
            m = bus.recv(timeout=0.2)
            if m is not None:
                frames.append(m)
        assert len(frames) > 200, f"{len(frames)} frames in a second"
        assert all(m.is_extended_id for m in frames)
    finally:
        bus.shutdown()


def test_r2p_lists_the_robots_boards_and_topics(robot):
    p = r2p(robot, "nodes")
    assert p.returncode == 0, p.stdout
    assert BOARDS <= set(p.stdout.split()), p.stdout
    p = r2p(robot, "topics")
    assert p.returncode == 0, p.stdout
    for topic in ("psu/battery", "motor1/state", "motor3/setpoint", "proximity/ranges", "odom"):
        assert topic in p.stdout, (topic, p.stdout)


def test_r2p_echoes_a_motors_state_and_reads_a_parameter(robot):
    p = r2p(robot, "echo", "motor2/state", "--count", "3")
    assert p.returncode == 0, p.stdout
    assert p.stdout.count("speed") >= 3, p.stdout
    p = r2p(robot, "param", "get", "motor2", "0")
    assert p.returncode == 0, p.stdout
    assert "2" in p.stdout, "motor2's instance parameter is 2: " + p.stdout


def test_a_missing_robot_file_is_a_clear_error(built, tmp_path):
    p = run([str(R2P), "sim", str(tmp_path / "nope.toml"), "--seconds", "1", "--log", str(tmp_path / "x.log")],
            timeout=60)
    assert p.returncode != 0
    assert "nope.toml" in p.stdout and "Traceback" not in p.stdout


DIFFBOT = ROOT / "robots" / "diffbot.toml"


def test_diffbot_runs_deterministically_and_python_tools_read_its_imu(built, tmp_path):
    # The second robot file: PSU, two motors and the IMU module (an SPI sensor on an emulated
    # board). Same file, same trace; and its `imu` topic decodes over socketcand.
    outs = []
    for name in ("a.pcap", "b.pcap"):
        p = run([str(R2P), "sim", str(DIFFBOT), "--seconds", "2", "--log", str(tmp_path / name)], timeout=120)
        assert p.returncode == 0 and "diffbot: 2.0 s of virtual time" in p.stdout, p.stdout
        outs.append((tmp_path / name).read_bytes())
    assert outs[0] == outs[1]
    sim = SocketcandProcess([str(R2P), "sim", str(DIFFBOT), "--realtime"], "r2p sim")
    try:
        p = r2p(sim, "echo", "imu", "--count", "2")
        assert p.returncode == 0, p.stdout
        lines = [l for l in p.stdout.splitlines() if l.startswith("rate=")]
        assert len(lines) == 2 and all("yaw=" in l and "accel=" in l for l in lines), p.stdout
        # At rest, z up: the accelerometer reads ~g on z (the device's ±20 mg offset aside).
        az = float(lines[-1].split("accel=[")[1].split("]")[0].split(",")[2])
        assert abs(az - 9.81) < 0.3, lines[-1]
    finally:
        sim.kill()
