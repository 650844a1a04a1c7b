"""Texts on a schematic that a reader cannot tell apart: overlaps, and texts under the drawing.

A schematic is read by people: a value printed over a neighbour's reference, a label run into
another part's body, or a wire through a value make the sheet ambiguous although ERC is clean.
This module reads a `.kicad_sch` and reports every visible text (symbol fields, pin numbers, net,
global and hierarchical labels, sheet fields, notes) that

- comes closer to another text than `GAP_ALONG` along its reading direction (so two values on
  one baseline do not read as one string) or `GAP_ACROSS` across it, or
- enters a symbol's body (its graphics' box, other symbols and its own) or a sheet box, or
- is crossed by a wire, a pin or a frame line (block frames, sheet boxes); a label's own wire
  (the segment its anchor is on) is allowed.

Text extents come from KiCad's own text code (pcbnew's EDA_TEXT with the stroke font, the one
eeschema draws with), placed the way eeschema places them: a symbol field's box is turned by
its angle and the symbol's orientation and the text is drawn centred in it (SCH_FIELD::
GetBoundingBox); a label sits above (or left of) its wire by its text offset; global and
hierarchical labels add their flag's shape before the text; a pin's number sits on the pin,
just above (or left of) its line. Pin names are inside the library's body and are not checked.

    scripts/py -m r2ptools.kicad.sch_text hardware/motor/motor.kicad_sch [...]
"""
from __future__ import annotations

import functools
import math
import sys
from dataclasses import dataclass
from pathlib import Path

from . import sexpr

GAP_ALONG = 0.6
"""mm each text keeps free before and after itself along its reading direction: two texts on
one line need 1.2 mm between them, more than the font's word space (0.8 mm at 1.27 mm)."""
GAP_ACROSS = 0.1
"""mm each text keeps free above and below (a reference over its value, 2.54 mm apart, passes)."""
TOUCH = 0.05
"""mm a line may graze a text's box (round-off) without counting as crossing it."""
LABEL_OFFSET_RATIO = 0.15
"""eeschema's default label text offset (schematic settings: 0.15 × text size)."""
DEFAULT_PEN = 0.1524
"""eeschema's default line width (6 mil), the pen of non-bold schematic text."""

Box = tuple[float, float, float, float]
Seg = tuple[tuple[float, float], tuple[float, float]]


@dataclass(frozen=True)
class Text:
    what: str            # for the report: "R120 Value 24.9k", "label DRV_VG", "text 'VDD …'"
    box: Box             # drawn extent, mm on the sheet
    vertical: bool       # reads bottom to top
    owner: str = ""      # the symbol a field belongs to
    anchor: tuple[float, float] | None = None   # a label's connection point


def _rot(x: float, y: float, deg: float) -> tuple[float, float]:
    """KiCad's RotatePoint on the sheet (y down): counter-clockwise as seen."""
    c, s = round(math.cos(math.radians(deg))), round(math.sin(math.radians(deg)))
    return x * c + y * s, -x * s + y * c


def _normal(pts: list[tuple[float, float]]) -> Box:
    xs, ys = [p[0] for p in pts], [p[1] for p in pts]
    return min(xs), min(ys), max(xs), max(ys)


@functools.lru_cache(maxsize=None)
def _board():
    import pcbnew   # KiCad's Python module: imported only when a sheet is checked
    return pcbnew, pcbnew.BOARD()


@functools.lru_cache(maxsize=4096)
def text_box(text: str, size: tuple[float, float], bold: bool, italic: bool,
             h: str, v: str, ink: bool = False) -> Box:
    """The box of an unrotated text anchored at (0, 0) with justification h, v, in mm: KiCad's
    layout box (EDA_TEXT::GetTextBox: line pitch, descender room), or with `ink` the box of the
    strokes as drawn (EDA_TEXT::GetEffectiveTextShape, pen width included)."""
    pcbnew, board = _board()
    t = pcbnew.PCB_TEXT(board)
    t.SetText(text)
    t.SetTextSize(pcbnew.VECTOR2I(round(size[0] * 1e6), round(size[1] * 1e6)))
    pen = size[0] / 5 if bold else min(DEFAULT_PEN, size[0] * 0.18)
    t.SetTextThickness(round(pen * 1e6))
    t.SetBold(bold)
    t.SetItalic(italic)
    t.SetHorizJustify({"left": pcbnew.GR_TEXT_H_ALIGN_LEFT, "right": pcbnew.GR_TEXT_H_ALIGN_RIGHT,
                       "center": pcbnew.GR_TEXT_H_ALIGN_CENTER}[h])
    t.SetVertJustify({"top": pcbnew.GR_TEXT_V_ALIGN_TOP, "bottom": pcbnew.GR_TEXT_V_ALIGN_BOTTOM,
                      "center": pcbnew.GR_TEXT_V_ALIGN_CENTER}[v])
    t.SetTextPos(pcbnew.VECTOR2I(0, 0))
    b = t.GetEffectiveTextShape(False).BBox() if ink else t.GetTextBox(None)
    return b.GetX() / 1e6, b.GetY() / 1e6, (b.GetX() + b.GetWidth()) / 1e6, \
        (b.GetY() + b.GetHeight()) / 1e6


