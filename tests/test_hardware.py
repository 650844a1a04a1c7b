"""The boards under hardware/: what a maker relies on before sending one to a fab.

Every board with a KiCad project passes ERC (0 errors, no drawing faults), DRC against the
JLCPCB capability (0 errors, no warnings, 0 unconnected items), schematic parity, and the
parts-database check; its MCU pins carry the signals of its firmware board file; its fab package
regenerates from the KiCad files byte for byte. The KiCad files are the source: a board edited by
hand passes, and scripts/hwgen only scaffolds new boards. The last tests break a scratch copy on
purpose and see each check fail, so the checks cannot pass vacuously.
"""
from __future__ import annotations

import filecmp
import re
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

from conftest import ROOT

# KiCad is part of the kit's tooling (scripts/setup installs it): without it these checks fail,
# they do not skip.
if shutil.which("kicad-cli") is None:
    pytest.fail("kicad-cli is not installed: run scripts/setup (installs KiCad 9)", pytrace=False)

from r2ptools.kicad import catalog, check, fab, libsym, netlist  # noqa: E402
from r2ptools import manifest  # noqa: E402

HARDWARE = ROOT / "hardware"
BOARDS = check.boards()

def test_the_expected_boards_exist():
    assert {b.name for b in BOARDS} >= {"proximity", "psu", "template"}


@pytest.mark.parametrize("board", BOARDS, ids=lambda b: b.name)
def test_board_passes_erc_drc_parity_and_bom(board):
    r = check.check(board)
    assert r.ok, "\n".join(r.problems)


def _board_mcu(module: str) -> str:
    """The MCU part of firmware/boards/<module>.toml (or of the file it extends)."""
    d = tomllib.loads((ROOT / "firmware" / "boards" / f"{module}.toml").read_text())["board"]
    return d["mcu"] if "mcu" in d else _board_mcu(d["extends"].removesuffix(".toml"))


def _board_file(module: str) -> dict[str, str]:
    """pin -> signal from firmware/boards/<module>.toml and the file it extends."""
    path = ROOT / "firmware" / "boards" / f"{module}.toml"
    d = tomllib.loads(path.read_text())
    pins = {}
    if "extends" in d.get("board", {}):
        pins.update(_board_file(d["board"]["extends"].removesuffix(".toml")))
    pins.update({p: v["signal"] for p, v in d.get("pins", {}).items()})
    return pins


@pytest.mark.parametrize("module", [m.name for m in manifest.load(check_tree=False)
                                    if m.board_file and (HARDWARE / m.name / f"{m.name}.kicad_sch").is_file()])
def test_mcu_pins_carry_the_board_file_signals(module):
    net = netlist.export(HARDWARE / module / f"{module}.kicad_sch")
    pad_names = {p.number: p.name for p in libsym.pins(catalog.item(_board_mcu(module)).symbol)}
    wanted = _board_file(module)
    seen = {}
    for name, nodes in net.nets.items():
        for ref, pin in nodes:
            if ref == "U1":
                seen[pad_names[pin]] = (name, len(nodes))
    for pin, signal in wanted.items():
        assert seen[pin][0].rsplit("/", 1)[-1] == signal, f"{module}: {pin} is on {seen[pin][0]}, not {signal}"
    for pin, (name, nodes) in seen.items():
        if pin not in wanted and not pin.startswith(("V", "NRST", "BOOT0")):
            assert nodes == 1, f"{module}: {pin} is wired ({name}) but the board file does not use it"


def _scaffold_scratch(tmp_path: Path) -> Path:
    """A scratch hardware/ without the template board (its route cache kept), and a core sheet
    that has never heard of it: as a new module finds them."""
    from r2ptools.kicad import sch_gen, sexpr
    out = tmp_path / "hardware"
    shutil.copytree(HARDWARE, out, ignore=shutil.ignore_patterns("fab"))
    for f in (out / "template").iterdir():
        if f.name not in ("route.ses", "route.key"):
            f.unlink()
    core_sch = out / "core" / "core.kicad_sch"
    tree = sexpr.parse(core_sch.read_text())
    for inst in (sexpr.find(x, "instances") for x in sexpr.find_all(tree, "symbol")):
        for proj in [p for p in sexpr.find_all(inst or [], "project") if str(p[1]) == "template"]:
            inst.remove(proj)
    sch_gen.write(core_sch, tree)
    assert "template" not in sch_gen.core_projects(core_sch)
    return out


