"""The fab packages are what JLCPCB takes as is (docs/hardware.md, "Fab packages").

For every board with a fab package: the CPL puts every polarised part the way JLC's library
needs it, checked *without* the correction table (from pin 1's position on our board, the CPL's
rotation, and one statement per package of where JLC's part has pin 1 at 0°); the BOM has
JLC's columns and an LCSC part on every line (nothing consigned); the interactive BOM, the
two-page assembly drawing and the pin-1 checklist are there and complete. Each check is also
run on a deliberately broken copy and must fail there. Byte-for-byte regeneration of the whole
package is tests/test_hardware.py::test_fab_package_is_current_and_byte_identical.
"""
from __future__ import annotations

import csv
import math
import re
import shutil
import subprocess
from dataclasses import dataclass
from pathlib import Path

import pytest

from conftest import ROOT

if shutil.which("kicad-cli") is None:
    pytest.fail("kicad-cli is not installed: run scripts/setup (installs KiCad 9)", pytrace=False)

from r2ptools.kicad import fab, jlc  # noqa: E402

HARDWARE = ROOT / "hardware"

# --- where JLC's library has pin 1 at 0° -------------------------------------------------------
#
# Written down once per package, independently of jlc.py's correction table: the direction of
# pin 1 (cathode for diodes and LEDs) from the part's centre in JLC's part at 0°, looking at the
# side it is placed on, in degrees counter-clockwise from +x (0 right, 90 up, 180 left, 225
# lower left). JLC's rule (quoted by LCSC and in the field's tools' threads): 0° is the part as
# it lies in its carrier tape with the sprocket holes on the left. ICs (SOIC, TSSOP, QFP, QFN)
# then have pin 1 next to the holes at the lower left with their rows horizontal; the SOT-23
# family has pin 1 away from the holes, at the lower right; two-terminal diodes and LEDs have
# the cathode on the left (as IPC-7351); packages the field's tools have no correction for keep
# KiCad's IPC-7351 orientation. The SOT-23 family and the 2x5 1.27 mm header are disputed
# between the tools (jlc.DISPUTED; the checklist flags them for JLC's preview). A new package on
# a board fails test_every_polarised_part_has_a_statement until its line is added here.

@dataclass(frozen=True)
class Zero:
    pattern: str
    pin1_deg: float
    why: str


