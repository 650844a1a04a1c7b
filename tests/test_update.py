"""`r2p update` on the emulated Triskar2 in real time, over socketcand as on a real robot's bus
(issue 18 item 3): a signed image reaches a motor module with a progress bar, the module swaps it
in and confirms it, and `r2p nodes` shows the new version; images the module or the CLI refuse
say why and leave the module on its image. The same through the gateway's own network endpoint
(its application's socketcand server, `r2p sim --gateway`), as a robot is reached over Ethernet."""
from __future__ import annotations

import re
from pathlib import Path

import pytest

from conftest import ROOT, SocketcandProcess, free_port, run

FIRMWARE = ROOT / "firmware"
R2P = FIRMWARE / "target" / "debug" / "r2p"
TRISKAR2 = ROOT / "robots" / "triskar2.toml"


@pytest.fixture(scope="module")
def robot():
    p = run(["cargo", "build", "-q", "-p", "r2p-cli"], cwd=FIRMWARE, timeout=900)
    assert p.returncode == 0, p.stdout
    gateway = free_port()
    sim = SocketcandProcess([str(R2P), "sim", str(TRISKAR2), "--realtime", "--gateway", f"127.0.0.1:{gateway}"],
                            "r2p sim")
    sim.gateway = gateway
    try:
        yield sim
    finally:
        sim.kill()


def r2p(sim, *args: str, timeout: float = 120, port: int | None = None):
    port = port or sim.port
    return run([str(R2P), "--socketcand", f"127.0.0.1:{port}", "--timeout", "2", *args], timeout=timeout)


def signed(tmp_path, module_image: str | Path, kind: str, version: str):
    """The committed image `module_image` (or the file at that path) signed (development key) as
    `kind` `version`."""
    out = tmp_path / f"{kind}-{version}.bin"
    image = module_image if isinstance(module_image, Path) else FIRMWARE / "images" / f"{module_image}.bin"
    p = run([str(R2P), "sign", str(image), "--kind", kind, "--version", version, "-o", str(out)])
    assert p.returncode == 0, p.stdout
    digest = re.search(r"digest ([0-9a-f]{16})", p.stdout).group(1)
    return out, digest


def firmware_of(sim, name: str, port: int | None = None) -> str:
    p = r2p(sim, "nodes", port=port)
    assert p.returncode == 0, p.stdout
    row = next(line for line in p.stdout.splitlines() if f" {name} " in line)
    return row


def test_a_motor_module_is_updated_over_the_bus_and_runs_the_new_image(robot, tmp_path):
    assert "0.1.0" in firmware_of(robot, "motor2"), "flashed with the factory image"
    # The template's image fits a slot; signed for a motor module it stands for a motor update.
    image, digest = signed(tmp_path, "template", "motor", "1.4.0")
    p = r2p(robot, "update", "motor2", str(image), timeout=180)
    assert p.returncode == 0, p.stdout
    assert re.search(r"\[#+\.*\] +\d+ % .* KiB/s, .* left", p.stdout), "a progress bar: " + p.stdout
    assert "verified and marked" in p.stdout, p.stdout
    assert re.search(rf"0\.1\.0 [0-9a-f]{{16}} -> 1\.4\.0 {digest}: running, confirmed", p.stdout), \
        "what it ran before, then what it runs: " + p.stdout
    row = firmware_of(robot, "motor2")
    assert f"1.4.0 {digest}" in row and "on trial" not in row, row
    assert "0.1.0" in firmware_of(robot, "motor3"), "only the module named was updated"


def test_refused_images_say_why_and_the_module_keeps_its_image(robot, tmp_path):
    before = firmware_of(robot, "motor1")
    # The motor's image grown by 1 KB of code past its end: more than a 56 192 B slot holds.
    grown = tmp_path / "grown.bin"
    grown.write_bytes((FIRMWARE / "images" / "motor.bin").read_bytes() + bytes(range(256)) * 4 * 4)
    assert grown.stat().st_size > 56_192
    big, _ = signed(tmp_path, grown, "motor", "2.0.0")
    p = r2p(robot, "update", "motor1", str(big))
    assert p.returncode != 0
    assert "refused" in p.stdout and "larger than the module's image slot" in p.stdout, p.stdout
    assert "it keeps running its image" in p.stdout, p.stdout
    unsigned = FIRMWARE / "images" / "template.bin"
    p = r2p(robot, "update", "motor1", str(unsigned))
    assert p.returncode != 0 and "not a signed R2P image" in p.stdout, p.stdout
    p = r2p(robot, "update", "--all", str(unsigned), "motor1")
    assert p.returncode != 0 and "with --all give only IMAGE" in p.stdout, p.stdout
    assert firmware_of(robot, "motor1").split()[8:10] == before.split()[8:10], "unchanged"


def test_a_motor_module_is_updated_through_the_gateway(robot, tmp_path):
    image, digest = signed(tmp_path, "motor", "motor", "1.5.0")
    p = r2p(robot, "update", "motor1", str(image), timeout=180, port=robot.gateway)
    assert p.returncode == 0, p.stdout
    assert f"-> 1.5.0 {digest}: running, confirmed" in p.stdout, p.stdout
    row = firmware_of(robot, "motor1", port=robot.gateway)
    assert f"1.5.0 {digest}" in row and "on trial" not in row, row


def test_the_gateway_is_updated_through_its_own_endpoint(robot, tmp_path):
    # The template's image signed for the gateway (its F407) stands for a gateway update. Its reset
    # closes the connection the CLI came through: the CLI connects again and sees it confirm.
    image, digest = signed(tmp_path, "template", "gateway", "1.6.0")
    p = r2p(robot, "update", "gateway", str(image), timeout=240, port=robot.gateway)
    assert p.returncode == 0, p.stdout
    assert "the link went down with it; connecting again" in p.stdout, p.stdout
    assert f"-> 1.6.0 {digest}: running, confirmed" in p.stdout, p.stdout
    assert f"1.6.0 {digest}" in firmware_of(robot, "gateway", port=robot.gateway)