def test_hwgen_scaffolds_a_new_board_then_steps_aside(tmp_path):
    """scripts/hwgen writes a new board from its description (here the template's, routing
    replayed from its cache), records it in the shared core sheet without redrawing the sheet,
    and the board passes every check; its drawn sheets are the description's circuit (the same
    netlist as the label-per-pin rendering, net by net and pin by pin). Run again, it refuses:
    the KiCad files are the source from then on."""
    from r2ptools.kicad import netcompare, sch_gen
    out = _scaffold_scratch(tmp_path)
    run = [sys.executable, "-m", "r2ptools.kicad.generate", "template", "--out", str(out)]
    p = subprocess.run(run, cwd=ROOT / "scripts", capture_output=True, text=True)
    assert p.returncode == 0, p.stdout + p.stderr
    assert "freerouting" not in p.stdout, "routing was not replayed from route.ses: " + p.stdout
    assert "template" in sch_gen.core_projects(out / "core" / "core.kicad_sch")
    r = check.check(out / "template")
    assert r.ok, "\n".join(r.problems)
    reference = netlist.export(_label_per_pin("template", tmp_path / "reference"))
    assert netcompare.differences(reference, netlist.export(out / "template" / "template.kicad_sch")) == []
    before = (out / "template" / "template.kicad_pcb").read_bytes()
    p = subprocess.run(run, cwd=ROOT / "scripts", capture_output=True, text=True)
    assert p.returncode == 2 and "KiCad" in p.stderr, p.stdout + p.stderr
    assert (out / "template" / "template.kicad_pcb").read_bytes() == before


def _label_per_pin(module: str, out: Path) -> Path:
    """A description's circuit written label-per-pin (every pin labelled, no wires to get wrong)."""
    from r2ptools.kicad import sch_gen
    from r2ptools.kicad.modules import build_all
    from r2ptools.kicad.schematic import SheetWriter
    modules = build_all()
    m = next(x for x in modules if x.name == module)
    from r2ptools.kicad.modules import core
    sch_gen.write_core(core.build(), [m], out, writer=SheetWriter)
    sch = sch_gen.write_module(m, out, writer=SheetWriter)
    for f in ("sym-lib-table", "fp-lib-table"):
        shutil.copy(HARDWARE / module / f, sch.parent / f)
    shutil.copytree(HARDWARE / "core" / "R2P.pretty", out / "core" / "R2P.pretty")
    return sch


def test_a_wire_missing_from_a_drawing_changes_its_netlist(tmp_path):
    """The equivalence check can fail: the core sheet with its longest wire removed."""
    from r2ptools.kicad import netcompare, sexpr
    out = tmp_path / "hardware"
    for d in ("template", "core"):
        shutil.copytree(HARDWARE / d, out / d, ignore=shutil.ignore_patterns("fab"))
    core_sch = out / "core" / "core.kicad_sch"
    tree = sexpr.parse(core_sch.read_text())
    def length(w: list) -> float:
        (a, b) = [(float(xy[1]), float(xy[2])) for xy in sexpr.find_all(sexpr.find(w, "pts"), "xy")]
        return abs(a[0] - b[0]) + abs(a[1] - b[1])
    before = netlist.export(out / "template" / "template.kicad_sch")
    tree.remove(max(sexpr.find_all(tree, "wire"), key=length))
    core_sch.write_text(sexpr.dump(tree) + "\n")
    after = netlist.export(out / "template" / "template.kicad_sch")
    assert netcompare.differences(before, after)


def _drag(tree: list, ref: str, dx: float, dy: float) -> None:
    """Moves symbol `ref` and whatever is attached to its pins (wire ends, power symbols,
    labels, junctions), as KiCad's drag does."""
    from r2ptools.kicad import drawing, sexpr
    sym = next(x for x in sexpr.find_all(tree, "symbol")
               if any(str(p[1]) == "Reference" and str(p[2]) == ref for p in sexpr.find_all(x, "property")))
    at = sexpr.find(sym, "at")
    pl = drawing.place(str(sexpr.find(sym, "lib_id")[1]), ref,
                       (round(float(at[1]) * 100), round(float(at[2]) * 100)), int(at[3]), {}, None)
    pins = {(q.p[0] / 100, q.p[1] / 100) for q in pl.pins}

    def shift(node: list, i: int = 1) -> None:
        node[i], node[i + 1] = sexpr.num(float(node[i]) + dx), sexpr.num(float(node[i + 1]) + dy)

    def on_pin(node: list, i: int = 1) -> bool:
        return (round(float(node[i]), 2), round(float(node[i + 1]), 2)) in pins
    for item in tree:
        if not isinstance(item, list) or item is sym:
            continue
        if item[0] == "wire":
            for xy in sexpr.find_all(sexpr.find(item, "pts"), "xy"):
                if on_pin(xy):
                    shift(xy)
        elif item[0] in ("symbol", "label", "junction", "no_connect", "hierarchical_label"):
            a = sexpr.find(item, "at")
            if on_pin(a):
                shift(a)
                for prop in sexpr.find_all(item, "property"):
                    shift(sexpr.find(prop, "at"))
    shift(at)
    for prop in sexpr.find_all(sym, "property"):
        shift(sexpr.find(prop, "at"))