JLC_ZERO = [
    Zero(r"LQFP-\d+_", 225, "quad flat: pin 1 at the left end of the bottom row"),
    Zero(r"(Texas_\w+_)?[VW]?QFN-\d+", 225, "quad no-lead: pin 1 at the left end of the bottom row"),
    Zero(r"SOIC-\d+_", 225, "SOIC: rows horizontal, pin 1 lower left, next to the tape's holes"),
    Zero(r"H?TSSOP-\d+", 225, "TSSOP/HTSSOP: rows horizontal, pin 1 lower left"),
    Zero(r"(MSOP|VSSOP|SSOP)-\d+", 225, "(V)(M)SSOP: rows horizontal, pin 1 lower left"),
    Zero(r"(V|W)?(DFN|SON)-\d+", 225, "DFN/SON/WSON: rows horizontal, pin 1 lower left"),
    Zero(r"(T?SOT-23(-[5-8])?|SOT-223(-3_TabPin2)?)$", 315,
         "SOT-23 family, SOT-223: pin 1 lower right, away from the tape's holes"),
    Zero(r"SOT-89-3$", 320,
         "SOT-89: the three leads on the right, pin 1 lower right, the tab left (KiCad's turned 180°: "
         "the field's tools' ^SOT-89 180, the SOT-23 family's rule)"),
    Zero(r"TO-252-2", 135, "DPAK: leads to the left, pin 1 the upper lead (IPC-7351, no correction)"),
    Zero(r"D_(SOD-123F?|SOD-323F?|SMA|SMB|SMC|MiniMELF)$", 180,
         "diode: cathode left (IPC-7351; JLC's diodes likewise)"),
    Zero(r"LED_\d{4}_\d{4}Metric", 180, "chip LED: cathode left (IPC-7351; JLC's LEDs likewise)"),
    Zero(r"CP_Elec_|CP_EIA-", 0, "polarised capacitor: + on the right (the tools' 180 from KiCad's)"),
    Zero(r"Crystal_SMD_3225-4Pin", 225, "4-pad crystal: pin 1 lower left (IPC-7351)"),
    Zero(r"PinHeader_2x05_P1\.27mm_Vertical_SMD", 225,
         "2x5 1.27 mm SMD header: rows horizontal, pin 1 at the left end of the bottom row"),
    Zero(r"SW_Push_1P1T_XKB_TS-1187A", 135, "4-pad tact switch: pad 1 upper left (IPC-7351)"),
    Zero(r"SW_SPDT_Shouhan_MSK12C02", 135, "slide switch: pad 1 upper left (IPC-7351)"),
    Zero(r"SW_DIP_SPSTx\d+_Slide_KingTek_", 160,
         "SMD DIP switch: pin 1 at the top of the left column (IPC-7351, no correction)"),
    Zero(r"PinHeader_1x0[45]_P2\.54mm_Vertical", 90, "THT header: pin 1 at the top (KiCad)"),
    Zero(r"RJ45_Amphenol_54602-x08_Horizontal", 135,
         "THT RJ45, cable opening down: pin 1 upper left (KiCad's orientation; fitted by hand)"),
    Zero(r"RJ45_Hanrun_HR911105A_Horizontal", 135,
         "THT RJ45 with magnetics, cable opening down: pin 1 upper left (KiCad's orientation; fitted by hand)"),
    Zero(r"AMASS_XT30PW-M_1x02_P2\.50mm_Horizontal", 315,
         "THT XT30, cable entry down: pin 1 lower right of the pads' centre (KiCad's orientation)"),
    Zero(r"TO-263-2$", 160, "D2PAK: leads to the left, pin 1 the upper lead (IPC-7351, no correction)"),
    Zero(r"CP_Radial_D\d", 180, "THT radial electrolytic: + (pin 1) left (KiCad's orientation; fitted by hand)"),
    Zero(r"AMASS_XT60PW-M_1x02_P7\.20mm_Horizontal", 200,
         "THT XT60 male, cable entry up: pin 1 left of the pads' centre (KiCad's orientation)"),
    Zero(r"AMASS_XT60PW-F_1x02_P7\.20mm_Horizontal", 340,
         "THT XT60 female, cable entry up: pin 1 right of the pads' centre (KiCad's orientation)"),
    Zero(r"(ST_H)?LGA-1[024]_", 135,
         "ST LGA/HLGA sensor: pin 1 upper left (IPC-7351, no correction; jlc.DISPUTED: check first)"),
    Zero(r"JST_GH_SM\d+B-GHS-TB_1x\d+-1MP_P1\.25mm_Horizontal", 330,
         "SMD JST GH side entry: pin 1 at the right end of the contact row (KiCad's turned 180°)"),
    Zero(r"JST_PH_S\dB-PH-K_1x\d+_P2\.00mm_Horizontal", 0,
         "THT JST PH side entry: pin 1 at the right end (JLC's part is KiCad's turned 180°)"),
]
TOLERANCE_DEG = 40
"""Half-width of the accepted window: any 90° or 180° error, or a wrong mirror, lands outside."""
UNPOLARISED = re.compile(r"^(R_\d{4}_|C_\d{4}_|Fuse_|L_)")
"""Resistors, ceramic capacitors, fuses, inductors: either way round is right."""


def _zero(footprint: str) -> Zero | None:
    return next((z for z in JLC_ZERO if re.match(z.pattern, footprint)), None)


@dataclass(frozen=True)
class Placed:
    ref: str
    footprint: str
    bottom: bool
    pin1: tuple[float, float]
    """Pin 1's offset from the pads' centre in mm, x right, y up, as seen from the top."""


