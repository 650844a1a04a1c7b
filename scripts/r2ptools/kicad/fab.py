"""`make fab`: each board's fab package, byte for byte reproducible, into hardware/<module>/fab/.

    scripts/fab [MODULE…] [--out DIR]

    gerbers/          Gerber X2 (copper, mask, paste, silk, outline), Excellon drill (PTH and
                      NPTH apart), Gerber job file: what a fab needs to make the bare board
    <module>-gerbers.zip  the same files zipped for upload (fixed timestamps and order)
    <module>-bom.csv  JLCPCB's BOM: Comment, Designator, Footprint, LCSC Part #, Manufacturer, MPN
    <module>-cpl.csv  JLCPCB's CPL (Designator, Mid X, Mid Y, Layer, Rotation), rotations
                      corrected for JLC's part orientations (jlc.py), from the drill origin
    <module>-ibom.html    interactive HTML BOM (ibom.py)
    <module>-assembly.pdf assembly drawing: top, then bottom mirrored (assembly.py)
    <module>-assembly-checklist.md  pin 1 / polarity of every polarised part, for JLC's preview
    <module>-schematic.pdf
    <module>-netlist.txt       components and nets, sorted: the circuit as reviewers diff it
    <module>-schematic.png     the largest block of the module's own sheet, for its README
    <module>-top.png, <module>-bottom.png   renders with KiCad's 3D models (models3d.py)

KiCad stamps the date into Gerber, drill, job and PDF files; those stamps are removed or pinned
to 1980-01-01 (the zip epoch) so that regenerating from unchanged sources gives identical
bytes, which the tests check.
"""
from __future__ import annotations

import argparse
import io
import re
import shutil
import sys
import zipfile
from pathlib import Path

from .. import ROOT, manifest
from . import assembly, ibom, jlc, models3d
from .kicadcli import run as _kicad

HARDWARE = ROOT / "hardware"
FAB_BOARDS = [m.name for m in manifest.load(check_tree=False) if m.fab]
"""Boards with a committed fab package: `fab = true` in modules.toml (the template is checked but
not manufactured)."""

GERBER_LAYERS = ["F.Cu", "B.Cu", "F.Paste", "B.Paste", "F.SilkS", "B.SilkS", "F.Mask", "B.Mask",
                 "Edge.Cuts"]
ZIP_DATE = (1980, 1, 1, 0, 0, 0)
PDF_DATE = b"D:19800101000000+00'00'"

_DATE_LINES = [
    re.compile(r"^%TF\.CreationDate,.*\*%\r?\n", re.M),
    re.compile(r"^; #@! TF\.CreationDate,.*\r?\n", re.M),
    re.compile(r'^\s*"CreationDate":\s*".*",?\r?\n', re.M),
]


def strip_dates(text: str) -> str:
    """Removes KiCad's creation-date stamps from Gerber, Excellon and job files."""
    for rx in _DATE_LINES:
        text = rx.sub("", text)
    text = re.sub(r"^(G04 Created by KiCad \(.*?\)) date .*\*$", r"\1*", text, flags=re.M)
    text = re.sub(r"^(; DRILL file \{.*?\}) date .*$", r"\1", text, flags=re.M)
    return text


def pin_pdf_dates(data: bytes) -> bytes:
    """Same-length replacement of the PDF's date strings (keeps the xref offsets valid)."""
    def fix(m: re.Match) -> bytes:
        inner = m.group(2)
        new = PDF_DATE[:len(inner)].ljust(len(inner), b" ")
        return m.group(1) + new + m.group(3)
    return re.sub(rb"(/(?:CreationDate|ModDate)\s*\()([^)]*)(\))", fix, data)


def gerbers(pcb: Path, out: Path) -> list[Path]:
    out.mkdir(parents=True, exist_ok=True)
    layers = list(GERBER_LAYERS)
    if "(layers" in (text := pcb.read_text()) and '"In1.Cu"' in text.split("(setup", 1)[0]:
        layers[1:1] = ["In1.Cu", "In2.Cu"]          # a 4-layer board's planes
    _kicad("pcb", "export", "gerbers", "--layers", ",".join(layers), "--subtract-soldermask",
           "--use-drill-file-origin", "-o", str(out) + "/", str(pcb))
    _kicad("pcb", "export", "drill", "--format", "excellon", "--excellon-units", "mm",
           "--excellon-separate-th", "--drill-origin", "plot", "-o", str(out) + "/", str(pcb))
    files = sorted(p for p in out.iterdir() if p.is_file())
    for f in files:
        f.write_text(strip_dates(f.read_text()))
    return files


def write_zip(files: list[Path], dest: Path) -> None:
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as z:
        for f in sorted(files, key=lambda p: p.name):
            info = zipfile.ZipInfo(f.name, date_time=ZIP_DATE)
            info.external_attr = 0o644 << 16
            info.compress_type = zipfile.ZIP_DEFLATED
            z.writestr(info, f.read_bytes())
    dest.write_bytes(buf.getvalue())


def schematic_pdf(sch: Path, dest: Path) -> None:
    _kicad("sch", "export", "pdf", "-o", str(dest), str(sch))
    dest.write_bytes(pin_pdf_dates(dest.read_bytes()))