def test_a_board_edited_by_hand_in_its_files_passes_every_check(tmp_path):
    """What a contributor does in KiCad, done to the files: a part dragged to a new place, a
    wire rerouted round a detour, a track widened. ERC, DRC, parity, parts, pins and the fab
    netlist still pass: the checks read the KiCad files, not the description."""
    from r2ptools import pins
    from r2ptools.kicad import sexpr
    root = tmp_path
    for d in ("proximity", "core"):
        shutil.copytree(HARDWARE / d, root / "hardware" / d, ignore=shutil.ignore_patterns("fab"))
    shutil.copytree(ROOT / "firmware" / "boards", root / "firmware" / "boards")
    core_sch = root / "hardware" / "core" / "core.kicad_sch"
    tree = sexpr.parse(core_sch.read_text())
    _drag(tree, "C12", 2.54, 0)
    flat = [w for w in sexpr.find_all(tree, "wire")
            if len({xy[2] for xy in sexpr.find_all(sexpr.find(w, "pts"), "xy")}) == 1]
    wire = max(flat, key=lambda w: abs(float(sexpr.find(w, "pts")[1][1]) - float(sexpr.find(w, "pts")[2][1])))
    (ax, ay), (bx, by) = [(xy[1], xy[2]) for xy in sexpr.find_all(sexpr.find(wire, "pts"), "xy")]
    up = sexpr.num(float(ay) - 1.27)
    i = tree.index(wire)
    tree[i:i + 1] = [["wire", ["pts", ["xy", p, q], ["xy", r, t]], ["stroke", ["width", "0"], ["type", "default"]],
                      ["uuid", sexpr.Q(f"5e0c0a3e-1d2b-4c5d-8e9f-00000000000{k}")]]
                     for k, (p, q, r, t) in enumerate(((ax, ay, ax, up), (ax, up, bx, up), (bx, up, bx, by)))]
    core_sch.write_text(sexpr.dump(tree) + "\n")
    import pcbnew
    pcb = root / "hardware" / "proximity" / "proximity.kicad_pcb"
    b = pcbnew.LoadBoard(str(pcb))
    track = max((t for t in b.GetTracks() if t.GetNetname() == "GND" and not isinstance(t, pcbnew.PCB_VIA)),
                key=lambda t: t.GetLength())
    track.SetWidth(track.GetWidth() + pcbnew.FromMM(0.05))
    pcbnew.SaveBoard(str(pcb), b)
    r = check.check(root / "hardware" / "proximity")
    assert r.ok, "\n".join(r.problems)
    assert pins.main(["proximity", "--root", str(root)]) == 0
    fab.netlist_text(root / "hardware" / "proximity" / "proximity.kicad_sch", tmp_path / "net.txt")
    assert (tmp_path / "net.txt").read_text() == \
        (HARDWARE / "proximity" / "fab" / "proximity-netlist.txt").read_text()


def test_a_dangling_wire_is_a_drawing_fault(scratch):
    """A wire end that connects nothing is reported (ERC warnings of that kind are faults)."""
    from r2ptools.kicad import sexpr
    sch = scratch / "proximity.kicad_sch"
    tree = sexpr.parse(sch.read_text())
    tree.insert(-1, ["wire", ["pts", ["xy", "12.7", "12.7"], ["xy", "17.78", "12.7"]],
                     ["stroke", ["width", "0"], ["type", "default"]],
                     ["uuid", sexpr.Q("0b7c5f62-9d0e-4d3c-8a41-5b2f3e1d9a77")]])
    sch.write_text(sexpr.dump(tree) + "\n")
    assert _problems(scratch, "wire_dangling")


@pytest.mark.parametrize("module", fab.FAB_BOARDS)
def test_fab_package_is_current_and_byte_identical(module, tmp_path):
    committed = HARDWARE / module / "fab"
    fab.package(HARDWARE / module, tmp_path / "fab")
    ours = sorted(p.relative_to(tmp_path / "fab") for p in (tmp_path / "fab").rglob("*") if p.is_file())
    theirs = sorted(p.relative_to(committed) for p in committed.rglob("*") if p.is_file())
    assert ours == theirs
    differ = [str(f) for f in ours if not filecmp.cmp(committed / f, tmp_path / "fab" / f, shallow=False)]
    assert not differ, f"{module}: fab files differ (run `make fab`): {differ}"