def _geometry(module: str) -> dict[str, Placed]:
    """Pin 1 of each placed footprint, read from the board with pcbnew (not from jlc.py)."""
    import pcbnew
    board = pcbnew.LoadBoard(str(HARDWARE / module / f"{module}.kicad_pcb"))
    out = {}
    for fp in board.Footprints():
        if fp.GetAttributes() & pcbnew.FP_EXCLUDE_FROM_POS_FILES:
            continue                    # not placed by the assembler (test pads, fiducials)
        pads = list(fp.Pads())
        one = [p for p in pads if p.GetNumber() == "1"]
        if not one:
            continue
        xs = [x for p in pads for x in (p.GetBoundingBox().GetLeft(), p.GetBoundingBox().GetRight())]
        ys = [y for p in pads for y in (p.GetBoundingBox().GetTop(), p.GetBoundingBox().GetBottom())]
        cx, cy = (min(xs) + max(xs)) / 2, (min(ys) + max(ys)) / 2
        p1 = one[0].GetPosition()
        out[fp.GetReference()] = Placed(fp.GetReference(), str(fp.GetFPID().GetLibItemName()),
                                        fp.IsFlipped(), (pcbnew.ToMM(p1.x - cx), -pcbnew.ToMM(p1.y - cy)))
    return out


def _cpl(path: Path) -> dict[str, dict[str, str]]:
    with path.open(newline="") as f:
        return {r["Designator"]: r for r in csv.DictReader(f)}


def rotation_errors(geometry: dict[str, Placed], cpl: dict[str, dict[str, str]]) -> list[str]:
    """Every polarised part whose CPL rotation does not bring JLC's pin 1 onto ours."""
    errors = []
    for ref, g in sorted(geometry.items()):
        if UNPOLARISED.match(g.footprint) or ref not in cpl:
            continue
        zero = _zero(g.footprint)
        if zero is None:
            errors.append(f"{ref}: no statement of JLC's pin 1 for {g.footprint} (add one to JLC_ZERO)")
            continue
        row = cpl[ref]
        if (row["Layer"] == "Bottom") != g.bottom:
            errors.append(f"{ref}: CPL layer {row['Layer']}, board side {'bottom' if g.bottom else 'top'}")
            continue
        x, y = g.pin1
        if g.bottom:
            x = -x                      # JLC looks at the bottom from below: left and right swap
        seen = math.degrees(math.atan2(y, x))
        expected = zero.pin1_deg + float(row["Rotation"])
        off = (seen - expected + 180) % 360 - 180
        if abs(off) > TOLERANCE_DEG:
            errors.append(f"{ref} ({g.footprint}): CPL rotation {row['Rotation']} puts JLC's pin 1 at "
                          f"{expected % 360:.0f}°, ours is at {seen % 360:.0f}° ({zero.why})")
    return errors


@pytest.fixture(scope="module", params=fab.FAB_BOARDS)
def board(request):
    m = request.param
    return m, _geometry(m), HARDWARE / m / "fab"


def test_every_polarised_part_has_a_statement(board):
    module, geometry, _ = board
    unknown = sorted({g.footprint for g in geometry.values()
                      if not UNPOLARISED.match(g.footprint) and _zero(g.footprint) is None})
    assert not unknown, f"{module}: say where JLC's part has pin 1 at 0° (JLC_ZERO) for {unknown}"


def test_cpl_rotations_put_pin_1_where_jlc_has_it(board):
    module, geometry, folder = board
    errors = rotation_errors(geometry, _cpl(folder / f"{module}-cpl.csv"))
    assert not errors, f"{module}:\n" + "\n".join(errors)


