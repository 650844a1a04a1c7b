"""JLCPCB's assembly files: the BOM in its columns and the CPL with its part orientations.

JLCPCB's 0° for a part is its orientation in the carrier tape (sprocket holes on the left),
which differs from KiCad's IPC-7351 zero for many packages: an LQFP or SOIC is 90° off, a
SOT-23 180° (or 90°: see DISPUTED). Rather than invent corrections, the table the field's tools share is used: KiBot's
JLCPCB rotation table (`kibot.misc.DEFAULT_ROTATIONS`, imported from the pinned PyPI package,
itself grown from matthewlai/JLCKicadTools' cpl_rotations_db.csv, which Bouni's
kicad-jlcpcb-tools also loads), with the same arithmetic as KiBot's `_rot_footprint_jlcpcb`
filter and kicad-jlcpcb-tools' `fix_rotation`:

    top:    (KiCad rotation + correction) mod 360
    bottom: (180 − KiCad rotation + correction) mod 360    (JLC views the bottom un-mirrored)

`OVERRIDES` (below) holds the footprints where our boards need something else, each with its
reason; it is searched first. Positions are the centre of the footprint's pads (as
kicad-jlcpcb-tools does), not KiCad's footprint origin: a through-hole connector's origin is
its pin 1, and the centre of the pads is where JLC's own footprint is centred. KiBot's origin
offsets (for footprints whose origin is pin 1) are therefore not used: its row for the
through-hole 2x5 1.27 mm header also matches our SMD variant (same pin pattern, so the same
rotation is right), but the SMD variant's origin is its centre and KiBot's own JLCPCB output
moves our SWD header J4 by 2.6 mm with it.

tests/test_fab.py checks every polarised part's rotation against a statement of where JLC's
part has pin 1, without this table. KiBot (GPL/AGPL) is a build-time dependency whose table is
imported at run time, not copied into this MIT/Apache code.
"""
from __future__ import annotations

import csv
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

from kibot.misc import DEFAULT_ROTATIONS as KIBOT_ROTATIONS

BOM_COLUMNS = ["Comment", "Designator", "Footprint", "LCSC Part #", "Manufacturer", "MPN"]
"""JLCPCB's BOM template columns (Comment, Designator, Footprint, LCSC Part #) plus the maker's."""
CPL_COLUMNS = ["Designator", "Mid X", "Mid Y", "Layer", "Rotation"]
"""JLCPCB's CPL template columns."""
LCSC_PART = re.compile(r"C\d+")


@dataclass(frozen=True)
class Override:
    pattern: str
    """Regular expression matched against the whole footprint name (no library)."""
    correction: float
    """Degrees counter-clockwise added to KiCad's rotation (as in KiBot's table)."""
    reason: str


OVERRIDES = [
    Override(r"Texas_RNP0030B_WQFN-30-1EP_4x6mm_P0\.5mm_EP1\.8x4\.5mm", 270,
             "a quad no-lead package like the table's QFN/DFN rows (270: KiCad's pin 1 at the "
             "top of the left side, JLC's at the left end of the bottom side); the table's QFN "
             "patterns are anchored at the start of the name and miss TI's 'Texas_…_WQFN-30' "
             "name, so without this row the LM76005 would be placed 90° off"),
]


DISPUTED = {
    r"SOT-23(-\d)?": (
        "180 (used) has most of the evidence: KiBot 1.9.1's table, the jlcpcba rotations file, "
        "kicad-jlcpcb-tools' default ^SOT-23-6 180 (Bouni/kicad-jlcpcb-tools#472) and a reported "
        "upload that came out 180° off without it (Combinatix/JLCPCB-Basic-Parts#1); "
        "JLCKicadTools' cpl_rotations_db.csv says -90 after one checked upload "
        "(matthewlai/JLCKicadTools#105), and its maintainer answered there that JLC's 0° follows "
        "each part's orientation on its reel, so no footprint table can be right for every maker: "
        "look at every SOT-23 in the preview"),
    r"PinHeader_2x05_P1\.27mm_Vertical(_SMD)?": (
        "the tools disagree: KiBot 1.9.1's table says -90, JLCKicadTools master says +90; no "
        "upload report found either way (2026-11)"),
    r"(ST_H)?LGA-1[024]_.*": (
        "no table has a correction for ST's LGA/HLGA sensors (KiCad's IPC-7351 zero used: pin 1 "
        "upper left); no upload report found (2026-11): check the LSM6DSO, LIS3MDL and LPS22HH "
        "(pin-1 dot, and the LPS22HH's vent hole up) in the preview"),
}
"""Footprints whose correction the field's tables disagree on: the CPL uses KiBot's, and the
checklist asks for these to be looked at first in JLC's placement preview."""