def _effects(node: list) -> tuple[tuple[float, float], bool, bool, str, str, bool]:
    """size, bold, italic, h, v, hidden of an (effects ...) holder."""
    eff = sexpr.find(node, "effects") or ["effects"]
    font = sexpr.find(eff, "font") or ["font"]
    sz = sexpr.find(font, "size")
    size = (float(sz[1]), float(sz[2])) if sz else (1.27, 1.27)

    def flag(holder: list, key: str) -> bool:
        f = sexpr.find(holder, key)
        return f is not None and (len(f) == 1 or str(f[1]) == "yes") or key in holder[1:]

    just = sexpr.find(eff, "justify") or ["justify"]
    h = next((str(j) for j in just[1:] if str(j) in ("left", "right")), "center")
    v = next((str(j) for j in just[1:] if str(j) in ("top", "bottom")), "center")
    hidden = flag(eff, "hide") or flag(node, "hide")
    return size, flag(font, "bold"), flag(font, "italic"), h, v, hidden


def _at(node: list) -> tuple[float, float, float]:
    a = sexpr.find(node, "at")
    return float(a[1]), float(a[2]), float(a[3]) if len(a) > 3 else 0.0


class Symbol:
    """A placed symbol: its orientation as KiCad's TRANSFORM (x1, y1, x2, y2), sheet y down."""

    def __init__(self, node: list, lib: dict[str, list]):
        self.node = node
        self.lib_id = str(sexpr.find(node, "lib_id")[1])
        self.x, self.y, rot = _at(node)
        self.unit = int(sexpr.find(node, "unit")[1]) if sexpr.find(node, "unit") else 1
        t = {0: (1, 0, 0, 1), 90: (0, 1, -1, 0), 180: (-1, 0, 0, -1), 270: (0, -1, 1, 0)}[int(rot) % 360]
        m = sexpr.find(node, "mirror")
        if m is not None and str(m[1]) == "x":        # about the x axis: y flips
            t = (t[0], t[1], -t[2], -t[3])
        elif m is not None and str(m[1]) == "y":
            t = (-t[0], -t[1], t[2], t[3])
        self.t = t
        self.lib = lib.get(self.lib_id)
        ref = next((p for p in sexpr.find_all(node, "property") if str(p[1]) == "Reference"), None)
        self.ref = str(ref[2]) if ref else self.lib_id

    def apply(self, dx: float, dy: float) -> tuple[float, float]:
        """A vector in the symbol's frame (sheet orientation, y down) onto the sheet."""
        x1, y1, x2, y2 = self.t
        return x1 * dx + y1 * dy, x2 * dx + y2 * dy

    def lib_point(self, lx: float, ly: float) -> tuple[float, float]:
        """A library point (y up) on the sheet."""
        dx, dy = self.apply(lx, -ly)
        return self.x + dx, self.y + dy

    def _units(self) -> list[list]:
        out = []
        for sub in sexpr.find_all(self.lib or [], "symbol"):
            parts = str(sub[1]).rsplit("_", 2)
            if int(parts[-2]) in (0, self.unit) and int(parts[-1]) in (0, 1):
                out.append(sub)
        return out

    def body(self) -> Box | None:
        """Box of the library graphics (not the pins)."""
        pts = []
        for sub in self._units():
            for item in sub:
                if not isinstance(item, list):
                    continue
                if item[0] == "rectangle":
                    pts += [(float(p[1]), float(p[2])) for p in (sexpr.find(item, "start"), sexpr.find(item, "end"))]
                elif item[0] in ("polyline", "bezier"):
                    pts += [(float(xy[1]), float(xy[2])) for xy in sexpr.find_all(sexpr.find(item, "pts"), "xy")]
                elif item[0] == "circle":
                    c, r = sexpr.find(item, "center"), float(sexpr.find(item, "radius")[1])
                    pts += [(float(c[1]) - r, float(c[2]) - r), (float(c[1]) + r, float(c[2]) + r)]
                elif item[0] == "arc":
                    pts += [(float(p[1]), float(p[2])) for p in
                            (sexpr.find(item, "start"), sexpr.find(item, "mid"), sexpr.find(item, "end"))]
        if not pts:
            return None
        return _normal([self.lib_point(*p) for p in pts])

    def _drawn_pins(self):
        """Each visible pin with a line (a power symbol's has none: its graphics are the body),
        and its two ends on the sheet: the connection point, then the body end."""
        for sub in self._units():
            for pin in sexpr.find_all(sub, "pin"):
                if "hide" in pin[1:] or (sexpr.find(pin, "hide") is not None
                                         and str(sexpr.find(pin, "hide")[1]) == "yes"):
                    continue
                x, y, a = _at(pin)
                ln = float(sexpr.find(pin, "length")[1])
                if ln == 0:
                    continue
                ex, ey = x + ln * round(math.cos(math.radians(a))), y + ln * round(math.sin(math.radians(a)))
                yield pin, self.lib_point(x, y), self.lib_point(ex, ey)

    def pins(self) -> list[Seg]:
        return [(a, b) for _, a, b in self._drawn_pins()]

    def pin_numbers(self) -> list[Text]:
        """The library's pin numbers as eeschema draws them: centred on the pin, just above a
        level pin or left of an upright one (below or right when the pin names sit outside)."""
        if self.lib is None or _hidden(self.lib, "pin_numbers"):
            return []
        names = sexpr.find(self.lib, "pin_names")
        off = sexpr.find(names, "offset") if names else None
        outside = off is not None and float(off[1]) == 0 and not _hidden(self.lib, "pin_names")
        out = []
        for pin, (ax, ay), (bx, by) in self._drawn_pins():
            num = sexpr.find(pin, "number")
            size, *_ = _effects(num)
            mx, my = (ax + bx) / 2, (ay + by) / 2
            x0, y0, x1, y1 = text_box(str(num[1]), size, False, False, "center", "center", ink=True)
            gap = 0.1016 + DEFAULT_PEN / 2
            side = 1 if outside else -1
            if abs(ay - by) < 1e-6:           # level: above the line
                dy = side * (gap + (y1 - y0) / 2)
                box, vertical = (mx + x0, my + dy + y0, mx + x1, my + dy + y1), False
            else:                              # upright: left of the line, reading upwards
                w, h = y1 - y0, x1 - x0
                dx = side * (gap + w / 2)
                box, vertical = (mx + dx - w / 2, my - h / 2, mx + dx + w / 2, my + h / 2), True
            out.append(Text(f"{self.ref} pin {num[1]}", box, vertical, owner=self.ref))
        return out

    def fields(self) -> list[Text]:
        out = []
        for p in sexpr.find_all(self.node, "property"):
            name, value = str(p[1]), str(p[2])
            size, bold, italic, h, v, hidden = _effects(p)
            if hidden or value in ("", "~"):
                continue
            px, py, angle = _at(p)
            bx0, by0, bx1, by1 = text_box(value, size, bold, italic, h, v)
            # eeschema: the layout box around the anchor, turned by the field's angle and the
            # symbol's orientation; the text is drawn centred in it (SCH_FIELD::GetBoundingBox),
            # level or upright (SCH_FIELD::GetDrawRotation)
            corners = [self.apply(*_rot(cx, cy, angle)) for cx in (bx0, bx1) for cy in (by0, by1)]
            x0, y0, x1, y1 = _normal(corners)
            cx, cy = px + (x0 + x1) / 2, py + (y0 + y1) / 2
            vertical = (round(angle) % 180 == 90) != (self.t[1] != 0)
            ix0, iy0, ix1, iy1 = text_box(value, size, bold, italic, "center", "center", ink=True)
            if vertical:
                ix0, iy0, ix1, iy1 = _normal([_rot(ix0, iy0, 90), _rot(ix1, iy1, 90)])
            out.append(Text(f"{self.ref} {name} {value!r}", (cx + ix0, cy + iy0, cx + ix1, cy + iy1),
                            vertical, owner=self.ref))
        return out


