"""Committed pictures regenerate byte for byte (issue 23, item 6): `make bench` on a fresh clone
must not rewrite them, on this machine or another of its kind.

- docs/img/triskar2-trajectory.png is redrawn from a new emulated run (deterministic, virtual
  time); a change to the robot's behaviour that moves the path fails here until the picture is
  regenerated (`scripts/py -c "from r2ptools import bench; bench.plot_trajectory()"`).
- The bench's plots (bench-pubsub-cortex-m3.png, rtcan-load-*.png) are drawn only from the
  numbers committed beside them (bench-pubsub-cortex-m3.json, rtcan-load.json; r2ptools.pictures):
  they are redrawn here from those files, without running the bench (minutes), and compared.
  `make bench` writes numbers and plots together.
- docs/img/bus-voltage-drop.png is drawn from the model in docs/img/bus-voltage-drop.py.
- Every plot opens only matplotlib's own fonts (shipped in the pinned wheel), never a system font
  that may differ between machines.
- The rest is checked where it is made (`test_every_committed_picture_has_a_check`).
"""
from __future__ import annotations

import importlib.util
import subprocess

from pathlib import Path

import pytest

from conftest import ROOT, run

FIRMWARE = ROOT / "firmware"
IMG = ROOT / "docs" / "img"
BUS_VOLTAGE = IMG / "bus-voltage-drop.py"


def test_the_triskar2_trajectory_plot_regenerates_byte_for_byte(tmp_path):
    from r2ptools import bench
    p = run(["cargo", "build", "-q", "-p", "r2p-cli"], cwd=FIRMWARE, timeout=900)
    assert p.returncode == 0, p.stdout
    out = bench.plot_trajectory(out=tmp_path / "t.png", r2p=FIRMWARE / "target" / "debug" / "r2p")
    committed = bench.TRAJECTORY_PLOT.read_bytes()
    assert out.read_bytes() == committed, (
        f"{bench.TRAJECTORY_PLOT.relative_to(ROOT)} is not what the code draws now: regenerate it "
        "(scripts/py -c 'from r2ptools import bench; bench.plot_trajectory()') and commit it")


def bus_voltage():
    """docs/img/bus-voltage-drop.py as a module."""
    spec = importlib.util.spec_from_file_location("bus_voltage_drop", BUS_VOLTAGE)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def draw_pubsub(out: Path) -> list[Path]:
    from r2ptools import bench
    return [bench.redraw_pubsub(out=out / bench.PLOT.name)]


def draw_load(out: Path) -> list[Path]:
    from r2ptools import bench
    return bench.redraw_load(outdir=out)


def draw_bus_voltage(out: Path) -> list[Path]:
    return [bus_voltage().main(out / "bus-voltage-drop.png")]


DRAWN_FROM_COMMITTED_NUMBERS = {
    "bench-pubsub-cortex-m3": draw_pubsub,
    "rtcan-load": draw_load,
    "bus-voltage-drop": draw_bus_voltage,
}


@pytest.mark.parametrize("name", DRAWN_FROM_COMMITTED_NUMBERS)
def test_plot_regenerates_byte_for_byte_from_its_committed_numbers(name, tmp_path, capsys):
    drawn = DRAWN_FROM_COMMITTED_NUMBERS[name](tmp_path)
    assert drawn
    for png in drawn:
        committed = IMG / png.name
        assert png.read_bytes() == committed.read_bytes(), (
            f"docs/img/{png.name} is not what its numbers draw: make bench writes both (or "
            "scripts/py -c 'from r2ptools import bench; bench.redraw_pubsub(); bench.redraw_load()', "
            "scripts/py docs/img/bus-voltage-drop.py); commit them together")
        assert b"tEXt" not in committed.read_bytes() and b"tIME" not in committed.read_bytes()


@pytest.mark.parametrize("data", ["bench-pubsub-cortex-m3.json", "rtcan-load.json"])
def test_a_data_file_is_what_writing_its_numbers_gives(data, tmp_path):
    """The committed numbers are rounded and laid out as `make bench` writes them: read, written
    again, the same bytes (a hand-edited or unrounded file fails); and the plot drawn from
    what was read back is the committed one."""
    from r2ptools import bench, pictures
    path = IMG / data
    read = pictures.read_data(path)
    generated_by = read.pop("generated_by")
    assert generated_by.startswith("make bench") and generated_by.endswith("do not edit")
    assert pictures.dumps(generated_by, read) == path.read_text(encoding="utf-8")
    if data == "rtcan-load.json":
        again = bench.write_load(read["points"], tmp_path / data)
        assert read["points"] and all(pt["reports"] for pt in read["points"])
        assert not {"wall_s", "events_per_s"} & set(read["points"][0]), "no wall-clock numbers"
    else:
        again = bench.write_pubsub(read["rows"], tmp_path / data)
        assert [r["subscribers"] for r in read["rows"]] == list(range(1, 9))
    assert again.read_bytes() == path.read_bytes()


def test_a_changed_number_changes_the_plot(tmp_path):
    from r2ptools import bench, pictures
    data = pictures.read_data(bench.PLOT_DATA)
    data["rows"][0]["r2p_insn_per_msg"] += 40
    changed = pictures.write_data(tmp_path / "x.json", data.pop("generated_by"), data)
    out = bench.redraw_pubsub(changed, tmp_path / "x.png")
    assert out.read_bytes() != bench.PLOT.read_bytes()