def test_a_wrong_rotation_is_caught(board, tmp_path):
    """Each polarised part turned by 90°, 180° or 270° in a copy of the CPL fails the check, and
    so does the raw KiCad rotation for the parts the table corrects (the issue's finding)."""
    module, geometry, folder = board
    cpl = _cpl(folder / f"{module}-cpl.csv")
    polar = [r for r, g in geometry.items() if not UNPOLARISED.match(g.footprint) and r in cpl]
    assert len(polar) >= 15, polar
    for ref in polar:
        for turn in (90, 180, 270):
            broken = {k: dict(v) for k, v in cpl.items()}
            broken[ref]["Rotation"] = f"{(float(cpl[ref]['Rotation']) + turn) % 360:.2f}"
            assert any(e.startswith(ref + " ") for e in rotation_errors(geometry, broken)), (ref, turn)
    import pcbnew
    b = pcbnew.LoadBoard(str(HARDWARE / module / f"{module}.kicad_pcb"))
    raw = {k: dict(v) for k, v in cpl.items()}
    for fp in b.Footprints():
        if fp.GetReference() in raw:
            raw[fp.GetReference()]["Rotation"] = f"{fp.GetOrientationDegrees() % 360:.2f}"
    caught = {e.split()[0] for e in rotation_errors(geometry, raw)}
    assert {"U1", "U3"} <= caught, caught            # LQFP-48, SOIC-8 with KiCad's raw angle


def test_bottom_side_parts_use_jlcs_bottom_convention(tmp_path):
    """No polarised part is on a bottom side today: flip the CAN transceiver and an LED of a
    copy of the proximity board to the bottom, and the CPL fab.py writes must still pass, while
    the top-side formula applied to them must fail."""
    import pcbnew
    pcb = tmp_path / "proximity.kicad_pcb"
    shutil.copyfile(HARDWARE / "proximity" / "proximity.kicad_pcb", pcb)
    b = pcbnew.LoadBoard(str(pcb))
    for fp in b.Footprints():
        if fp.GetReference() in ("U3", "D2"):
            fp.SetOrientationDegrees(30 if fp.GetReference() == "U3" else 0)
            fp.Flip(fp.GetPosition(), pcbnew.FLIP_DIRECTION_LEFT_RIGHT)
    pcbnew.SaveBoard(str(pcb), b)
    placed, _ = jlc.parts(pcb)
    jlc.write_cpl(placed, tmp_path / "cpl.csv")
    cpl = _cpl(tmp_path / "cpl.csv")
    assert cpl["U3"]["Layer"] == "Bottom" and cpl["D2"]["Layer"] == "Bottom"
    geometry = {}
    board_geo = pcbnew.LoadBoard(str(pcb))
    for fp in board_geo.Footprints():
        if fp.GetReference() in ("U3", "D2"):
            pads = list(fp.Pads())
            xs = [pcbnew.ToMM(p.GetPosition().x) for p in pads]
            ys = [pcbnew.ToMM(p.GetPosition().y) for p in pads]
            one = next(p for p in pads if p.GetNumber() == "1").GetPosition()
            cx, cy = (min(xs) + max(xs)) / 2, (min(ys) + max(ys)) / 2
            geometry[fp.GetReference()] = Placed(fp.GetReference(), str(fp.GetFPID().GetLibItemName()),
                                                 True, (pcbnew.ToMM(one.x) - cx, -(pcbnew.ToMM(one.y) - cy)))
    assert rotation_errors(geometry, cpl) == []
    top_formula = {k: dict(v) for k, v in cpl.items()}
    for p in placed:
        if p.ref in geometry:
            top_formula[p.ref]["Rotation"] = f"{(p.kicad_rotation + jlc.correction(p.footprint)[0]) % 360:.2f}"
    assert {e.split()[0] for e in rotation_errors(geometry, top_formula)} == {"U3", "D2"}


def test_cpl_is_what_jlc_py_computes_for_the_board(board, tmp_path):
    """The committed CPL has JLC's columns and the table's rotation for every placed part."""
    module, _, folder = board
    placed, _ = jlc.parts(HARDWARE / module / f"{module}.kicad_pcb")
    assert jlc.cpl_problems(folder / f"{module}-cpl.csv", placed) == []
    text = (folder / f"{module}-cpl.csv").read_text()
    broken = tmp_path / "cpl.csv"
    broken.write_text(text.replace("Designator,Mid X,Mid Y,Layer,Rotation", "Ref,PosX,PosY,Side,Rot", 1))
    assert jlc.cpl_problems(broken, placed)
    u1 = next(line for line in text.splitlines() if line.startswith("U1,"))
    turned = (float(u1.rsplit(",", 1)[1]) + 90) % 360       # a quarter turn off, whatever it was
    broken.write_text(text.replace(u1, u1.rsplit(",", 1)[0] + f",{turned:.2f}"))
    assert any("U1 " in p for p in jlc.cpl_problems(broken, placed))