def test_fab_package_has_what_a_fab_needs():
    files = {p.name for p in (HARDWARE / "psu" / "fab" / "gerbers").iterdir()}
    for layer in ("F_Cu", "B_Cu", "F_Mask", "B_Mask", "F_Silkscreen", "B_Silkscreen", "Edge_Cuts"):
        assert any(layer in f for f in files), layer
    assert any(f.endswith(".drl") for f in files) and any(f.endswith(".gbrjob") for f in files)
    for f in files:
        text = (HARDWARE / "psu" / "fab" / "gerbers" / f).read_text()
        assert "CreationDate" not in text and not re.search(r"date \d", text), f"{f} carries a date"
    bom = (HARDWARE / "psu" / "fab" / "psu-bom.csv").read_text().splitlines()
    assert bom[0] == "Comment,Designator,Footprint,LCSC Part #,Manufacturer,MPN"   # JLCPCB's
    assert any(line.endswith(",LM76005RNPR") for line in bom)
    package = {p.name for p in (HARDWARE / "psu" / "fab").iterdir()}
    assert {"psu-gerbers.zip", "psu-bom.csv", "psu-cpl.csv", "psu-ibom.html", "psu-assembly.pdf",
            "psu-assembly-checklist.md", "psu-schematic.pdf", "psu-top.png", "psu-bottom.png"} <= package


# --- the checks fail for real -------------------------------------------------------------------

@pytest.fixture
def scratch(tmp_path):
    """A scratch copy of hardware/ (the proximity board and the shared core and footprints)."""
    out = tmp_path / "hardware"
    for d in ("proximity", "core"):
        shutil.copytree(HARDWARE / d, out / d, ignore=shutil.ignore_patterns("fab"))
    return out / "proximity"


def _problems(board: Path, kind: str) -> list[str]:
    return [p for p in check.check(board).problems if kind in p]


def test_a_missing_track_is_reported_unconnected(scratch):
    import pcbnew
    pcb = scratch / "proximity.kicad_pcb"
    b = pcbnew.LoadBoard(str(pcb))
    # every segment of the net: one alone may be a redundant stub the router left
    victims = [t for t in b.GetTracks() if t.GetNetname().endswith("CAN_RX")]
    assert victims
    for t in victims:
        b.Delete(t)
    pcbnew.SaveBoard(str(pcb), b)
    assert _problems(scratch, "unconnected")


def test_overlapping_parts_are_a_drc_error(scratch):
    import pcbnew
    pcb = scratch / "proximity.kicad_pcb"
    b = pcbnew.LoadBoard(str(pcb))
    b.FindFootprintByReference("R102").SetPosition(b.FindFootprintByReference("R103").GetPosition())
    pcbnew.SaveBoard(str(pcb), b)
    assert _problems(scratch, "DRC error")


def test_a_reference_over_another_part_is_a_silkscreen_problem(scratch):
    """silk.py keeps references off pads and other silk; check.py must not wave one through."""
    import pcbnew
    pcb = scratch / "proximity.kicad_pcb"
    b = pcbnew.LoadBoard(str(pcb))
    ref = b.FindFootprintByReference("R102").GetFieldByName("Reference")
    ref.SetPosition(b.FindFootprintByReference("R103").GetPosition())
    pcbnew.SaveBoard(str(pcb), b)
    found = _problems(scratch, "DRC warning silk_")
    assert any("Reference field of R102" in p for p in found), found


def test_a_library_outline_over_the_edge_is_a_silkscreen_problem(scratch):
    """fplib.py trims the JST outlines short of the bottom edge; an outline crossing it fails."""
    import pcbnew
    pcb = scratch / "proximity.kicad_pcb"
    b = pcbnew.LoadBoard(str(pcb))
    fp = b.FindFootprintByReference("J101")
    line = max((g for g in fp.GraphicalItems() if isinstance(g, pcbnew.PCB_SHAPE)
                and g.GetLayer() == pcbnew.F_SilkS and g.GetShape() == pcbnew.SHAPE_T_SEGMENT),
               key=lambda g: max(g.GetStart().y, g.GetEnd().y))
    end = line.GetEnd() if line.GetEnd().y >= line.GetStart().y else line.GetStart()
    end.y += pcbnew.FromMM(1.0)                     # back over the edge, like the KiCad original
    line.SetEnd(end) if line.GetEnd().y >= line.GetStart().y else line.SetStart(end)
    pcbnew.SaveBoard(str(pcb), b)
    found = _problems(scratch, "DRC warning")
    assert any("silk_edge_clearance" in p and "J101" in p for p in found), found
    assert any("lib_footprint_mismatch" in p and "J101" in p for p in found), found