def test_plots_open_only_matplotlibs_own_fonts(tmp_path, monkeypatch, capsys):
    """Text and mathtext (the log axes' 10^n labels) alike: the files must be the pinned
    matplotlib wheel's, whatever fonts the machine has."""
    import matplotlib
    import matplotlib._mathtext as mathtext
    import matplotlib.backends.backend_agg as agg
    opened = []

    def recording(real):
        def get_font(paths, *args, **kwargs):
            opened.extend([paths] if isinstance(paths, (str, Path)) else paths)
            return real(paths, *args, **kwargs)
        return get_font
    monkeypatch.setattr(agg, "get_font", recording(agg.get_font))
    monkeypatch.setattr(mathtext, "get_font", recording(mathtext.get_font))
    for name, draw in DRAWN_FROM_COMMITTED_NUMBERS.items():
        draw(tmp_path / name)
    own = Path(matplotlib.get_data_path()).resolve()
    files = {Path(p).resolve() for p in opened}
    assert any(f.name == "DejaVuSans.ttf" for f in files), files
    assert all(own in f.parents for f in files), sorted(str(f) for f in files if own not in f.parents)


def test_a_plot_does_not_depend_on_what_was_set_before_it(tmp_path, capsys):
    """Neither the user's matplotlibrc nor an earlier plot in the same process (the bus-voltage
    script sets its own font size) changes what a plot draws."""
    import matplotlib
    from r2ptools import bench
    def settings():
        return {k: v for k, v in matplotlib.rcParams.items() if not k.startswith("backend")}
    before = settings()
    draw_bus_voltage(tmp_path)
    assert settings() == before, "a plot's settings leak out of it"
    with matplotlib.rc_context({"font.size": 17, "lines.linewidth": 4, "axes.grid": True}):
        out = bench.redraw_pubsub(out=tmp_path / "p.png")
    assert out.read_bytes() == bench.PLOT.read_bytes()


def test_numbers_are_rounded_and_bad_data_files_say_what_to_do(tmp_path):
    from r2ptools import pictures
    assert pictures.rounded({"a": [0.1000088, 1 / 3, 2, True, None, "x"], "b": (1e-9 / 3,)}) == \
        {"a": [0.100009, 0.333333, 2, True, None, "x"], "b": [3.33333e-10]}
    for bad in (float("nan"), float("inf")):
        with pytest.raises(ValueError, match="not a number a data file can hold"):
            pictures.rounded([bad])
    with pytest.raises(TypeError):
        pictures.rounded({"a": object()})
    with pytest.raises(ValueError, match="own key"):
        pictures.dumps("me", {"generated_by": "someone else"})
    with pytest.raises(ValueError, match=r"missing\.json: .*regenerate it with make bench"):
        pictures.read_data(tmp_path / "missing.json")
    (tmp_path / "bad.json").write_text("{not json")
    with pytest.raises(ValueError, match=r"bad\.json: .*regenerate it with make bench"):
        pictures.read_data(tmp_path / "bad.json")
    (tmp_path / "list.json").write_text("[1, 2]")
    with pytest.raises(ValueError, match="no generated_by"):
        pictures.read_data(tmp_path / "list.json")


# Every committed picture and the test that regenerates it (or, where a renderer cannot be made
# deterministic, compares what it shows).
CHECKED_BY = {
    "docs/img/triskar2-trajectory.png": "test_pictures.py (a new emulated run, bytes)",
    "docs/img/bench-pubsub-cortex-m3.png": "test_pictures.py (from its .json, bytes)",
    "docs/img/rtcan-load-srt-miss.png": "test_pictures.py (from rtcan-load.json, bytes)",
    "docs/img/rtcan-load-latency.png": "test_pictures.py (from rtcan-load.json, bytes)",
    "docs/img/rtcan-load-hrt-jitter.png": "test_pictures.py (from rtcan-load.json, bytes)",
    "docs/img/rtcan-load-carried.png": "test_pictures.py (from rtcan-load.json, bytes)",
    "docs/img/rtcan-load-layout.png": "test_pictures.py (from rtcan-load.json, bytes)",
    "docs/img/bus-voltage-drop.png": "test_pictures.py (from its script's model, bytes)",
    "docs/img/r2p-ui.png": "test_ui.py (live values: what the page shows, docs/img/r2p-ui.json)",
    "hardware/*/fab/*": "test_hardware.py::test_fab_package_is_current_and_byte_identical (renders, "
                        "schematic PNG and PDFs with the whole fab package, bytes)",
    "enclosures/*/*.png": "test_enclosures.py::test_module_case_regenerates_byte_for_byte (OpenSCAD "
                          "preview, bytes)",
}
PICTURE = (".png", ".jpg", ".jpeg", ".gif", ".svg", ".webp", ".pdf")


def test_every_committed_picture_has_a_check():
    p = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, check=True)
    files = [f for f in p.stdout.decode().split("\0") if f.lower().endswith(PICTURE)]
    assert "docs/img/r2p-ui.png" in files
    unchecked = [f for f in files if not any(Path(f).match(pattern) for pattern in CHECKED_BY)]
    assert not unchecked, (f"committed pictures no test regenerates: {unchecked}; add a check and "
                           "list it in CHECKED_BY")