# --- BOM ------------------------------------------------------------------------------------------

def test_bom_has_jlc_columns_and_an_lcsc_part_on_every_line(board):
    """Fails on a consigned part (a line without an LCSC number) or other columns."""
    module, _, folder = board
    assert jlc.bom_problems(folder / f"{module}-bom.csv") == []


def test_bom_check_fails_on_broken_copies(tmp_path):
    good = HARDWARE / "proximity" / "fab" / "proximity-bom.csv"
    rows = list(csv.reader(good.open(newline="")))
    assert rows[0] == ["Comment", "Designator", "Footprint", "LCSC Part #", "Manufacturer", "MPN"]

    def problems(rows):
        p = tmp_path / "bom.csv"
        with p.open("w", newline="") as f:
            csv.writer(f, lineterminator="\n").writerows(rows)
        return jlc.bom_problems(p)

    consigned = [list(r) for r in rows]
    consigned[3][3] = ""
    assert any("no LCSC part" in p and consigned[3][1] in p for p in problems(consigned))
    not_a_number = [list(r) for r in rows]
    not_a_number[2][3] = "TPS2065CDBVR"
    assert any("no LCSC part" in p for p in problems(not_a_number))
    renamed = [list(r) for r in rows]
    renamed[0][3] = "LCSC"
    assert any("columns" in p for p in problems(renamed))
    old_layout = [["Designator", "Quantity", "Value", "Footprint", "Manufacturer", "MPN", "LCSC"]] + rows[1:]
    assert any("columns" in p for p in problems(old_layout))


def test_bom_lists_every_placed_part_once(board):
    module, _, folder = board
    _, bom_parts = jlc.parts(HARDWARE / module / f"{module}.kicad_pcb")
    with (folder / f"{module}-bom.csv").open(newline="") as f:
        refs = [r for row in csv.DictReader(f) for r in row["Designator"].split(",")]
    assert sorted(refs) == sorted(p.ref for p in bom_parts)
    assert len(refs) == len(set(refs))


# --- interactive BOM, assembly drawing, checklist -------------------------------------------------

def test_interactive_bom_is_there_with_every_part(board):
    """The page's board data names every BOM part with its LCSC number and MPN."""
    import json
    module, geometry, folder = board
    html = (folder / f"{module}-ibom.html").read_text()
    data = json.loads(re.search(r"^var pcbdata = (\{.*\})$", html, re.M).group(1))
    fields = data["bom"]["fields"]
    refs = {ref: fields[str(i)] for group in data["bom"]["both"] for ref, i in group}
    _, bom_parts = jlc.parts(HARDWARE / module / f"{module}.kicad_pcb")
    for p in bom_parts:
        assert p.ref in refs, f"{module}: {p.ref} is not in the interactive BOM"
        assert p.fields.get("LCSC", "") in refs[p.ref] and p.fields["MPN"] in refs[p.ref], p.ref
    assert data["metadata"]["date"] == "1980-01-01 00:00:00", data["metadata"]


def test_interactive_bom_data_is_pinned(tmp_path):
    """The board file's time, which InteractiveHtmlBom would show as the date, is pinned."""
    from r2ptools.kicad import ibom
    pcb = tmp_path / "proximity.kicad_pcb"
    shutil.copyfile(HARDWARE / "proximity" / "proximity.kicad_pcb", pcb)
    ibom.interactive_bom(pcb, tmp_path / "a.html")
    import os
    os.utime(pcb, (2_000_000_000, 2_000_000_000))
    ibom.interactive_bom(pcb, tmp_path / "b.html")
    assert (tmp_path / "a.html").read_bytes() == (tmp_path / "b.html").read_bytes()