def _hidden(lib: list, key: str) -> bool:
    node = sexpr.find(lib, key)
    if node is None:
        return False
    h = sexpr.find(node, "hide")
    return "hide" in node[1:] or (h is not None and (len(h) == 1 or str(h[1]) == "yes"))


def _label(node: list) -> Text:
    kind = node[0]
    name = str(node[1])
    x, y, angle = _at(node)
    size, bold, italic, h, v, _ = _effects(node)
    pen = DEFAULT_PEN
    vertical = round(angle) % 180 == 90
    bx0, by0, bx1, by1 = text_box(name, size, bold, italic, h, v, ink=True)
    direction = _rot(1, 0, angle)          # from the anchor outwards, along the text
    if kind == "label":
        # above its wire (left of it when vertical) by the text offset
        d = LABEL_OFFSET_RATIO * size[1] + pen
        if vertical:
            bx0, by0, bx1, by1 = _normal([_rot(bx0, by0, 90), _rot(bx1, by1, 90)])
            box = (x + bx0 - d, y + by0, x + bx1 - d, y + by1)
        else:
            box = (x + bx0, y + by0 - d, x + bx1, y + by1 - d)
    else:
        # the flag's shape (about one text height) before the text, the text centred on the wire
        d = size[1] * (1.0 if kind == "hierarchical_label" else 1.2) + pen
        w, hh = bx1 - bx0, (by1 - by0) / 2 + pen
        ex, ey = x + direction[0] * (d + w), y + direction[1] * (d + w)
        if vertical:
            box = (x - hh, min(y, ey), x + hh, max(y, ey))
        else:
            box = (min(x, ex), y - hh, max(x, ex), y + hh)
    return Text(f"{kind.replace('_', ' ')} {name}", box, vertical, anchor=(x, y))


