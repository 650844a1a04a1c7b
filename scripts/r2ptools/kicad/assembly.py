"""The assembly drawing (PDF) and the pin-1 / polarity checklist of a fab package.

The drawing is KiCad's fabrication layers (F.Fab, B.Fab: part outlines with their pin-1
chamfers and cathode bars, references) with the pads sketched, a filled dot on pad 1 of every
polarised part, and the board outline: page 1 the top, page 2 the bottom mirrored (as
seen when the board is turned over). kicad-cli plots at 1:1 on the board's A4 sheet; the page is
cropped to the board so a viewer or printer scales it up.

The checklist lists every part whose orientation matters (everything but resistors,
non-polarised capacitors, fuses and inductors) with its CPL rotation and where pin 1 lies on our
board, to compare against JLCPCB's placement preview before paying for the order.
"""
from __future__ import annotations

import hashlib
import math
import re
import subprocess
import tempfile
from pathlib import Path

from .jlc import Part, correction, disputed
from .kicadcli import run as _kicad

PT_PER_MM = 72 / 25.4
MARGIN_MM = 4.0
UNPOLARISED = re.compile(r"^(R_\d{4}_|C_\d{4}_|Fuse_|L_)")
"""Footprints whose two (or more) terminals may be swapped: no orientation to check."""


def polarised(p: Part) -> bool:
    return not UNPOLARISED.match(p.footprint)


def _crop(pdf: bytes, box_mm: tuple[float, float, float, float], mirror_width_mm: float | None) -> bytes:
    """Sets the page's MediaBox to the board (same length, so the xref offsets stay valid)."""
    m = re.search(rb"/MediaBox \[([^\]]*)\]", pdf)
    _, _, w, h = (float(v) for v in m.group(1).split())
    x0, y0, x1, y1 = box_mm
    if mirror_width_mm is not None:        # --mirror flips x about the page's centre
        x0, x1 = mirror_width_mm - x1, mirror_width_mm - x0
    box = (math.floor((x0 - MARGIN_MM) * PT_PER_MM), math.floor(h - (y1 + MARGIN_MM) * PT_PER_MM),
           math.ceil((x1 + MARGIN_MM) * PT_PER_MM), math.ceil(h - (y0 - MARGIN_MM) * PT_PER_MM))
    new = " ".join(str(v) for v in box).encode()
    old = m.group(1)
    if len(new) > len(old):
        raise RuntimeError(f"assembly drawing: crop box {new!r} longer than {old!r}")
    return pdf[:m.start(1)] + new.ljust(len(old)) + pdf[m.end(1):]


def _fixed_id(pdf: bytes) -> bytes:
    """pdfunite writes a random document /ID into the trailer; the trailer follows the xref
    table, so replacing it (with a hash of the rest) moves no object."""
    i = pdf.rfind(b"trailer")
    a = pdf.find(b"/ID [", i)
    if i < 0 or a < 0:
        return pdf
    b = pdf.find(b"] /Root", a)
    if b < 0:
        raise RuntimeError("assembly drawing: pdfunite's trailer has an unexpected form")
    digest = hashlib.md5(pdf[:i]).hexdigest().encode()
    return pdf[:a] + b"/ID [<" + digest + b"> <" + digest + b">" + pdf[b:]


PIN1_DOT_MM = 0.5


def _marked_copy(pcb: Path, folder: Path) -> Path:
    """A copy of the board with a filled dot on the fabrication layer at pad 1 of every
    polarised part, so the drawing marks pin 1 even where a library outline does not."""
    import pcbnew
    board = pcbnew.LoadBoard(str(pcb))
    for fp in board.Footprints():
        name = str(fp.GetFPID().GetLibItemName())
        one = next((p for p in fp.Pads() if p.GetNumber() == "1"), None)
        if one is None or UNPOLARISED.match(name) or fp.GetAttributes() & pcbnew.FP_EXCLUDE_FROM_BOM:
            continue
        dot = pcbnew.PCB_SHAPE(board, pcbnew.SHAPE_T_CIRCLE)
        dot.SetLayer(pcbnew.B_Fab if fp.IsFlipped() else pcbnew.F_Fab)
        dot.SetCenter(one.GetPosition())
        dot.SetEnd(one.GetPosition() + pcbnew.VECTOR2I(pcbnew.FromMM(PIN1_DOT_MM / 2), 0))
        dot.SetFilled(True)
        dot.SetWidth(0)
        board.Add(dot)
    copy = folder / pcb.name
    pcbnew.SaveBoard(str(copy), board)
    return copy