def netlist_text(sch: Path, dest: Path) -> None:
    """The circuit as reviewers diff it: every component (reference, value, footprint, MPN) and
    every net with its pins, sorted, from KiCad's own netlist of the sheets. Regenerated with the
    package, so a drawing change that is not a circuit change leaves it byte for byte the same."""
    from . import netlist
    net = netlist.export(sch)
    lines = ["# components: reference, value, footprint, MPN"]
    for ref in sorted(net.components, key=_natural):
        c = net.components[ref]
        lines.append(f"{ref}\t{c.value}\t{c.footprint}\t{c.fields.get('MPN', '')}")
    lines.append("# nets: name, then reference.pin of every pin on it")
    for name in sorted(net.nets):
        pins = sorted(net.nets[name], key=lambda rp: (_natural(rp[0]), _natural(rp[1])))
        lines.append(name + "\t" + " ".join(f"{r}.{p}" for r, p in pins))
    dest.write_text("\n".join(lines) + "\n")


def _natural(s: str) -> tuple:
    return tuple(int(t) if t.isdigit() else t for t in re.split(r"(\d+)", s))


def main_block_png(sch: Path, dest: Path) -> None:
    """The largest functional block of the module's own sheet (its dashed frame), as a picture
    for the module's README; the whole sheet if it has no blocks."""
    from . import sexpr, sheet_png
    tree = sexpr.parse(sch.read_text())
    boxes = []
    for r in sexpr.find_all(tree, "rectangle"):
        (x0, y0), (x1, y1) = ((float(sexpr.find(r, k)[1]), float(sexpr.find(r, k)[2]))
                              for k in ("start", "end"))
        boxes.append(((x1 - x0) * (y1 - y0), (x0 - 2, y0 - 2, x1 + 2, y1 + 2)))
    crop = max(boxes)[1] if boxes else None
    sheet_png.render(sch, dest, page=1, crop=crop, dpi=110)


def renders(pcb: Path, folder: Path, name: str) -> list[Path]:
    """Top and bottom renders with the 3D models KiCad ships for our footprints."""
    env = {"KICAD9_3DMODEL_DIR": str(models3d.ensure([pcb]))}
    out = []
    for side in ("top", "bottom"):
        dest = folder / f"{name}-{side}.png"
        _kicad("pcb", "render", "--side", side, "--width", "1200", "--height", "1000",
               "--quality", "basic", "--background", "opaque", "--zoom", "1.0", "-o", str(dest), str(pcb),
               env=env)
        out.append(dest)
    return out


def board_box_mm(pcb: Path) -> tuple[float, float, float, float]:
    """The board outline's bounding box in page millimetres (x0, y0, x1, y1)."""
    import pcbnew
    bb = pcbnew.LoadBoard(str(pcb)).GetBoardEdgesBoundingBox()
    return (pcbnew.ToMM(bb.GetLeft()), pcbnew.ToMM(bb.GetTop()), pcbnew.ToMM(bb.GetRight()),
            pcbnew.ToMM(bb.GetBottom()))


def package(board_dir: Path, out: Path) -> list[Path]:
    """Writes the fab package of `board_dir` into `out` (replaced entirely)."""
    name = board_dir.name
    pcb, sch = board_dir / f"{name}.kicad_pcb", board_dir / f"{name}.kicad_sch"
    if out.exists():
        shutil.rmtree(out)
    out.mkdir(parents=True)
    files = gerbers(pcb, out / "gerbers")
    write_zip(files, out / f"{name}-gerbers.zip")
    placed, bom_parts = jlc.parts(pcb)
    jlc.write_bom(bom_parts, out / f"{name}-bom.csv")
    jlc.write_cpl(placed, out / f"{name}-cpl.csv")
    ibom.interactive_bom(pcb, out / f"{name}-ibom.html")
    assembly.drawing(pcb, board_box_mm(pcb), out / f"{name}-assembly.pdf", pin_pdf_dates)
    assembly.checklist(name, placed, out / f"{name}-assembly-checklist.md")
    schematic_pdf(sch, out / f"{name}-schematic.pdf")
    netlist_text(sch, out / f"{name}-netlist.txt")
    main_block_png(sch, out / f"{name}-schematic.png")
    renders(pcb, out, name)
    for problem in jlc.bom_problems(out / f"{name}-bom.csv"):
        print(f"fab: {name}: JLCPCB would not take this BOM as is: {problem}", file=sys.stderr)
    return sorted(p for p in out.rglob("*") if p.is_file())


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="scripts/fab", description=__doc__.split("\n")[0])
    ap.add_argument("modules", nargs="*", help=f"boards (default: {', '.join(FAB_BOARDS)})")
    ap.add_argument("--hardware", type=Path, default=HARDWARE, help="hardware folder to read")
    ap.add_argument("--out", type=Path, default=None,
                    help="write packages under OUT/<module>/fab instead of the hardware folder")
    args = ap.parse_args(argv)
    names = args.modules or [n for n in FAB_BOARDS if (args.hardware / n / f"{n}.kicad_pcb").exists()]
    for n in names:
        src = args.hardware / n
        if not (src / f"{n}.kicad_pcb").exists():
            have = [b for b in FAB_BOARDS if (args.hardware / b / f"{b}.kicad_pcb").exists()]
            how = (f"generate it with scripts/hwgen {n}" if n in FAB_BOARDS
                   else f"{n} is not one of the boards ({', '.join(FAB_BOARDS)})")
            print(f"fab: no board {src / (n + '.kicad_pcb')}: {how}; boards present in "
                  f"{args.hardware}: {', '.join(have) or 'none'}", file=sys.stderr)
            return 2
        dest = (args.out or args.hardware) / n / "fab"
        try:
            files = package(src, dest)
        except RuntimeError as e:            # a missing tool or model package: the message says what to do
            print(f"fab: {n}: {e}", file=sys.stderr)
            return 2
        print(f"fab: {n}: {len(files)} files in {dest}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
