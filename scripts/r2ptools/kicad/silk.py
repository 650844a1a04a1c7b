"""Silkscreen layout: every reference readable beside its part, nothing over pads or the edge.

A maker assembling by hand reads the designators, and a fab clips silk that lands on a pad's
solder-mask opening or the board edge; so the generator lays the silkscreen out itself and DRC
accepts no reference or label in a silkscreen warning (check.py). Three steps, on the board:

1. **Board labels** (module name, BUS IN/OUT, TERM, pin labels…, from the description) are
   deliberate and fixed: one that touches a pad, the edge or another label is an error naming it
   (move it in the description).
2. **Footprint outlines and pin-1 marks** are obstacles here, not edited: they are the KiCad
   library's, or, where a library outline overhangs the board edge or touches a neighbour (the
   RJ45, XT30 and JST PH bodies, the PSU's eFuse beside J2's arrow), the trimmed variant from
   the project library that fplib.py swapped in after routing.
3. **References**: each is tried beside its part, rotated with it (0/180° parts read
   left-to-right, 90/270° parts bottom-to-top), on the sides in a fixed order (a horizontal part
   above, below, left, right; a vertical one left, right, above, below), centred and then slid
   along the side; 1.0 mm text first, then JLCPCB's 0.8 mm minimum, then the other rotation. The
   first candidate clear of pads (0.15 mm), outlines, labels, other parts' bodies (their F.Fab
   outline: silk there is hidden once the part is fitted), the edge (0.3 mm) and the references
   already placed wins; parts with the fewest clear candidates choose first. A part with no
   room keeps its reference on the assembly layer (F.Fab) only, hidden on the silk.

Reference and label positions are not part of the Specctra DSN, so this changes no routing key.
Everything is in KiCad's integer units and sorted, so the result is the same bytes every time.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import pcbnew

from .board import BOARD_H, BOARD_W, ORIGIN, mm, outline_size

REF_SIZES = (1.0, 0.8)
"""Reference text heights tried, mm; 0.8 mm is JLCPCB's minimum (fabcap.MIN_TEXT_HEIGHT)."""
REF_LINE = 0.15
"""Reference stroke, mm (JLCPCB's 0.15 mm minimum)."""
GAP_PART = 0.15          # reference to its own part's pads and outline
GAP_MASK = 0.15          # silk to any solder-mask opening (a pad)
GAP_SILK = 0.15          # text to other silk
GAP_EDGE = 0.3           # silk to the board edge
SLIDES = (0.0, 0.5, -0.5, 1.0, -1.0, 1.5, -1.5, 2.0, -2.0, 2.5, -2.5)
"""Offsets along a side (mm) tried for each side, centred first."""


class SilkError(ValueError):
    """A board label over a pad, an outline, another label or the edge; the message names it."""


@dataclass
class Report:
    placed: int = 0
    shrunk: list[str] = field(default_factory=list)      # references at the 0.8 mm fallback
    turned: list[str] = field(default_factory=list)      # references in the other rotation
    hidden: list[str] = field(default_factory=list)      # references left on F.Fab only

    def summary(self) -> str:
        return (f"silk: {self.placed} references placed, {len(self.shrunk)} at 0.8 mm "
                f"({', '.join(self.shrunk) or '-'}), {len(self.turned)} turned "
                f"({', '.join(self.turned) or '-'}), {len(self.hidden)} hidden "
                f"({', '.join(self.hidden) or '-'})")


@dataclass
class Obstacle:
    box: tuple[int, int, int, int]       # x0, y0, x1, y1 (internal units)
    shape: object                        # a pcbnew SHAPE
    what: str


def _box(b: pcbnew.BOX2I) -> tuple[int, int, int, int]:
    return (b.GetX(), b.GetY(), b.GetX() + b.GetWidth(), b.GetY() + b.GetHeight())


def _near(a, b, gap: int) -> bool:
    return a[0] - gap <= b[2] and b[0] - gap <= a[2] and a[1] - gap <= b[3] and b[1] - gap <= a[3]


def _hits(shape, box, obstacles: list[Obstacle], gap: int) -> Obstacle | None:
    for o in obstacles:
        if _near(box, o.box, gap) and shape.Collide(o.shape, gap):
            return o
    return None


def _inside(box, gap: int, size: tuple[float, float] = (BOARD_W, BOARD_H)) -> bool:
    """Within the board outline (`size`, mm) less `gap` (the 2 mm corner arcs are edge obstacles too)."""
    x0, y0 = mm(ORIGIN[0]) + gap, mm(ORIGIN[1]) + gap
    x1, y1 = mm(ORIGIN[0] + size[0]) - gap, mm(ORIGIN[1] + size[1]) - gap
    return box[0] >= x0 and box[1] >= y0 and box[2] <= x1 and box[3] <= y1


