"""Draws a sheet as a circuit: functional blocks, wires inside them, labels between them.

A person lays the sheet out (`Sheet.drawing`: where each symbol goes, in 2.54 mm grid units, and
`Sheet.blocks`: the frames, titles and design notes); this module does the tedious, error-prone
part, the wiring, the way a schematic is drawn by hand:

- a pin on a rail (GND, +3V3, +5V) gets the rail's power symbol, pointing away from the part;
- the pins of one net inside one block are joined by wires (a tree of straight and L-shaped
  segments, grown from the nearest pin), with junction dots where three items meet, and one net
  label on the wires so the net keeps its name (the board's nets are named after them);
- where the same net is in another block, or leaves the sheet, a short stub ends in a label
  (local, or hierarchical for a sheet port);
- a wire never runs through a symbol's body, over a pin or an end of another net, or along
  another net's wire; where no such path exists, the pin gets a stub and a label instead, so a
  drawing is always electrically the description, whatever the layout.

Parts without a place in `Sheet.drawing` are packed below the drawing with a label on each pin
(the old label-per-pin style), so a sheet can be drawn a block at a time.

Coordinates are integers in 0.01 mm (KiCad's symbol libraries sit on a 1.27 mm grid, so every
connection point is exact); symbol rotations are KiCad's (counter-clockwise on screen).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from . import libsym, sexpr
from .design import GLOBAL_NETS, Part, Sheet
from .schematic import SheetWriter, _prop, part_fields, snap, uid
from .sexpr import Q

G = 254          # one grid unit (2.54 mm) in 0.01 mm
STUB = 254       # length of the wire from a pin to its label
POWER_SYMBOL = {"GND": "power:GND", "+3V3": "power:+3V3", "+5V": "power:+5V"}
"""Rails drawn as power symbols: the board-wide nets (design.GLOBAL_NETS)."""
assert set(POWER_SYMBOL) == set(GLOBAL_NETS)

Pt = tuple[int, int]
Seg = tuple[Pt, Pt]


def mm(v: int) -> str:
    return sexpr.num(v / 100)


def _rot(dx: float, dy: float, deg: int) -> tuple[float, float]:
    """Screen rotation, counter-clockwise as seen (y grows downwards)."""
    c, s = round(math.cos(math.radians(deg))), round(math.sin(math.radians(deg)))
    return dx * c + dy * s, -dx * s + dy * c


def _to_screen(lx: float, ly: float, at: Pt, deg: int) -> Pt:
    dx, dy = _rot(lx * 100, -ly * 100, deg)
    return at[0] + round(dx), at[1] + round(dy)


def _body_lib(lib_id: str) -> tuple[float, float, float, float]:
    """Bounding box of a library symbol's drawing and pins (library coordinates, y up)."""
    xs, ys = [], []
    for sub in sexpr.find_all(libsym.embedded(lib_id), "symbol"):
        if int(str(sub[1]).rsplit("_", 2)[-2]) not in (0, 1):
            continue
        for item in sub:
            if not isinstance(item, list):
                continue
            if item[0] == "rectangle":
                for k in ("start", "end"):
                    p = sexpr.find(item, k)
                    xs.append(float(p[1])); ys.append(float(p[2]))
            elif item[0] in ("polyline", "bezier"):
                for xy in sexpr.find_all(sexpr.find(item, "pts"), "xy"):
                    xs.append(float(xy[1])); ys.append(float(xy[2]))
            elif item[0] == "circle":
                c, r = sexpr.find(item, "center"), float(sexpr.find(item, "radius")[1])
                xs += [float(c[1]) - r, float(c[1]) + r]; ys += [float(c[2]) - r, float(c[2]) + r]
            elif item[0] == "arc":
                for k in ("start", "mid", "end"):
                    p = sexpr.find(item, k)
                    xs.append(float(p[1])); ys.append(float(p[2]))
            elif item[0] == "pin":
                at = sexpr.find(item, "at")
                ln = float(sexpr.find(item, "length")[1])
                a = math.radians(float(at[3]))
                x, y = float(at[1]), float(at[2])
                xs += [x, x + ln * math.cos(a)]; ys += [y, y + ln * math.sin(a)]
    return min(xs), min(ys), max(xs), max(ys)