def disputed(footprint: str) -> str | None:
    return next((why for pattern, why in DISPUTED.items() if re.fullmatch(pattern, footprint)), None)


def correction(footprint: str) -> tuple[float, str]:
    """(degrees, where the correction comes from) for a footprint name without library."""
    for o in OVERRIDES:
        if re.fullmatch(o.pattern, footprint):
            return o.correction, f"override: {o.reason}"
    for pattern, angle in KIBOT_ROTATIONS:
        if re.search(pattern, footprint):
            return float(angle), f"KiBot table: {pattern} {angle:g}"
    return 0.0, "none (JLC's library has KiCad's orientation)"


def jlc_rotation(footprint: str, kicad_rotation: float, bottom: bool) -> float:
    """The CPL rotation JLCPCB needs for a footprint KiCad has at `kicad_rotation` degrees."""
    base = 180.0 - kicad_rotation if bottom else kicad_rotation
    return round((base + correction(footprint)[0]) % 360.0, 3) % 360.0


@dataclass(frozen=True)
class Part:
    """One placed footprint, in the CPL's frame: mm from the board's drill/aux origin, y up."""
    ref: str
    value: str
    footprint: str
    library: str
    x: float
    y: float
    bottom: bool
    kicad_rotation: float
    rotation: float
    pin1: tuple[float, float] | None
    """Pad 1's centre (same frame), None if the footprint has no pad 1."""
    through_hole: bool
    fields: dict[str, str] = field(default_factory=dict)


def _ref_key(ref: str) -> tuple[str, int]:
    head = ref.rstrip("0123456789")
    return head, int(ref[len(head):] or 0)


def parts(pcb: Path, board=None) -> tuple[list[Part], list[Part]]:
    """(placed parts, BOM parts) of a board, sorted by reference: the BOM has the footprints
    KiCad would put in its BOM (not DNP, not board-only, not excluded from the BOM); the CPL those
    of them KiCad would also put in its position file. A fiducial (in KiCad's position file but
    not its BOM) stays out of the CPL: JLC would flag a placement without a BOM line."""
    import pcbnew
    b = board or pcbnew.LoadBoard(str(pcb))
    origin = b.GetDesignSettings().GetAuxOrigin()
    placed, bom = [], []
    for fp in b.Footprints():
        attrs = fp.GetAttributes()
        if fp.IsDNP() or attrs & pcbnew.FP_BOARD_ONLY:
            continue
        pads = [p for p in fp.Pads()]
        box = None
        for p in pads:
            bb = p.GetBoundingBox()
            if box is None:
                box = bb
            else:
                box.Merge(bb)
        centre = box.GetCenter() if box is not None else fp.GetPosition()
        one = next((p for p in pads if p.GetNumber() == "1"), None)

        def mm(v):
            return (round(pcbnew.ToMM(v.x - origin.x), 4), round(-pcbnew.ToMM(v.y - origin.y), 4))

        name = str(fp.GetFPID().GetLibItemName())
        bottom = fp.IsFlipped()
        rot = fp.GetOrientationDegrees()
        x, y = mm(centre)
        fields = {k: str(v) for k, v in fp.GetFieldsText().items()}
        part = Part(ref=fp.GetReference(), value=fp.GetValue(), footprint=name,
                    library=str(fp.GetFPID().GetLibNickname()), x=x, y=y, bottom=bottom,
                    kicad_rotation=rot, rotation=jlc_rotation(name, rot, bottom),
                    pin1=mm(one.GetPosition()) if one is not None else None,
                    through_hole=bool(attrs & pcbnew.FP_THROUGH_HOLE), fields=fields)
        if attrs & pcbnew.FP_EXCLUDE_FROM_BOM:
            continue                 # fiducials, test points, logos: nothing for JLC to place
        bom.append(part)
        if not attrs & pcbnew.FP_EXCLUDE_FROM_POS_FILES and pads:
            placed.append(part)
    placed.sort(key=lambda p: _ref_key(p.ref))
    bom.sort(key=lambda p: _ref_key(p.ref))
    return placed, bom