def _free_text(node: list) -> Text:
    body = str(node[1])
    x, y, angle = _at(node)
    size, bold, italic, h, v, _ = _effects(node)
    bx0, by0, bx1, by1 = text_box(body, size, bold, italic, h, v, ink=True)
    x0, y0, x1, y1 = _normal([_rot(bx0, by0, angle), _rot(bx1, by1, angle)])
    first = body.split("\n", 1)[0]
    return Text(f"text {first[:40]!r}", (x + x0, y + y0, x + x1, y + y1), round(angle) % 180 == 90)


def _sheet(node: list) -> tuple[Box, list[Text]]:
    x, y, _ = _at(node)
    sz = sexpr.find(node, "size")
    box = (x, y, x + float(sz[1]), y + float(sz[2]))
    texts = []
    for p in sexpr.find_all(node, "property"):
        size, bold, italic, h, v, hidden = _effects(p)
        if hidden:
            continue
        px, py, angle = _at(p)
        bx0, by0, bx1, by1 = text_box(str(p[2]), size, bold, italic, h, v, ink=True)
        x0, y0, x1, y1 = _normal([_rot(bx0, by0, angle), _rot(bx1, by1, angle)])
        texts.append(Text(f"sheet {p[1]} {str(p[2])!r}", (px + x0, py + y0, px + x1, py + y1),
                          round(angle) % 180 == 90))
    return box, texts


@dataclass
class Drawing:
    texts: list[Text]
    bodies: list[tuple[str, Box]]      # (whose, box)
    lines: list[tuple[str, Seg]]       # (what, segment)


def read(sch: Path) -> Drawing:
    tree = sexpr.parse(sch.read_text())
    libs = sexpr.find(tree, "lib_symbols") or []
    lib = {str(s[1]): s for s in libs[1:] if isinstance(s, list)}
    texts: list[Text] = []
    bodies: list[tuple[str, Box]] = []
    lines: list[tuple[str, Seg]] = []
    for item in tree[1:]:
        if not isinstance(item, list):
            continue
        kind = item[0]
        if kind == "symbol":
            s = Symbol(item, lib)
            texts += s.fields() + s.pin_numbers()
            b = s.body()
            if b is not None:
                bodies.append((s.ref, b))
            lines += [(f"{s.ref} pin", seg) for seg in s.pins()]
        elif kind in ("label", "global_label", "hierarchical_label"):
            texts.append(_label(item))
        elif kind == "text":
            texts.append(_free_text(item))
        elif kind == "wire":
            pts = [(float(p[1]), float(p[2])) for p in sexpr.find_all(sexpr.find(item, "pts"), "xy")]
            lines += [("wire", (a, b)) for a, b in zip(pts, pts[1:])]
        elif kind == "rectangle":
            (x0, y0), (x1, y1) = [(float(p[1]), float(p[2])) for p in
                                  (sexpr.find(item, "start"), sexpr.find(item, "end"))]
            lines += [("frame", seg) for seg in _edges((x0, y0, x1, y1))]
        elif kind == "sheet":
            box, sheet_texts = _sheet(item)
            bodies.append(("sheet", box))
            lines += [("sheet box", seg) for seg in _edges(box)]
            texts += sheet_texts
    return Drawing(texts, bodies, lines)