@dataclass
class PinAt:
    ref: str
    number: str
    net: str
    p: Pt            # connection point
    out: Pt          # unit vector pointing away from the body


@dataclass
class Placed:
    part: Part | None
    lib_id: str
    ref: str
    at: Pt
    rot: int
    box: tuple[int, int, int, int]      # body, screen coordinates
    pins: list[PinAt]


def place(lib_id: str, ref: str, at: Pt, rot: int, nets: dict[str, str], part: Part | None) -> Placed:
    x0, y0, x1, y1 = _body_lib(lib_id)
    corners = [_to_screen(x, y, at, rot) for x in (x0, x1) for y in (y0, y1)]
    box = (min(c[0] for c in corners), min(c[1] for c in corners),
           max(c[0] for c in corners), max(c[1] for c in corners))
    pins = []
    for lp in libsym.pins(lib_id):
        p = _to_screen(lp.x, lp.y, at, rot)
        ox, oy = _rot(-math.cos(math.radians(lp.angle)), math.sin(math.radians(lp.angle)), rot)
        pins.append(PinAt(ref, lp.number, nets.get(lp.number, ""), p, (round(ox), round(oy))))
    # a drawing may overhang a pin's end (an LED's light arrows): a wire leaving that pin must
    # still be free to go, so no side of the body reaches past the pins that point out of it
    x0, y0, x1, y1 = box
    for pin in pins:
        if pin.out == (1, 0):
            x1 = min(x1, pin.p[0])
        elif pin.out == (-1, 0):
            x0 = max(x0, pin.p[0])
        elif pin.out == (0, 1):
            y1 = min(y1, pin.p[1])
        else:
            y0 = max(y0, pin.p[1])
    return Placed(part, lib_id, ref, at, rot, (x0, y0, x1, y1), pins)


def _on_segment(p: Pt, s: Seg) -> bool:
    (ax, ay), (bx, by) = s
    if ax == bx:
        return p[0] == ax and min(ay, by) <= p[1] <= max(ay, by)
    return p[1] == ay and min(ax, bx) <= p[0] <= max(ax, bx)


def _overlap(s: Seg, t: Seg) -> bool:
    """Collinear segments sharing more than a point."""
    (a, b), (c, d) = s, t
    if a[0] == b[0] == c[0] == d[0]:
        lo, hi = max(min(a[1], b[1]), min(c[1], d[1])), min(max(a[1], b[1]), max(c[1], d[1]))
        return hi > lo
    if a[1] == b[1] == c[1] == d[1]:
        lo, hi = max(min(a[0], b[0]), min(c[0], d[0])), min(max(a[0], b[0]), max(c[0], d[0]))
        return hi > lo
    return False


def _through_box(s: Seg, box: tuple[int, int, int, int]) -> bool:
    """Does the segment enter the open interior of the box?"""
    (ax, ay), (bx, by) = s
    x0, y0, x1, y1 = box
    if ax == bx:
        return x0 < ax < x1 and max(min(ay, by), y0) < min(max(ay, by), y1)
    return y0 < ay < y1 and max(min(ax, bx), x0) < min(max(ax, bx), x1)


class Canvas:
    """What is already drawn: symbol bodies, and every point and wire with its net."""

    def __init__(self) -> None:
        self.boxes: list[tuple[int, int, int, int]] = []
        self.points: dict[Pt, set[str]] = {}
        self.wires: list[tuple[str, Seg]] = []

    def mark(self, p: Pt, net: str) -> None:
        self.points.setdefault(p, set()).add(net)

    def ok(self, net: str, s: Seg) -> bool:
        if s[0] == s[1]:
            return True
        if any(_through_box(s, b) for b in self.boxes):
            return False
        for p, nets in self.points.items():
            if nets - {net} and _on_segment(p, s):
                return False
        for n, t in self.wires:
            if n == net:
                continue
            if _overlap(s, t) or _on_segment(s[0], t) or _on_segment(s[1], t) \
                    or _on_segment(t[0], s) or _on_segment(t[1], s):
                return False
        return True

    def add(self, net: str, s: Seg) -> None:
        if s[0] != s[1]:
            self.wires.append((net, s))
        self.mark(s[0], net)
        self.mark(s[1], net)