def test_a_footprint_missing_from_the_board_breaks_parity(scratch):
    import pcbnew
    pcb = scratch / "proximity.kicad_pcb"
    b = pcbnew.LoadBoard(str(pcb))
    b.Delete(b.FindFootprintByReference("C104"))
    pcbnew.SaveBoard(str(pcb), b)
    assert _problems(scratch, "parity")


def test_an_unconnected_pin_is_an_erc_error(scratch):
    """Remove the no-connect flag on the CAN transceiver's Vref output (U3 pin 5, in the core
    sheet the proximity board uses): ERC must object."""
    from r2ptools.kicad.schematic import uid
    sch = scratch.parent / "core" / "core.kicad_sch"
    text = sch.read_text()
    flag = re.search(r"\n\t\(no_connect\n\t\t\(at [^)]*\)\n\t\t\(uuid \"%s\"\)\n\t\)"
                     % uid("core", "nc", "U3/5"), text)
    assert flag, "U3 pin 5's no-connect flag not found"
    sch.write_text(text[:flag.start()] + text[flag.end():])
    assert _problems(scratch, "ERC error")


def test_a_field_disagreeing_with_the_parts_database_is_reported(scratch):
    sch = scratch / "proximity.kicad_sch"
    sch.write_text(sch.read_text().replace('(property "LCSC" "C25803"', '(property "LCSC" "C99999"', 1))
    assert any("C99999" in p for p in _problems(scratch, "BOM"))


# --- hardware/psu revision B: the design calculation is the board's ------------------------------

def _si(value: str) -> float:
    """A catalogue value ("6.8k", "470nF 25V", "10m 1%", "10uH 7.5A") as a number in SI units."""
    m = re.match(r"([0-9.]+)\s*([pnumkM]?)", value)
    if not m:
        raise ValueError(f"not a component value: {value!r}")
    scale = {"": 1.0, "p": 1e-12, "n": 1e-9, "u": 1e-6, "m": 1e-3, "k": 1e3, "M": 1e6}[m.group(2)]
    return float(m.group(1)) * scale


def test_psu_design_calculation_uses_the_boards_values():
    """calc/psu.py prints the design numbers from BOARD_VALUES: they must be the board's parts."""
    from r2ptools.kicad.calc import psu as calc
    net = netlist.export(HARDWARE / "psu" / "psu.kicad_sch")        # the board's own values
    parts = net.components
    wrong = [f"{ref}: calc assumes {want:g}, board has {parts[ref].value}"
             for ref, want in calc.BOARD_VALUES.items()
             if ref not in parts or abs(_si(parts[ref].value) - want) > 1e-9 * want]
    assert not wrong, "\n".join(wrong)
    pin = {p.name: p.number for p in libsym.pins("Regulator_Switching:LM76005")}
    assert net.pin_nets()[("U102", pin["BIAS"])].endswith("+5V_BUCK"), \
        "LM76005 BIAS on the 5 V output (SNVSBK5)"
    assert calc.main() == 0, "a design row fails: run scripts/py -m r2ptools.kicad.calc.psu"


def test_psu_calculation_catches_a_drifted_value(monkeypatch):
    """The check above is real: a value the calculation did not assume is reported."""
    from r2ptools.kicad.calc import psu as calc
    monkeypatch.setitem(calc.BOARD_VALUES, "R116", 3.9e3)      # revision A's 4.6 A limit
    with pytest.raises(AssertionError, match="R116"):
        test_psu_design_calculation_uses_the_boards_values()
    rows = {r.what: r for r in calc.rows()}
    assert not rows["eFuse limit 18/R_ILIM"].ok, "4.6 A out of one jack must fail the bus rule"


def test_psu_output_worst_case_is_checked_not_the_typical(monkeypatch):
    """The VOUT row checks the reference's min-max and the feedback resistors' tolerance against
    the bus's 4.90-5.10 V: revision B's first pair (100 k / 24.9 k, 1 %) was 5.05 V typical and
    passed a typical check, yet reaches 5.18 V; 1 % parts fail even on the centred pair."""
    from r2ptools.kicad.calc import psu as calc
    worst = "VOUT worst case (reference range, resistor tolerance)"
    assert {r.what: r for r in calc.rows()}[worst].ok
    monkeypatch.setitem(calc.BOARD_VALUES, "R108", 100e3)
    monkeypatch.setitem(calc.BOARD_VALUES, "R109", 24.9e3)
    monkeypatch.setattr(calc, "FB_RES_TOL", 0.01)
    rows = {r.what: r for r in calc.rows()}
    assert rows["VOUT typical = VFB (1 + R108/R109)"].ok and not rows[worst].ok
    monkeypatch.setitem(calc.BOARD_VALUES, "R108", 102e3)
    monkeypatch.setitem(calc.BOARD_VALUES, "R109", 25.5e3)
    assert not {r.what: r for r in calc.rows()}[worst].ok, "1 % parts: the band is too wide"