def _edges(b: Box) -> list[Seg]:
    x0, y0, x1, y1 = b
    return [((x0, y0), (x1, y0)), ((x1, y0), (x1, y1)), ((x1, y1), (x0, y1)), ((x0, y1), (x0, y0))]


def _grown(t: Text) -> Box:
    x0, y0, x1, y1 = t.box
    ax, ay = (GAP_ACROSS, GAP_ALONG) if t.vertical else (GAP_ALONG, GAP_ACROSS)
    return x0 - ax, y0 - ay, x1 + ax, y1 + ay


def _meet(a: Box, b: Box, shrink: float = 0.0) -> bool:
    return (min(a[2], b[2]) - max(a[0], b[0]) > shrink) and (min(a[3], b[3]) - max(a[1], b[1]) > shrink)


def _crosses(s: Seg, b: Box) -> bool:
    """Does the (axis-parallel or not) segment pass through the box by more than TOUCH?"""
    (ax, ay), (bx, by) = s
    x0, y0, x1, y1 = b[0] + TOUCH, b[1] + TOUCH, b[2] - TOUCH, b[3] - TOUCH
    if x0 >= x1 or y0 >= y1:
        return False
    # Liang-Barsky clip
    t0, t1 = 0.0, 1.0
    dx, dy = bx - ax, by - ay
    for p, q in ((-dx, ax - x0), (dx, x1 - ax), (-dy, ay - y0), (dy, y1 - ay)):
        if p == 0:
            if q < 0:
                return False
            continue
        r = q / p
        if p < 0:
            t0 = max(t0, r)
        else:
            t1 = min(t1, r)
        if t0 > t1:
            return False
    return True


def _on(p: tuple[float, float], s: Seg) -> bool:
    (ax, ay), (bx, by) = s
    if abs((bx - ax) * (p[1] - ay) - (by - ay) * (p[0] - ax)) > 1e-6:
        return False
    return min(ax, bx) - 1e-6 <= p[0] <= max(ax, bx) + 1e-6 and min(ay, by) - 1e-6 <= p[1] <= max(ay, by) + 1e-6


def problems(sch: Path) -> list[str]:
    """Every text that overlaps another, enters a body or is crossed by a line (one line each)."""
    d = read(sch)
    out = []
    grown = [_grown(t) for t in d.texts]
    for i, a in enumerate(d.texts):
        for j in range(i + 1, len(d.texts)):
            b = d.texts[j]
            if _meet(grown[i], grown[j]):
                out.append(f"{a.what} overlaps {b.what} (within {GAP_ALONG} mm along, {GAP_ACROSS} mm across)")
        pin_number = " pin " in a.what
        for whose, box in d.bodies:
            if pin_number and whose == a.owner:
                continue          # a pin's number sits by its own symbol by design
            if _meet(a.box, box, shrink=TOUCH):
                out.append(f"{a.what} over the body of {whose}")
        for what, seg in d.lines:
            if a.anchor is not None and _on(a.anchor, seg):
                continue
            if pin_number and what == f"{a.owner} pin":
                continue
            if _crosses(seg, a.box):
                out.append(f"{a.what} crossed by a {what} {_fmt(seg)}")
    return out


def _fmt(s: Seg) -> str:
    return f"({s[0][0]:g}, {s[0][1]:g})-({s[1][0]:g}, {s[1][1]:g}) mm"


def main(argv: list[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else argv
    if not args:
        print("usage: sch_text SCHEMATIC [...]: texts that overlap, enter a body or sit under a line",
              file=sys.stderr)
        return 2
    bad = 0
    for a in args:
        found = problems(Path(a))
        for f in found:
            print(f"{a}: {f}")
        print(f"{a}: {len(found)} text problems")
        bad += len(found)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