class Layout:
    def __init__(self, board: pcbnew.BOARD):
        self.board = board
        self.size = outline_size(board)
        self.fps = sorted(board.GetFootprints(), key=lambda f: f.GetReference())
        self.edge = [Obstacle(_box(d.GetBoundingBox()), d.GetEffectiveShape(pcbnew.Edge_Cuts), "edge")
                     for d in board.GetDrawings() if d.GetLayer() == pcbnew.Edge_Cuts]
        self.mask: dict[int, list[Obstacle]] = {}       # silk layer -> pad openings on its side
        self.silk: dict[int, list[Obstacle]] = {pcbnew.F_SilkS: [], pcbnew.B_SilkS: []}
        self.bodies: dict[int, list[tuple[str, tuple]]] = {pcbnew.F_SilkS: [], pcbnew.B_SilkS: []}
        for silk, mask in ((pcbnew.F_SilkS, pcbnew.F_Mask), (pcbnew.B_SilkS, pcbnew.B_Mask)):
            self.mask[silk] = [
                Obstacle(_box(p.GetBoundingBox()), p.GetEffectiveShape(mask), f"pad {f.GetReference()}.{p.GetNumber()}")
                for f in self.fps for p in f.Pads() if p.IsOnLayer(mask)]
        for f in self.fps:
            side = pcbnew.B_SilkS if f.IsFlipped() else pcbnew.F_SilkS
            fab = pcbnew.B_Fab if f.IsFlipped() else pcbnew.F_Fab
            boxes = [_box(g.GetBoundingBox()) for g in f.GraphicalItems()
                     if g.GetLayer() == fab and isinstance(g, pcbnew.PCB_SHAPE)]
            if boxes:
                self.bodies[side].append((f.GetReference(), (min(b[0] for b in boxes), min(b[1] for b in boxes),
                                                             max(b[2] for b in boxes), max(b[3] for b in boxes))))
        self.report = Report()

    # --- 1. labels -------------------------------------------------------------------------
    def labels(self) -> None:
        texts = sorted((d for d in self.board.GetDrawings()
                        if d.GetLayer() in self.silk and isinstance(d, pcbnew.PCB_TEXT)),
                       key=lambda t: (t.GetLayer(), t.GetText(), t.GetPosition().x, t.GetPosition().y))
        errors = []
        for t in texts:
            layer = t.GetLayer()
            box = _box(t.GetBoundingBox())
            shape = pcbnew.SHAPE_RECT(t.GetBoundingBox())
            where = f"board label {t.GetText()!r} at ({pcbnew.ToMM(t.GetPosition().x) - ORIGIN[0]:.2f}, " \
                    f"{pcbnew.ToMM(t.GetPosition().y) - ORIGIN[1]:.2f}) mm on {t.GetLayerName()}"
            o = _hits(shape, box, self.mask[layer] + self.edge, mm(GAP_MASK)) or \
                _hits(shape, box, self.silk[layer], mm(GAP_SILK))
            if o is not None or not _inside(box, mm(GAP_EDGE), self.size):
                errors.append(f"{where} overlaps {o.what if o else 'the board edge'}")
            self.silk[layer].append(Obstacle(box, shape, f"label {t.GetText()!r}"))
        if errors:
            raise SilkError("; ".join(errors) + ": move them in the module description "
                            "(scripts/r2ptools/kicad/modules)")

    # --- 2. footprint outlines -------------------------------------------------------------
    def outlines(self) -> None:
        """The footprint outlines and marks as they are (fplib.py trimmed any that needed it)."""
        for f in self.fps:
            for g in f.GraphicalItems():
                if g.GetLayer() in self.silk:
                    self.silk[g.GetLayer()].append(Obstacle(_box(g.GetBoundingBox()),
                                                            g.GetEffectiveShape(g.GetLayer()),
                                                            f"outline of {f.GetReference()}"))

    # --- 3. references ---------------------------------------------------------------------
    def _own_box(self, f) -> tuple[int, int, int, int]:
        layer = pcbnew.B_SilkS if f.IsFlipped() else pcbnew.F_SilkS
        boxes = [_box(p.GetBoundingBox()) for p in f.Pads()]
        boxes += [_box(g.GetBoundingBox()) for g in f.GraphicalItems() if g.GetLayer() == layer
                  and isinstance(g, pcbnew.PCB_SHAPE)]
        return (min(b[0] for b in boxes), min(b[1] for b in boxes),
                max(b[2] for b in boxes), max(b[3] for b in boxes))

    def _candidates(self, f):
        """(size, angle, x, y, turned) in preference order: beside the part, rotated with it."""
        x0, y0, x1, y1 = self._own_box(f)
        cx, cy = (x0 + x1) // 2, (y0 + y1) // 2
        vertical = round(f.GetOrientationDegrees()) % 180 == 90
        ref = f.Reference()
        g = mm(GAP_PART)
        for turn in (False, True):
            angle = 90.0 if vertical != turn else 0.0
            for size in REF_SIZES:
                box, _ = self._try(ref, size, angle, 0, 0)     # the strokes' extent, centred
                w, h = box[2] - box[0], box[3] - box[1]
                dx, dy = -(box[0] + box[2]) // 2, -(box[1] + box[3]) // 2
                sides = {
                    "above": (cx, y0 - g - h // 2 - 1, "x"),
                    "below": (cx, y1 + g + h // 2 + 1, "x"),
                    "left": (x0 - g - w // 2 - 1, cy, "y"),
                    "right": (x1 + g + w // 2 + 1, cy, "y"),
                }
                order = ("left", "right", "above", "below") if vertical else ("above", "below", "left", "right")
                for slide in SLIDES:
                    for side in order:
                        x, y, axis = sides[side]
                        if axis == "x":
                            x += mm(slide)
                        else:
                            y += mm(slide)
                        yield size, angle, x + dx, y + dy, turn

    def _try(self, ref: pcbnew.PCB_FIELD, size: float, angle: float, x: int, y: int):
        """Sets the reference; returns the box of its strokes (what DRC tests) and that box."""
        ref.SetTextSize(pcbnew.VECTOR2I(mm(size), mm(size)))
        ref.SetTextThickness(mm(REF_LINE))
        ref.SetTextAngleDegrees(angle)
        ref.SetHorizJustify(pcbnew.GR_TEXT_H_ALIGN_CENTER)
        ref.SetVertJustify(pcbnew.GR_TEXT_V_ALIGN_CENTER)
        ref.SetPosition(pcbnew.VECTOR2I(x, y))
        bb = ref.GetEffectiveShape(ref.GetLayer()).BBox()
        return _box(bb), pcbnew.SHAPE_RECT(bb)

    def _clear(self, f, box, shape, placed: bool) -> bool:
        layer = pcbnew.B_SilkS if f.IsFlipped() else pcbnew.F_SilkS
        if not _inside(box, mm(GAP_EDGE), self.size):
            return False
        own = f"pad {f.GetReference()}."
        for o in self.mask[layer]:
            gap = mm(GAP_PART if o.what.startswith(own) else GAP_MASK)
            if _near(box, o.box, gap) and shape.Collide(o.shape, gap):
                return False
        if _hits(shape, box, self.edge, mm(GAP_EDGE)):
            return False
        silk = self.silk[layer] if placed else [o for o in self.silk[layer] if not o.what.startswith("ref ")]
        if _hits(shape, box, silk, mm(GAP_SILK)):
            return False
        for r, body in self.bodies[layer]:
            if r != f.GetReference() and _near(box, body, 0):
                return False
        return True

    def references(self) -> None:
        parts = [f for f in self.fps if f.Reference().IsVisible()]
        # the parts with the fewest clear places choose first
        def freedom(f):
            ref = f.Reference()
            n = 0
            for size, angle, x, y, _ in self._candidates(f):
                box, shape = self._try(ref, size, angle, x, y)
                n += self._clear(f, box, shape, placed=False)
            return (n, f.GetReference())
        for f in sorted(parts, key=freedom):
            ref = f.Reference()
            layer = pcbnew.B_SilkS if f.IsFlipped() else pcbnew.F_SilkS
            for size, angle, x, y, turn in self._candidates(f):
                box, shape = self._try(ref, size, angle, x, y)
                if self._clear(f, box, shape, placed=True):
                    self.silk[layer].append(Obstacle(box, shape, f"ref {f.GetReference()}"))
                    self.report.placed += 1
                    if size != REF_SIZES[0]:
                        self.report.shrunk.append(f.GetReference())
                    if turn:
                        self.report.turned.append(f.GetReference())
                    break
            else:
                ref.SetVisible(False)
                self.report.hidden.append(f.GetReference())
        for lst in (self.report.shrunk, self.report.turned, self.report.hidden):
            lst.sort(key=lambda r: (r.rstrip("0123456789"), int(r[len(r.rstrip("0123456789")):] or 0)))


def layout(board: pcbnew.BOARD) -> Report:
    """Lays out the silkscreen of a routed board in place (see the module doc)."""
    lay = Layout(board)
    lay.outlines()
    lay.labels()
    lay.references()
    return lay.report