def _paths(a: Pt, b: Pt) -> list[list[Seg]]:
    if a[0] == b[0] or a[1] == b[1]:
        return [[(a, b)]]
    return [[(a, (b[0], a[1])), ((b[0], a[1]), b)], [(a, (a[0], b[1])), ((a[0], b[1]), b)]]


def _candidates(pin: "PinAt", t: Pt) -> list[list[Seg]]:
    """Straight or L paths from the pin to `t`, then the same after 1-3 grid out of the pin
    (a comb: how same-net pins in a row are joined without running over their neighbours)."""
    out = _paths(pin.p, t)
    for k in (1, 2, 3):
        e = (pin.p[0] + pin.out[0] * k * G, pin.p[1] + pin.out[1] * k * G)
        if e != t:
            out += [[(pin.p, e), *p] for p in _paths(e, t)]
    return out


def _length(path: list[Seg]) -> int:
    return sum(abs(s[0][0] - s[1][0]) + abs(s[0][1] - s[1][1]) for s in path)


class DrawnSheetWriter(SheetWriter):
    """A sheet drawn as a circuit from `sheet.drawing` and `sheet.blocks` (see module doc)."""

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self.canvas = Canvas()
        self.placed: list[Placed] = []
        self.power_n = 0

    # --- symbols ------------------------------------------------------------------------------
    def _emit_symbol(self, pl: Placed, value: str, fields: dict[str, str], in_bom: bool = True,
                     on_board: bool = True, hide_fields: bool = False,
                     value_at: tuple[int, int, str | None] | None = None) -> None:
        if pl.lib_id not in self.lib_ids:
            self.lib_ids.append(pl.lib_id)
        x0, y0, x1, y1 = pl.box
        # a connector (every pin out of one side) reads like a tall part: text beside its body
        one_side = len({p.out for p in pl.pins}) == 1 and pl.pins[0].out[1] == 0
        tall = (y1 - y0) > (x1 - x0) or len(pl.pins) > 2 or one_side
        if tall:
            rx, ry, vx, vy, just = x1 + 127, (y0 + y1) // 2 - 127, x1 + 127, (y0 + y1) // 2 + 127, "left"
            if len(pl.pins) > 4:       # an IC: reference above, value below the body
                rx, ry, vx, vy, just = x0, y0 - 127, x0, y1 + 254, "left"
                rx, vx = _beside_lanes(pl, pl.ref, rx, (0, -1)), _beside_lanes(pl, value, vx, (0, 1))
            elif all(p.out == (1, 0) for p in pl.pins):    # pins on the right (a jack turned
                rx, vx, just = x0 - 127, x0 - 127, "right"  # to face the circuit): text left
        else:
            rx, ry, vx, vy, just = (x0 + x1) // 2, y0 - 127, (x0 + x1) // 2, y1 + 254, None
        if value_at is not None:
            vx, vy, just = value_at
        if pl.rot in (90, 180) and just is not None:
            # KiCad reads a field's justification in the symbol's frame: turned 90 (with the
            # level field angle below) or 180, "left" is drawn right-justified, over the body
            just = {"left": "right", "right": "left"}[just]
        hide = hide_fields or pl.ref.startswith("#")
        props = [_prop("Reference", pl.ref, rx / 100, ry / 100, hide=hide, justify=just),
                 _prop("Value", value, vx / 100, vy / 100, hide=hide and not pl.lib_id.startswith("power:")
                       , justify=just)]
        for k, v in fields.items():
            props.append(_prop(k, v, pl.at[0] / 100, pl.at[1] / 100, hide=True))
        if pl.rot in (90, 270):      # field angles are relative to the symbol's: keep text level
            for prop in props:
                prop[3][3] = "90"
        pins = [["pin", Q(p.number), ["uuid", Q(uid(self.key, pl.ref, "pin", p.number))]]
                for p in libsym.pins(pl.lib_id)]
        inst = ["instances"]
        for i in self.instances:
            inst.append(["project", Q(i.project),
                         ["path", Q(i.path), ["reference", Q(pl.ref)], ["unit", "1"]]])
        self.items.append(["symbol", ["lib_id", Q(pl.lib_id)],
                           ["at", mm(pl.at[0]), mm(pl.at[1]), str(pl.rot)], ["unit", "1"],
                           ["exclude_from_sim", "no"], ["in_bom", "yes" if in_bom else "no"],
                           ["on_board", "yes" if on_board else "no"], ["dnp", "no"],
                           ["uuid", Q(uid(self.key, pl.ref))], *props, *pins, inst])

    def _power(self, net: str, p: Pt, out: Pt) -> None:
        """The rail's symbol at `p`, pointing along `out` (GND natively down, rails up)."""
        self.power_n += 1
        lib_id = POWER_SYMBOL[net]
        native = (0, 1) if net == "GND" else (0, -1)
        rot = next(r for r in (0, 90, 180, 270)
                   if tuple(round(v) for v in _rot(*native, r)) == out)
        ref = f"#PWR{self.key[:3].upper()}{self.power_n:03d}"
        pl = place(lib_id, ref, p, rot, {"1": net}, None)
        # a sideways symbol (an IC's side pin): its name just above the pin's line, where the
        # next pin's label (drawn above its own wire, below this one) leaves room
        tip = (p[0] + out[0] * 400, p[1] + out[1] * 400 - (100 if out[1] == 0 else 0))
        just = {(1, 0): "left", (-1, 0): "right"}.get(out)
        self._emit_symbol(pl, net, {"Footprint": "", "Datasheet": "", "Description": ""},
                          in_bom=False, on_board=False, value_at=(*tip, just))
        self.canvas.mark(p, net)

    def _wire(self, s: Seg, tag: str) -> None:
        self.items.append(["wire", ["pts", ["xy", mm(s[0][0]), mm(s[0][1])],
                                    ["xy", mm(s[1][0]), mm(s[1][1])]],
                           ["stroke", ["width", "0"], ["type", "default"]],
                           ["uuid", Q(uid(self.key, "wire", tag))]])

    def _net_label(self, net: str, p: Pt, out: Pt, tag: str) -> None:
        angle = {(1, 0): 0, (0, -1): 90, (-1, 0): 180, (0, 1): 270}[out]
        self._label(net, p[0] / 100, p[1] / 100, angle, tag)

    # --- wiring ---------------------------------------------------------------------------------
    def _stub_label(self, pin: PinAt, tag: str) -> None:
        end = (pin.p[0] + pin.out[0] * STUB, pin.p[1] + pin.out[1] * STUB)
        if self.canvas.ok(pin.net, (pin.p, end)) and end not in self.canvas.points:
            self.canvas.add(pin.net, (pin.p, end))
            self._wire((pin.p, end), tag)
            self._net_label(pin.net, end, pin.out, tag)
        else:
            self._net_label(pin.net, pin.p, pin.out, tag)
            self.canvas.mark(pin.p, pin.net)

    def _route(self, net: str, pins: list[PinAt], tag: str, label: bool = True) -> list[Seg]:
        """Joins `pins` (one net, one block) into a tree of wires grown from the first pin."""
        segs: list[Seg] = []
        ends: dict[Pt, int] = {}
        done = [pins[0]]
        tree_pts = {pins[0].p}
        todo = list(pins[1:])
        labelled: list[PinAt] = []
        while todo:
            best = None
            for pin in todo:
                targets = set(tree_pts)
                for s in segs:
                    for q in ((pin.p[0], s[0][1]), (s[0][0], pin.p[1])):
                        if _on_segment(q, s):
                            targets.add(q)
                for t in targets:
                    for path in _candidates(pin, t):
                        if best is not None and _length(path) >= best[0]:
                            continue
                        if _leaves_inward(pin, path):
                            continue
                        if all(self.canvas.ok(net, s) for s in path):
                            best = (_length(path), pin, path, t)
            if best is None:
                if label and len(todo) > 1 and not segs:
                    # the first pin reaches none: it takes a stub and label, the rest join
                    self._stub_label(pins[0], f"{tag}/label/{pins[0].ref}/{pins[0].number}")
                    return self._route(net, todo, f"{tag}/rest", label)
                if label and len(todo) > 1 and segs:
                    # the rest may still join among themselves: a second tree with its label
                    self._route(net, todo, f"{tag}/rest", label)
                    todo = []
                    break
                labelled += todo
                break
            _, pin, path, t = best
            todo.remove(pin)
            done.append(pin)
            for s in list(segs):              # a T onto an existing wire: split it there
                if t != s[0] and t != s[1] and _on_segment(t, s):
                    segs.remove(s)
                    segs += [(s[0], t), (t, s[1])]
            for s in path:
                if s[0] != s[1]:
                    segs.append(s)
                    self.canvas.add(net, s)
                    tree_pts.update((s[0], s[1]))
            tree_pts.add(pin.p)
        for i, s in enumerate(segs):
            self._wire(s, f"{tag}/{i}")
            for q in s:
                ends[q] = ends.get(q, 0) + 1
        for pin in done:
            ends[pin.p] = ends.get(pin.p, 0) + 1
        for q, n in sorted(ends.items()):
            if n >= 3:
                self.items.append(["junction", ["at", mm(q[0]), mm(q[1])], ["diameter", "0"],
                                   ["color", "0", "0", "0", "0"],
                                   ["uuid", Q(uid(self.key, "junction", tag, str(q)))]])
        if label:     # the net's name: on its longest horizontal wire (text reads along it),
            flat = [s for s in segs if s[0][1] == s[1][1]]    # else on its first pin
            if flat:
                s = max(flat, key=lambda s: (abs(s[1][0] - s[0][0]), -min(s[0][0], s[1][0])))
                left = min(s, key=lambda q: q[0])
                # a wire shorter than the name (two pins side by side, a loop round an IC's
                # pin): the name reads leftwards from the wire's free end, not over the pin
                run = abs(s[1][0] - s[0][0])
                away = run < len(net) * 120 and left not in {p.p for p in pins}
                # off the corner or pin end by a grid where the wire has room: clear of what the
                # corner meets and of the pin's number (drawn on the pin, next to its end); off a
                # pin end by two where it has room for that, clear of a field printed beside the
                # part's first pin too (a connector's reference above its top right pin)
                fits = run - len(net) * 120 - 127
                inset = 0 if away else 2 * G if left in {p.p for p in pins} and fits >= 2 * G \
                    else G if fits >= G else 0
                self._label(net, (left[0] + inset) / 100, left[1] / 100, 180 if away else 0, f"{tag}/label")
            else:     # a stub off the pin, so the name does not run into the pin's number
                self._stub_label(pins[0], f"{tag}/label")
        for pin in labelled:
            if label:
                self._stub_label(pin, f"{tag}/label/{pin.ref}/{pin.number}")
            else:
                self._power(net, pin.p, pin.out)
        return segs

    def _power_pin(self, net: str, pin: PinAt, part_pins: int) -> None:
        """A rail on one pin. A two-terminal part lying sideways (an LED, a series resistor) gets
        a short wire and the symbol upright, as drawn by hand; an IC's side pin gets the symbol
        turned along the pin (upright it would cover the neighbouring pins)."""
        native = (0, 1) if net == "GND" else (0, -1)
        if part_pins <= 2 and pin.out[1] == 0:
            end = (pin.p[0] + pin.out[0] * STUB, pin.p[1])
            if self.canvas.ok(net, (pin.p, end)) and end not in self.canvas.points:
                self.canvas.add(net, (pin.p, end))
                self._wire((pin.p, end), f"power/{pin.ref}/{pin.number}")
                self._power(net, end, native)
                return
        self._power(net, pin.p, pin.out)

    def _comb(self, net: str, pins: list[PinAt], tag: str) -> None:
        """A part's pins on one rail and one side, wired together, with one power symbol at the
        end of the wire the symbol points to (GND below, a rail above)."""
        segs = self._route(net, pins, tag, label=False)
        pts = [q for s in segs for q in s] or [p.p for p in pins]
        native = (0, 1) if net == "GND" else (0, -1)
        pin_pts = {p.p for p in pins}
        end = max(pts, key=lambda q: (q[1] * native[1], q not in pin_pts, -q[0]))
        self._power(net, end, native)

    # --- sheet ----------------------------------------------------------------------------------
    def build(self) -> list:
        sh = self.sheet
        drawing = sh.drawing
        loose: list[Part] = []
        for part in sh.parts:
            a = drawing.get(part.ref)
            if a is None:
                loose.append(part)
                continue
            pl = place(part.item.symbol, part.ref, (round(a.x * G), round(a.y * G)), a.rot,
                       part.nets, part)
            self.placed.append(pl)
            self.canvas.boxes.append(pl.box)
        for pl in self.placed:
            for pin in pl.pins:
                self.canvas.mark(pin.p, pin.net or f"~nc/{pl.ref}/{pin.number}")
        for pl in self.placed:
            fields, on_bom = part_fields(pl.part)
            self._emit_symbol(pl, pl.part.value, fields, in_bom=on_bom, on_board=True)
        self._blocks()
        # group pins: (net, block) -> pins
        groups: dict[tuple[str, int], list[PinAt]] = {}
        combs: dict[tuple[str, str, Pt], dict[Pt, PinAt]] = {}
        for pl in self.placed:
            for pin in pl.pins:
                if not pin.net:
                    lp = next(q for q in libsym.pins(pl.lib_id) if q.number == pin.number)
                    if lp.etype != "no_connect":
                        self.items.append(["no_connect", ["at", mm(pin.p[0]), mm(pin.p[1])],
                                           ["uuid", Q(uid(self.key, "nc", pl.ref, pin.number))]])
                    continue
                if pin.net in POWER_SYMBOL:
                    combs.setdefault((pl.ref, pin.net, pin.out), {}).setdefault(pin.p, pin)
                    continue
                groups.setdefault((pin.net, self._block_of(pin.p)), []).append(pin)
        by_ref = {pl.ref: pl for pl in self.placed}
        for (ref, net, out), by_point in sorted(combs.items()):
            pins = list(by_point.values())
            if len(pins) == 1 or _interleaved(pins, by_ref[ref]):
                for pin in pins:
                    self._power_pin(net, pin, len(by_ref[ref].pins))
            else:
                self._comb(net, pins, f"comb/{ref}/{net}/{out}")
        # short nets first: they have the fewest ways round
        for (net, b), pins in sorted(groups.items(), key=lambda kv: (_spread(kv[1]), kv[0])):
            tag = f"net/{net}/{b}"
            if len(pins) == 1:
                self._stub_label(pins[0], tag)
            else:
                self._route(net, pins, tag)
        self._flags()
        self._loose(loose)
        return self.items

    def _block_of(self, p: Pt) -> int:
        for i, b in enumerate(self.sheet.blocks):
            if b.contains(p):
                return i
        return -1

    def _blocks(self) -> None:
        for i, b in enumerate(self.sheet.blocks):
            self.items.append(["rectangle", ["start", mm(round(b.x0 * G)), mm(round(b.y0 * G))],
                               ["end", mm(round(b.x1 * G)), mm(round(b.y1 * G))],
                               ["stroke", ["width", "0"], ["type", "dash"]], ["fill", ["type", "none"]],
                               ["uuid", Q(uid(self.key, "block", b.title))]])
            self._text(b.title, b.x0 + 0.5, b.y0 + 1.2, 2.0, bold=True, tag=f"block/{b.title}")
            for j, (x, y, text) in enumerate(b.notes):
                self._text(text, x, y, 1.27, tag=f"note/{b.title}/{j}")

    def _text(self, text: str, x: float, y: float, size: float, bold: bool = False, tag: str = "") -> None:
        font = ["font", ["size", sexpr.num(size), sexpr.num(size)]]
        if bold:
            font.append(["bold", "yes"])
        self.items.append(["text", Q(text), ["exclude_from_sim", "no"],
                           ["at", mm(round(x * G)), mm(round(y * G)), "0"],
                           ["effects", font, ["justify", "left", "bottom"]],
                           ["uuid", Q(uid(self.key, "text", tag))]])

    def _flags(self) -> None:
        """PWR_FLAGs (nets driven from outside the sheet) where the layout puts them."""
        for n, net in enumerate(self.sheet.flags, start=51):
            a = self.sheet.drawing.get(f"flag:{net}")
            if a is None:
                continue                     # packed with the loose parts
            p = (round(a.x * G), round(a.y * G))
            ref = f"#FLG{self.key[:3].upper()}{n:02d}"
            pl = place("power:PWR_FLAG", ref, p, 0, {"1": net}, None)
            self._emit_symbol(pl, "PWR_FLAG", {"Footprint": "", "Datasheet": "~", "Description": ""},
                              in_bom=False, on_board=False, hide_fields=True,
                              value_at=(p[0], pl.box[1] - 127, None))   # above: the label is right
            q = (p[0] + 2 * G, p[1])           # a short wire to the rail's symbol or label
            self._wire((p, q), f"flag/{net}")
            self.canvas.add(net, (p, q))
            # a label, not a power symbol, even for a rail: KiCad's ERC counts a flag joined only
            # to a power symbol as an unconnected pin (a global label joins the rail all the same)
            self._net_label(net, q, (1, 0), f"flag/{net}")

    def _loose(self, parts: list[Part]) -> None:
        """Parts (and PWR_FLAGs) not drawn yet: packed below the drawing, a label on each pin."""
        flags = [n for n in self.sheet.flags if f"flag:{n}" not in self.sheet.drawing]
        if not parts and not flags:
            return
        bottom = max([b.y1 for b in self.sheet.blocks] + [pl.box[3] / G for pl in self.placed] + [0])
        sub = Sheet(self.sheet.name, self.sheet.title, parts=parts, ports=self.sheet.ports,
                    flags=flags)
        w = SheetWriter(sub, self.key, self.instances, self.title, self.revision, self.ports)
        w.y_offset = snap(bottom * 2.54 + 10)
        w.build()
        self.items += w.items
        self.lib_ids += [l for l in w.lib_ids if l not in self.lib_ids]
        self.height = max(self.height, w.y_offset + w.height)

    def document(self, sheet_uses=None, root=False) -> list:
        items = self.items if self.items else self.build()
        xs = [pl.box[2] for pl in self.placed] + [round(b.x1 * G) for b in self.sheet.blocks] + [0]
        ys = [pl.box[3] for pl in self.placed] + [round(b.y1 * G) for b in self.sheet.blocks] + [0]
        self.width = max(self.width, max(xs) / 100 + 8)
        self.height = max(self.height, max(ys) / 100 + 8)
        self.items = items
        return super().document(sheet_uses, root)