def write_cpl(placed: list[Part], dest: Path) -> None:
    with dest.open("w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(CPL_COLUMNS)
        for p in placed:
            w.writerow([p.ref, f"{p.x:.4f}mm", f"{p.y:.4f}mm", "Bottom" if p.bottom else "Top",
                        f"{p.rotation:.2f}"])


def write_bom(bom: list[Part], dest: Path) -> None:
    """One line per (value, footprint, LCSC, manufacturer, MPN), designators comma-separated."""
    groups: dict[tuple, list[str]] = {}
    for p in bom:
        key = (p.value, p.footprint, p.fields.get("LCSC", ""), p.fields.get("Manufacturer", ""),
               p.fields.get("MPN", ""))
        groups.setdefault(key, []).append(p.ref)
    rows = sorted(((refs, k) for k, refs in groups.items()), key=lambda r: _ref_key(r[0][0]))
    with dest.open("w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(BOM_COLUMNS)
        for refs, (value, fp, lcsc, man, mpn) in rows:
            w.writerow([value, ",".join(refs), fp, lcsc, man, mpn])


def bom_problems(bom_csv: Path) -> list[str]:
    """What JLCPCB would not take as is: other columns, or a line without an LCSC part
    (JLC would treat it as consigned: the maker must buy and ship it)."""
    with bom_csv.open(newline="") as f:
        rows = list(csv.reader(f))
    if not rows or rows[0] != BOM_COLUMNS:
        return [f"{bom_csv.name}: columns are {rows[0] if rows else 'missing'}, JLCPCB's are "
                f"{BOM_COLUMNS}: regenerate with scripts/fab"]
    problems = []
    for n, row in enumerate(rows[1:], start=2):
        if len(row) != len(BOM_COLUMNS):
            problems.append(f"{bom_csv.name}:{n}: {len(row)} fields, expected {len(BOM_COLUMNS)}")
            continue
        d = dict(zip(BOM_COLUMNS, row))
        if not LCSC_PART.fullmatch(d["LCSC Part #"]):
            problems.append(f"{bom_csv.name}:{n}: {d['Designator']} ({d['MPN'] or d['Comment']}) "
                            f"has no LCSC part ({d['LCSC Part #']!r}): JLCPCB would need it "
                            "consigned; pick a part LCSC stocks (bom/parts.csv, catalog.py)")
        if not d["MPN"] or not d["Manufacturer"]:
            problems.append(f"{bom_csv.name}:{n}: {d['Designator']} has no manufacturer/MPN")
    return problems


def cpl_problems(cpl_csv: Path, placed: list[Part]) -> list[str]:
    """The CPL must have JLC's columns and, for every placed part, JLC's rotation."""
    with cpl_csv.open(newline="") as f:
        rows = list(csv.reader(f))
    if not rows or rows[0] != CPL_COLUMNS:
        return [f"{cpl_csv.name}: columns are {rows[0] if rows else 'missing'}, JLCPCB's are "
                f"{CPL_COLUMNS}"]
    got = {r[0]: r for r in rows[1:]}
    problems = []
    for p in placed:
        r = got.get(p.ref)
        if r is None:
            problems.append(f"{cpl_csv.name}: {p.ref} is placed but missing")
        elif not math.isclose(float(r[4]) % 360, p.rotation, abs_tol=0.01):
            problems.append(f"{cpl_csv.name}: {p.ref} ({p.footprint}) rotation {r[4]}, JLC needs "
                            f"{p.rotation:g} (KiCad {p.kicad_rotation:g}, "
                            f"{'bottom' if p.bottom else 'top'}; {correction(p.footprint)[1]})")
    return problems