def test_psu_buck_starts_from_the_emptiest_pack_under_both_en_readings(monkeypatch):
    """The LM76005's EN thresholds are not verified: the start/stop rows exist for both readings,
    and a start above VIN_MIN (an EN divider sized for the 1.2 V reading, read at 2.1 V) fails."""
    from r2ptools.kicad.calc import psu as calc
    rows = [r for r in calc.rows() if r.what.startswith(("buck start, EN reading", "buck stop, EN reading"))]
    assert len(rows) == 4 and all(r.ok for r in rows)
    monkeypatch.setitem(calc.BOARD_VALUES, "R107", 26.1e3)
    bad = [r.what for r in calc.rows() if r.what.startswith("buck start") and not r.ok]
    assert bad == ["buck start, EN reading A (2.1 V / 1.72 V, this file's)"], bad


def test_psu_high_voltage_clearance_rule_catches_a_violation(tmp_path):
    """psu.kicad_dru's IPC-2221B rule: a GND via 0.4 mm from a battery-side pad is a DRC error
    (0.4 mm passes the fab's 0.127 mm and the 0.15 mm class clearance, so only the rule sees it)."""
    import pcbnew
    out = tmp_path / "hardware"
    for d in ("psu", "core"):
        shutil.copytree(HARDWARE / d, out / d, ignore=shutil.ignore_patterns("fab"))
    pcb = out / "psu" / "psu.kicad_pcb"
    assert "ipc2221b" in (out / "psu" / "psu.kicad_dru").read_text()

    def ipc_errors() -> list[str]:
        return [v["description"] for v in check.drc(pcb)["violations"]
                if "ipc2221b" in v["description"]]

    assert not ipc_errors(), "the committed board keeps the rule"
    b = pcbnew.LoadBoard(str(pcb))
    pad = next(p for p in b.FindFootprintByReference("C102").Pads() if p.GetNetname().endswith("VIN_BUCK"))
    gnd = b.FindNet("GND")
    via = pcbnew.PCB_VIA(b)
    right = pad.GetPosition().x + pad.GetSize().x // 2
    via.SetPosition(pcbnew.VECTOR2I(right + pcbnew.FromMM(0.4 + 0.3), pad.GetPosition().y))
    via.SetWidth(pcbnew.FromMM(0.6))
    via.SetDrill(pcbnew.FromMM(0.3))
    via.SetNet(gnd)
    b.Add(via)
    pcbnew.SaveBoard(str(pcb), b)
    assert ipc_errors(), "a GND via 0.4 mm from VIN_BUCK must break the 0.6 mm rule"


@pytest.mark.parametrize("board", ["psu", "proximity", "template", "motor", "imu"])
def test_no_via_sits_in_an_smd_pad(board):
    """An open via in a pad wicks the joint's solder down the barrel (revision A had a VIN_BUCK via
    in C102's pad); the exposed pads' thermal vias are the only vias allowed in copper pads."""
    assert not check.vias_in_pads(HARDWARE / board / f"{board}.kicad_pcb")


def test_a_via_in_a_pad_is_reported_and_thermal_vias_are_not(tmp_path):
    """The check is real: a via dropped into C102's VIN_BUCK pad is named; U102's ten thermal vias
    in its exposed pad are not."""
    import pcbnew
    pcb = tmp_path / "psu.kicad_pcb"
    shutil.copyfile(HARDWARE / "psu" / "psu.kicad_pcb", pcb)
    b = pcbnew.LoadBoard(str(pcb))
    u102 = b.FindFootprintByReference("U102")
    ep = max((p for p in u102.Pads() if p.IsOnCopperLayer()), key=lambda p: p.GetSizeX() * p.GetSizeY())
    thermal = [v for v in b.GetTracks() if v.GetClass() == "PCB_VIA" and ep.HitTest(v.GetPosition(), 0)]
    assert len(thermal) == 10, "U102's exposed pad keeps its ten thermal vias"
    pad = next(p for p in b.FindFootprintByReference("C102").Pads() if p.GetNetname().endswith("VIN_BUCK"))
    via = pcbnew.PCB_VIA(b)
    via.SetPosition(pad.GetPosition())
    via.SetWidth(pcbnew.FromMM(0.6))
    via.SetDrill(pcbnew.FromMM(0.3))
    via.SetNet(pad.GetNet())
    b.Add(via)
    pcbnew.SaveBoard(str(pcb), b)
    faults = check.vias_in_pads(pcb)
    assert len(faults) == 1 and "inside C102 pad" in faults[0], faults