def _beside_lanes(pl: Placed, text: str, x: int, side: Pt) -> int:
    """Where a field above (side (0, -1)) or below (0, 1) an IC starts: at `x`, or, when a pin on
    that side runs under the text (a GND pin with its symbol, a rail's), right of the last such
    pin, clear of its power symbol and of the symbol's name (about 3.5 mm wide, centred on it)."""
    width = len(text) * 120                   # the stroke font's advance at 1.27 mm, about
    lanes = [p.p[0] for p in pl.pins if p.out == side]
    if not any(x - 254 <= lx <= x + width + 254 for lx in lanes):
        return x
    return max(lanes) + 381


def _interleaved(pins: list[PinAt], pl: Placed) -> bool:
    """Do other pins of the part sit between these (a connector's GND, +5V, GND...)? Then each
    pin gets its own power symbol: a comb would cross its neighbours."""
    xs, ys = [p.p[0] for p in pins], [p.p[1] for p in pins]
    box = (min(xs), min(ys), max(xs), max(ys))
    mine = {p.p for p in pins}
    return any(q.p not in mine and q.out == pins[0].out and box[0] <= q.p[0] <= box[2]
               and box[1] <= q.p[1] <= box[3] for q in pl.pins)


def _spread(pins: list[PinAt]) -> int:
    xs, ys = [p.p[0] for p in pins], [p.p[1] for p in pins]
    return (max(xs) - min(xs)) + (max(ys) - min(ys))


def _leaves_inward(pin: PinAt, path: list[Seg]) -> bool:
    """A wire must not leave a pin back along it, into the body."""
    s = path[0]
    d = (s[1][0] - s[0][0], s[1][1] - s[0][1])
    if d == (0, 0):
        return False
    dx, dy = (d[0] > 0) - (d[0] < 0), (d[1] > 0) - (d[1] < 0)
    return (dx, dy) == (-pin.out[0], -pin.out[1])