def drawing(pcb: Path, board_box_mm: tuple[float, float, float, float], dest: Path,
            pin_dates) -> None:
    """Two-page PDF: top (F.Fab), bottom (B.Fab, mirrored), each with the board outline."""
    with tempfile.TemporaryDirectory() as tmp:
        pcb = _marked_copy(pcb, Path(tmp))
        pages = []
        for side, layer, mirror in (("top", "F.Fab", False), ("bottom", "B.Fab", True)):
            out = Path(tmp) / f"{side}.pdf"
            _kicad("pcb", "export", "pdf", "--layers", f"{layer},Edge.Cuts",
                   "--sketch-pads-on-fab-layers", "--exclude-value", "--mode-single",
                   *(["--mirror"] if mirror else []), "-o", str(out), str(pcb))
            data = out.read_bytes()
            w_mm = float(re.search(rb"/MediaBox \[\S+ \S+ (\S+)", data).group(1)) / PT_PER_MM
            out.write_bytes(pin_dates(_crop(data, board_box_mm, w_mm if mirror else None)))
            pages.append(str(out))
        both = Path(tmp) / "assembly.pdf"
        p = subprocess.run(["pdfunite", *pages, str(both)], capture_output=True, text=True)
        if p.returncode != 0:
            raise RuntimeError(f"pdfunite failed (poppler-utils, installed by scripts/setup):\n{p.stderr}")
        dest.write_bytes(_fixed_id(pin_dates(both.read_bytes())))


def _where(p: Part) -> str:
    """Pin 1's direction from the part's centre, as seen on the side it is placed on."""
    if p.pin1 is None:
        return "no pad 1"
    dx, dy = p.pin1[0] - p.x, p.pin1[1] - p.y
    if p.bottom:
        dx = -dx                            # seen from below, left and right swap
    if math.hypot(dx, dy) < 0.05:
        return "at the centre"
    angle = math.degrees(math.atan2(dy, dx)) % 360
    names = ["right", "upper right", "top", "upper left", "left", "lower left", "bottom", "lower right"]
    return names[int(((angle + 22.5) % 360) // 45)]


def _pin1_name(p: Part) -> str:
    if p.ref.startswith(("D", "LED")) and p.footprint.startswith(("D_", "LED_")):
        return "cathode (pad 1)"
    return "pin 1"


def checklist(name: str, placed: list[Part], dest: Path) -> list[Part]:
    """Writes <module>-assembly-checklist.md; returns the parts it lists."""
    parts = [p for p in placed if polarised(p)]
    lines = [
        f"# {name}: pin 1 and polarity checklist for JLCPCB's placement preview",
        "",
        "Generated by scripts/fab from the board. Before paying for an assembled order, open the",
        "order's component placement preview and check, for each part below, that JLC's part",
        "shows its pin-1 / cathode mark where this list says (directions as seen looking at that",
        "side of the board, bottom side as seen from below). The CPL's rotations are already",
        "corrected for JLC's library (docs/hardware.md, \"Fab packages\"); a part that still",
        "looks wrong in the preview is a new case for `jlc.OVERRIDES`. Through-hole parts are",
        "fitted by hand against the silkscreen outline.",
        "",
        "| Ref | Part | Package | Side | KiCad rot | CPL rot | Pin 1 / cathode | Correction |",
        "|---|---|---|---|---|---|---|---|",
    ]
    notes: dict[str, str] = {}
    for p in parts:
        mpn = p.fields.get("MPN", "") or p.value
        kind = " (THT)" if p.through_hole else ""
        source = correction(p.footprint)[1].split(":")[0]
        why = disputed(p.footprint)
        if why:
            mark = notes.setdefault(why, f"[{len(notes) + 1}]")
            source = f"**{source}, disputed {mark}: check first**"
        lines.append(f"| {p.ref} | {mpn} | {p.footprint}{kind} | {'bottom' if p.bottom else 'top'} | "
                     f"{p.kicad_rotation % 360:g} | {p.rotation:g} | {_pin1_name(p)}: {_where(p)} | "
                     f"{source} |")
    lines += ["", f"{len(parts)} parts to check; resistors, non-polarised capacitors, fuses and "
              "inductors are not listed (either way round is right).", ""]
    for why, mark in notes.items():
        lines += [f"{mark} {why[0].upper()}{why[1:]}. If JLC's preview shows the part turned, "
                  "correct it there and record the angle in `jlc.OVERRIDES`.", ""]
    dest.write_text("\n".join(lines))
    return parts