# --- revision B: parts that are not assembled ---------------------------------------------------

def test_test_pads_and_fiducials_are_on_the_board_but_on_no_bom_or_placement_file(tmp_path):
    """Test pads (TP) are symbols excluded from the BOM; fiducials (FID) are board-only: both are
    copper on the board, and neither reaches the assembly BOM, the parts check or the CPL."""
    import pcbnew
    for module in ("proximity", "template"):
        pcb = HARDWARE / module / f"{module}.kicad_pcb"
        b = pcbnew.LoadBoard(str(pcb))
        refs = {fp.GetReference(): fp for fp in b.GetFootprints()}
        pads = [r for r in refs if r.startswith("TP")]
        fids = [r for r in refs if r.startswith("FID")]
        assert len(pads) >= 8 and len(fids) == 3, (module, pads, fids)
        for r in pads + fids:
            attrs = refs[r].GetAttributes()
            assert attrs & pcbnew.FP_EXCLUDE_FROM_BOM and attrs & pcbnew.FP_EXCLUDE_FROM_POS_FILES, r
        sch = HARDWARE / module / f"{module}.kicad_sch"
        assert not any(ref.startswith("TP") for _, ref, _ in check.symbol_fields(sch))
        assert sum(ref.startswith("TP") for _, ref, _ in check.symbol_fields(sch, excluded=True)) \
            == len(pads)
        from r2ptools import bom
        assert not any(s.ref.startswith("TP") for s in bom.schematic_symbols(sch))   # scripts/bom
        from r2ptools.kicad import jlc
        placed, on_bom = jlc.parts(pcb)
        jlc.write_bom(on_bom, tmp_path / "bom.csv")
        jlc.write_cpl(placed, tmp_path / "cpl.csv")
        for f in ("bom.csv", "cpl.csv"):
            text = (tmp_path / f).read_text()
            assert not re.search(r"\b(TP|FID)\d", text), (module, f)


def test_a_test_pad_put_on_the_bom_is_reported(scratch):
    """A test pad has no part number: marked "on the BOM", the parts check must object."""
    sch = scratch.parent / "core" / "core.kicad_sch"
    text = sch.read_text()
    i = text.index('(lib_id "Connector:TestPoint")')
    j = text.index("(in_bom no)", i)
    sch.write_text(text[:j] + "(in_bom yes)" + text[j + len("(in_bom no)"):])
    assert any("TP" in p and "no MPN" in p for p in _problems(scratch, "BOM"))


def test_design_numbers_hold():
    """The equations behind revision B's values (calc/core.py, calc/proximity.py,
    calc/gateway.py and calc/imu.py print them)
    hold, the boards' KiCad schematics carry the values they assume, and the emulated sensor
    switch uses the hardware's nominal limit."""
    from r2ptools.kicad.calc import core, gateway, proximity
    x = core.crystal_load()
    assert abs(x["chosen_pf"] - x["ideal_pf"]) <= 0.1 * x["ideal_pf"] and x["gain_margin"] >= 5
    assert x["cl_min_pf"] < core.CRYSTAL_CL_PF < x["cl_max_pf"]
    lo, nom, hi = proximity.switch_limit_ma()
    assert lo >= 4 * max(proximity.SENSORS_MA.values()) and hi < 200
    assert gateway.main() == 0, "a gateway design number fails: scripts/py -m r2ptools.kicad.calc.gateway"
    # the gateway draws the core's blocks around its own MCU (an F407, its own decoupling)
    core_values = {b.name: gateway.BOARD_VALUES if b.name == "gateway" else core.BOARD_VALUES
                   for b in BOARDS}
    from r2ptools.kicad.calc import imu
    assert imu.main() == 0, "an IMU design number fails: scripts/py -m r2ptools.kicad.calc.imu"
    for board, values in list(core_values.items()) + [("proximity", proximity.BOARD_VALUES),
                                                      ("imu", imu.BOARD_VALUES)]:
        parts = netlist.export(HARDWARE / board / f"{board}.kicad_sch").components
        wrong = [f"{board} {ref}: calc assumes {want:g}, board has {parts[ref].value}"
                 for ref, want in values.items()
                 if ref not in parts or abs(_si(parts[ref].value) - want) > 1e-9 * want]
        assert not wrong, "\n".join(wrong)
    model = (ROOT / "firmware/host/world/src/sensor_switch.rs").read_text()
    limit_a = float(re.search(r"SENSOR_SWITCH_LIMIT_A: f64 = ([0-9.]+);", model).group(1))
    assert abs(limit_a * 1000 - nom) < 1.0, (limit_a, nom)




