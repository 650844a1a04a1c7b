"""Board checks: KiCad's ERC and DRC (with schematic parity), and the parts-database check.

    scripts/py -m r2ptools.kicad.check [BOARD_DIR…]     (default: every hardware/*/ with a .kicad_pro)

Reads KiCad's JSON reports (exit status alone does not say whether there were violations) and
prints one line per problem. Exit status 1 if any board has an ERC error, any DRC error or
warning, an unconnected item, a parity difference, a via inside an SMD pad (vias_in_pads), or a
symbol whose MPN/Manufacturer/LCSC is missing or disagrees with bom/parts.csv.
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

from .. import ROOT
from . import catalog, sexpr

HARDWARE = ROOT / "hardware"

# No DRC warning is accepted: silk.py places every reference and checks every board label, and
# fplib.py trims the library outlines that overhang the board edge or touch a neighbour, so any
# silkscreen warning (or any other) is a problem to fix in the description or the generator.


DRAWING_FAULTS = {"wire_dangling", "label_dangling", "unconnected_wire_endpoint",
                  "endpoint_off_grid", "no_connect_dangling", "pin_not_connected",
                  "isolated_pin_label", "similar_labels", "multiple_net_names"}
"""ERC warnings that are faults of a drawn schematic, not reviewed exceptions: a wire or label
that connects nothing, a pin or wire end off the 1.27 mm grid (it looks connected and is not),
two names on one net or names differing only in case."""


@dataclass
class Report:
    board: Path
    problems: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return not self.problems


def boards(root: Path = HARDWARE) -> list[Path]:
    return sorted(p.parent for p in root.glob("*/*.kicad_pro"))


def _run(cmd: list[str]) -> None:
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode not in (0, 5):   # 5: violations found (with --exit-code-violations)
        raise RuntimeError(f"{' '.join(cmd)} failed ({p.returncode}):\n{p.stdout}{p.stderr}")


def erc(sch: Path) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "erc.json"
        _run(["kicad-cli", "sch", "erc", "--format", "json", "--severity-all", "-o", str(out), str(sch)])
        return json.loads(out.read_text())


def drc(pcb: Path) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "drc.json"
        _run(["kicad-cli", "pcb", "drc", "--format", "json", "--severity-all", "--schematic-parity",
              "-o", str(out), str(pcb)])
        return json.loads(out.read_text())


def _exposed_pad(fp, pad) -> bool:
    """A package's exposed (thermal) pad or power tab: vias in it are thermal vias, not a fault.

    Told by size, as the footprint libraries do not flag it: a pad of a part with three or more
    pads, at least four times the area of the part's median pad (QFN/HTSSOP exposed pads are
    10-50 times their pins, a D2PAK's tab 20 times its leads; a two-terminal part's pads are
    never exposed pads). Open vias there still take solder paste down their barrels: a board
    with many of them orders them filled and capped (hardware/motor/README.md, "Before ordering")."""
    def area(p) -> int:              # a custom pad's size is its anchor's: take its outline's box
        box = p.GetBoundingBox()
        return box.GetWidth() * box.GetHeight()
    areas = sorted(area(p) for p in fp.Pads() if p.IsOnCopperLayer())
    return len(areas) >= 3 and area(pad) >= 4 * areas[len(areas) // 2]


def vias_in_pads(pcb: Path) -> list[str]:
    """Vias whose drill reaches into an SMD pad's copper (exposed pads excepted).

    An open hole in a pad wicks the pad's solder paste down the barrel during reflow: the joint
    starves (a tombstoned or dry capacitor) and solder balls out on the back. JLCPCB's standard
    process does not fill and cap vias, so a via belongs beside the pad, joined by copper."""
    import pcbnew

    b = pcbnew.LoadBoard(str(pcb))
    origin = b.GetDesignSettings().GetAuxOrigin()
    pads = [(fp, p) for fp in b.GetFootprints() for p in fp.Pads()   # paste-only apertures aside
            if p.GetAttribute() == pcbnew.PAD_ATTRIB_SMD and p.IsOnCopperLayer()]
    faults = []
    for v in b.GetTracks():
        if v.GetClass() != "PCB_VIA":
            continue
        at, r = v.GetPosition(), v.GetDrillValue() // 2
        for fp, p in pads:
            if p.HitTest(at, r) and not _exposed_pad(fp, p):
                x, y = pcbnew.ToMM(at.x - origin.x), pcbnew.ToMM(at.y - origin.y)
                faults.append(f"via ({v.GetNetname()}, {pcbnew.ToMM(v.GetDrillValue()):.2f} mm drill) "
                              f"at ({x:.2f}, {y:.2f}) mm is inside {fp.GetReference()} pad "
                              f"{p.GetNumber()}: move it beside the pad and join it with copper")
    return faults


def _items(v: dict) -> str:
    return "; ".join(i["description"] for i in v.get("items", []))


def symbol_fields(sch: Path, excluded: bool = False) -> list[tuple[str, str, dict[str, str]]]:
    """(file, reference, fields) of every placed symbol in `sch` and the sheets it uses.

    Symbols marked "exclude from BOM" (power flags, bare test pads) are parts of no order and
    are left out unless `excluded` asks for them."""
    out = []
    seen = set()
    todo = [sch]
    while todo:
        f = todo.pop()
        if f in seen:
            continue
        seen.add(f)
        tree = sexpr.parse(f.read_text())
        for s in sexpr.find_all(tree, "symbol"):
            in_bom = sexpr.find(s, "in_bom")
            if not excluded and in_bom is not None and str(in_bom[1]) == "no":
                continue
            props = {str(p[1]): str(p[2]) for p in sexpr.find_all(s, "property")}
            refs = {str(sexpr.find(path, "reference")[1])
                    for inst in sexpr.find_all(s, "instances")
                    for proj in sexpr.find_all(inst, "project")
                    for path in sexpr.find_all(proj, "path")} or {props.get("Reference", "?")}
            for r in sorted(refs):
                out.append((f.name, r, props))
        for sh in sexpr.find_all(tree, "sheet"):
            for p in sexpr.find_all(sh, "property"):
                if str(p[1]) == "Sheetfile":
                    todo.append((f.parent / str(p[2])).resolve())
    return out


def bom_fields(sch: Path, warnings: list[str] | None = None) -> list[str]:
    """Every symbol on the board must name an MPN whose bom/parts.csv row it agrees with.

    A row may leave LCSC empty for a part LCSC does not list (bought from TI or a distributor
    and consigned): the symbol must then leave it empty too, and it is reported as a warning."""
    rows = catalog.database()
    problems = []
    for file, ref, props in symbol_fields(sch):
        if ref.startswith("#"):
            continue                              # power flags: not parts
        mpn = props.get("MPN", "")
        if not mpn:
            problems.append(f"{file}: {ref}: no MPN field")
            continue
        row = rows.get(mpn)
        if row is None:
            problems.append(f"{file}: {ref}: MPN {mpn} has no row in bom/parts.csv")
            continue
        if not row["LCSC"] and not props.get("LCSC") and warnings is not None:
            warnings.append(f"{file}: {ref}: {mpn} has no LCSC part number (consigned part)")
        for k in ("Manufacturer", "LCSC"):
            if k == "LCSC" and not row["LCSC"] and not props.get("LCSC"):
                continue
            if not props.get(k):
                problems.append(f"{file}: {ref}: empty {k} field (bom/parts.csv says {row[k]!r})")
            elif props[k] != row[k]:
                problems.append(f"{file}: {ref}: {k} {props[k]!r} but bom/parts.csv says {row[k]!r}")
    return problems


def check(folder: Path) -> Report:
    name = folder.name
    sch, pcb = folder / f"{name}.kicad_sch", folder / f"{name}.kicad_pcb"
    r = Report(folder)
    e = erc(sch)
    for s in e["sheets"]:
        for v in s["violations"]:
            line = f"{name}: ERC {v['severity']} {v['type']} on sheet {s['path']}: {v['description']} ({_items(v)})"
            bad = v["severity"] == "error" or v["type"] in DRAWING_FAULTS
            (r.problems if bad else r.warnings).append(line)
    d = drc(pcb)
    for v in d["violations"]:
        r.problems.append(f"{name}: DRC {v['severity']} {v['type']}: {v['description']} ({_items(v)})")
    for v in d["unconnected_items"]:
        r.problems.append(f"{name}: DRC unconnected: {v['description']} ({_items(v)})")
    for v in d["schematic_parity"]:
        r.problems.append(f"{name}: parity {v['type']}: {v['description']} ({_items(v)})")
    r.problems += [f"{name}: via in pad: {f}" for f in vias_in_pads(pcb)]
    bom_warnings: list[str] = []
    r.problems += [f"{name}: BOM {p}" for p in bom_fields(sch, bom_warnings)]
    r.warnings += [f"{name}: BOM {w}" for w in bom_warnings]
    return r


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="scripts/py -m r2ptools.kicad.check",
                                 description=__doc__.split("\n")[0])
    ap.add_argument("boards", nargs="*", type=Path, metavar="BOARD_DIR",
                    help="board folders, each holding <name>.kicad_sch and <name>.kicad_pcb "
                         "(default: every hardware/*/ with a .kicad_pro)")
    args = ap.parse_args(argv)
    folders = args.boards or boards()
    for f in folders:
        missing = [p.name for p in (f / f"{f.name}.kicad_sch", f / f"{f.name}.kicad_pcb")
                   if not p.is_file()]
        if missing:
            print(f"check: {f} is not a board folder: no {' or '.join(missing)} in it; pass a "
                  f"folder such as hardware/psu (boards: {', '.join(b.name for b in boards())})",
                  file=sys.stderr)
            return 2
    bad = 0
    for f in folders:
        try:
            r = check(f)
        except RuntimeError as e:      # kicad-cli could not load a file: its own message says why
            print(f"check: {f}: {e}", file=sys.stderr)
            return 2
        for p in r.problems:
            print(p)
        print(f"{f.name}: {'OK' if r.ok else 'FAILED'} ({len(r.problems)} problems, "
              f"{len(r.warnings)} reviewed warnings)")
        bad += not r.ok
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