def test_assembly_drawing_has_top_and_mirrored_bottom(board):
    module, geometry, folder = board
    pdf = folder / f"{module}-assembly.pdf"
    info = subprocess.run(["pdfinfo", str(pdf)], capture_output=True, text=True).stdout
    assert re.search(r"^Pages:\s+2$", info, re.M), info
    top = subprocess.run(["pdftotext", "-f", "1", "-l", "1", str(pdf), "-"], capture_output=True,
                         text=True).stdout
    for ref in ("U1", "U3", "J1", "SW1"):
        assert ref in top, f"{module}: {ref} is not labelled on the top assembly drawing"
    assert b"CreationDate (D:19800101" in pdf.read_bytes() or b"CreationDate" not in pdf.read_bytes()


def test_checklist_lists_every_polarised_part(board):
    module, geometry, folder = board
    text = (folder / f"{module}-assembly-checklist.md").read_text()
    cpl = _cpl(folder / f"{module}-cpl.csv")
    rows = {line.split("|")[1].strip(): line for line in text.splitlines()
            if line.startswith("| ") and not line.startswith("| Ref")}
    want = {r for r, g in geometry.items() if not UNPOLARISED.match(g.footprint) and r in cpl}
    assert want <= set(rows), f"{module}: missing from the checklist: {sorted(want - set(rows))}"
    for ref in want:
        cells = [c.strip() for c in rows[ref].split("|")]
        assert float(cells[6]) == pytest.approx(float(cpl[ref]["Rotation"]) % 360), ref
        assert "pin 1" in cells[7] or "cathode" in cells[7], ref


def test_every_override_is_needed(monkeypatch, tmp_path):
    """Without each of jlc.OVERRIDES, the independent check flags the parts it is for: no row
    in the table is decoration."""
    for override in list(jlc.OVERRIDES):
        monkeypatch.setattr(jlc, "OVERRIDES", [o for o in jlc.OVERRIDES if o is not override])
        flagged = set()
        for module in fab.FAB_BOARDS:
            placed, _ = jlc.parts(HARDWARE / module / f"{module}.kicad_pcb")
            users = {p.ref for p in placed if re.fullmatch(override.pattern, p.footprint)}
            if not users:
                continue
            jlc.write_cpl(placed, tmp_path / "cpl.csv")
            errors = rotation_errors(_geometry(module), _cpl(tmp_path / "cpl.csv"))
            assert users <= {e.split()[0] for e in errors}, (override.pattern, users, errors)
            flagged |= users
        assert flagged, f"no board uses {override.pattern}: remove the override"
        monkeypatch.undo()


def test_renders_ignore_the_users_kicad_settings(monkeypatch, tmp_path):
    """A colour theme in the user's KiCad configuration (KiBot's render step leaves one) must
    not change the committed renders: kicad-cli runs with a clean configuration."""
    dirty = tmp_path / "config"
    (dirty / "9.0" / "colors").mkdir(parents=True)
    (dirty / "9.0" / "colors" / "user.json").write_text(     # what KiBot 1.9.1's render_3d left behind
        '{"3d_viewer": {"background_bottom": "rgb(102, 102, 127)", "background_top": '
        '"rgb(204, 204, 229)", "board": "rgb(51, 43, 22)", "copper": "rgb(139, 137, 140)", '
        '"silkscreen_bottom": "rgb(213, 220, 228)", "silkscreen_top": "rgb(213, 220, 228)", '
        '"soldermask_bottom": "rgba(32, 139, 71, 0.83)", "soldermask_top": "rgba(32, 139, 71, 0.83)", '
        '"solderpaste": "rgb(128, 128, 128)", "use_board_stackup_colors": false}}')
    monkeypatch.setenv("KICAD_CONFIG_HOME", str(dirty))
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path))
    out = fab.renders(HARDWARE / "proximity" / "proximity.kicad_pcb", tmp_path, "proximity")
    for f in out:
        assert f.read_bytes() == (HARDWARE / "proximity" / "fab" / f.name).read_bytes(), f.name
