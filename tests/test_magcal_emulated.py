"""`r2p imu calibrate` end to end (issue 21): the emulated Diffbot (`r2p sim --realtime`) with a
deliberately distorted field at its IMU (the robot file's `hard_iron_ut` and `soft_iron`, plus the
emulated LIS3MDL's own zero-gauss offset). Standing still, the calibration is refused and nothing
is written; spinning on the spot under `r2p pub` wheel setpoints, it picks the planar fit, finds
the soft iron's inverse, writes the module's parameters and turns its magnetic heading on, and
the field the module then publishes over a turn is a circle about the origin."""
from __future__ import annotations

import json
import math
import subprocess

import pytest

from conftest import ROOT, SocketcandProcess, run

FIRMWARE = ROOT / "firmware"
R2P = FIRMWARE / "target" / "debug" / "r2p"
HARD_IRON = [18.0, -11.0, 25.0]
SOFT_IRON = [[1.15, 0.06, 0.0], [0.06, 0.88, 0.0], [0.0, 0.0, 1.0]]
MAG_OFFSET_X, MAG_HEADING = 12, 21  # r2p-app-imu's parameter indices


@pytest.fixture(scope="module")
def robot(tmp_path_factory):
    p = run(["cargo", "build", "-q", "-p", "r2p-cli"], cwd=FIRMWARE, timeout=900)
    assert p.returncode == 0, p.stdout
    text = (ROOT / "robots" / "diffbot.toml").read_text()
    anchor = 'kind = "imu"\n'
    assert anchor in text
    iron = f"hard_iron_ut = {HARD_IRON}\nsoft_iron = {SOFT_IRON}\n"
    path = tmp_path_factory.mktemp("robot") / "diffbot-iron.toml"
    path.write_text(text.replace(anchor, anchor + iron, 1))
    sim = SocketcandProcess([str(R2P), "sim", str(path), "--realtime"], "r2p sim")
    try:
        yield sim
    finally:
        sim.kill()


def r2p(sim, *args: str, timeout: float = 120):
    return run([str(R2P), "--socketcand", f"127.0.0.1:{sim.port}", "--timeout", "2", *args], timeout=timeout)


def test_standing_still_is_refused_then_spinning_calibrates(robot):
    # Standing still: one heading, refused, nothing written.
    p = r2p(robot, "imu", "calibrate", "--seconds", "6")
    assert p.returncode == 1, p.stdout
    assert "r2p: error: not calibrated: " in p.stdout, p.stdout
    assert "Nothing was written: the module keeps its calibration" in p.stdout, p.stdout
    p = r2p(robot, "param", "get", "imu", str(MAG_OFFSET_X))
    assert p.returncode == 0 and p.stdout.strip() == "f32:0.0", p.stdout

    # Spinning on the spot: the wheels at ∓3 rad/s, refreshed at 50 Hz.
    wheels = [subprocess.Popen(
        [str(R2P), "--socketcand", f"127.0.0.1:{robot.port}", "pub", f"motor{n}/setpoint",
         "--type", "WheelSetpoint", "mode=1", f"value={v}", "--rate", "50"],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL) for n, v in ((1, -3), (2, 3))]
    try:
        p = r2p(robot, "imu", "calibrate", "--seconds", "12", "--json")
        assert p.returncode == 0, p.stdout
        fit = json.loads(p.stdout.strip().splitlines()[-1])
        assert fit["kind"] == "planar" and fit["written"], fit
        assert fit["heading_sectors"] >= 27 and fit["rms_percent"] < 3.0, fit
        # S's x/y block is the soft iron's inverse, scaled to determinant 1.
        (a, b), (_, c) = SOFT_IRON[0][:2], SOFT_IRON[1][:2]
        det = a * c - b * b
        inv = [[c / det, -b / det], [-b / det, a / det]]
        k = 1 / math.sqrt(1 / det)
        want = {"mag_soft_xx": inv[0][0] * k, "mag_soft_xy": inv[0][1] * k, "mag_soft_yy": inv[1][1] * k}
        for name, value in want.items():
            assert abs(fit["params"][name] - value) < 0.01, (name, fit["params"][name], value)
        assert fit["params"]["mag_heading"] == 1, fit
        p = r2p(robot, "param", "get", "imu", str(MAG_HEADING))
        assert p.returncode == 0 and p.stdout.strip() == "u32:1", p.stdout

        # The field the module publishes now: its horizontal part is round about the origin,
        # where the raw one is an offset ellipse.
        p = r2p(robot, "echo", "imu/mag", "--count", "80", "--json")
        assert p.returncode == 0, p.stdout
        values = [json.loads(line)["value"] for line in p.stdout.splitlines()]
        field = [math.hypot(*v["field"][:2]) for v in values]
        raw = [math.hypot(*v["raw"][:2]) for v in values]
        assert max(raw) - min(raw) > 20, (min(raw), max(raw))
        assert max(field) - min(field) < 3.0, (min(field), max(field))
    finally:
        for w in wheels:
            w.kill()
            w.wait(timeout=10)
