"""Committed pictures regenerate byte for byte (issue 23, item 6): `make bench` on a fresh clone
must not rewrite them. The trajectory plot is redrawn here from a new emulated run and compared
with the committed file; a change to the robot's behaviour that moves the path fails this test
until the picture is regenerated (`scripts/bench`, or `scripts/py -c "from r2ptools import bench;
bench.plot_trajectory()"`)."""
from __future__ import annotations

from conftest import ROOT, run

FIRMWARE = ROOT / "firmware"


def test_the_triskar2_trajectory_plot_regenerates_byte_for_byte(tmp_path):
    from r2ptools import bench
    p = run(["cargo", "build", "-q", "-p", "r2p-cli"], cwd=FIRMWARE, timeout=900)
    assert p.returncode == 0, p.stdout
    out = bench.plot_trajectory(out=tmp_path / "t.png", r2p=FIRMWARE / "target" / "debug" / "r2p")
    committed = bench.TRAJECTORY_PLOT.read_bytes()
    assert out.read_bytes() == committed, (
        f"{bench.TRAJECTORY_PLOT.relative_to(ROOT)} is not what the code draws now: regenerate it "
        "(scripts/py -c 'from r2ptools import bench; bench.plot_trajectory()') and commit it")