def test_imu_field_estimates_use_the_boards_places():
    """calc/imu.py states the magnetometer's distances (README, schematic note) from PLACES: they
    must be where the parts are on hardware/imu/imu.kicad_pcb, so moving U102 or JP101 in KiCad
    fails here until the calculation (and the numbers it prints) follow."""
    import pcbnew
    from r2ptools.kicad.board import ORIGIN
    from r2ptools.kicad.calc import imu
    b = pcbnew.LoadBoard(str(HARDWARE / "imu" / "imu.kicad_pcb"))

    def at(fp) -> tuple[float, float]:          # mm from the board's top-left corner
        return (round(pcbnew.ToMM(fp.GetPosition().x) - ORIGIN[0], 2),
                round(pcbnew.ToMM(fp.GetPosition().y) - ORIGIN[1], 2))
    for ref in ("U102", "JP101"):
        got, want = at(b.FindFootprintByReference(ref)), imu.PLACES[ref]
        assert abs(got[0] - want[0]) < 0.05 and abs(got[1] - want[1]) < 0.05, (ref, got, want)
    holes = sorted(at(fp) for fp in b.GetFootprints() if fp.GetReference().startswith("H"))
    assert tuple(imu.PLACES["H3"]) in holes and tuple(imu.PLACES["H4"]) in holes, holes

MOTOR_ROLES = {
    # calc/motor.py DESIGN_VALUES role -> the references on hardware/motor that realise it
    # (sums for a string of resistors, every listed part for a repeated one)
    "R_VMOT_TOP": ("R108",), "R_VMOT_BOT": ("R109",),
    "R_OV_TOP": ("R110", "R111", "R112"), "R_OV_BOT": ("R113",),
    "C_BULK_EACH": ("C101", "C102", "C103", "C104"),
    "C_CER_EACH": ("C105", "C106", "C107", "C108", "C109", "C110", "C111", "C112"),
    "R_ENC_SERIES": ("R118", "R119"), "C_ENC": ("C124", "C125"),
    "R_ENC_PULLUP": ("R116", "R117"), "R_FAULT_PULLUP": ("R114",),
    # the HIP4082's bootstrap, VDD and dead time, its VDD regulator, the over-current window
    "C_BS": ("C114", "C115"), "C_VDD": ("C113",), "R_GATE": ("R101", "R102", "R103", "R104"),
    "R_DEL": ("R105",), "R_VDD_BIAS": ("R120",), "R_OC_OUTER": ("R121", "R123"), "R_OC_MID": ("R122",),
}
MOTOR_SERIES = {"R_OV_TOP"}


def _motor_wrong(values: dict[str, float]) -> list[str]:
    parts = netlist.export(HARDWARE / "motor" / "motor.kicad_sch").components
    wrong = []
    for role, refs in MOTOR_ROLES.items():
        missing = [r for r in refs if r not in parts]
        if missing:
            wrong.append(f"{role}: {', '.join(missing)} not on the board")
            continue
        have = [_si(parts[r].value) for r in refs]
        got = sum(have) if role in MOTOR_SERIES else have
        want = values[role]
        ok = abs(got - want) <= 1e-9 * want if role in MOTOR_SERIES else \
            all(abs(h - want) <= 1e-9 * want for h in have)
        if not ok:
            wrong.append(f"{role} ({', '.join(refs)}): calc assumes {want:g}, board has {got}")
    for role, count in (("N_BULK", 4), ("N_CER", 8)):
        if values[role] != count:
            wrong.append(f"{role}: calc assumes {values[role]}, board has {count}")
    return wrong


@pytest.mark.skipif(not (HARDWARE / "motor" / "motor.kicad_sch").exists(), reason="no motor board")
def test_motor_design_calculation_uses_the_boards_values(monkeypatch):
    """calc/motor.py's DESIGN_VALUES are the motor board's parts; a drifted value is reported."""
    from r2ptools.kicad.calc import motor as calc
    assert _motor_wrong(calc.DESIGN_VALUES) == []
    drifted = dict(calc.DESIGN_VALUES, R_VMOT_TOP=100e3)       # the firmware's old divider
    assert any("R_VMOT_TOP" in w for w in _motor_wrong(drifted))
