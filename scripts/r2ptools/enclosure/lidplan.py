"""What goes through and onto the lid, and where: light-pipe holes and LED windows, pin holes over
push buttons, vent slots over warm parts, and the module's name, around the fixed features (the
countersunk lid screws and the stacking pads). All in the case frame (see layout.py).

Holes may come within `min_bar` of a screw or pad (a web the printer makes well); vents and the
name keep `keepout` from everything.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from .board_facts import BoardError
from .case_rules import Design
from . import textfit

Rect = list[float]          # [x0, y0, x1, y1]


@dataclass(frozen=True)
class Circle:
    x: float
    y: float
    r: float


def r4(v: float) -> float:
    return round(v, 4)


def rects_overlap(a: Rect, b: Rect) -> bool:
    return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]


def _circle_hits_rect(c: Circle, r: Rect) -> bool:
    nx, ny = min(max(c.x, r[0]), r[2]), min(max(c.y, r[1]), r[3])
    return (nx - c.x) ** 2 + (ny - c.y) ** 2 < c.r ** 2


def _grow(r: Rect, m: float) -> Rect:
    return [r[0] - m, r[1] - m, r[2] + m, r[3] + m]


@dataclass
class Lid:
    leds: list[list[float]]          # light-pipe holes [x, y]
    windows: list[Rect]              # one per row of close LEDs
    pins: list[list[float]]          # pin holes over push buttons
    vents: list[Rect]
    name: dict


def plan(d: Design, where: str, board_h: float, interior: Rect, screws: list[tuple[float, float]],
         mounts: list[tuple[float, float]], leds: list[tuple[str, float, float]],
         buttons: list[tuple[str, float, float]], warm: list[Rect], name: str) -> Lid:
    ko = d.keepout
    fixed = [Circle(x, y, d.lid_csk_d / 2) for x, y in screws] + [Circle(x, y, d.pad_d / 2) for x, y in mounts]
    for what, dia, items in (("LED", d.led_hole_d, leds), ("button", d.pin_hole_d, buttons)):
        for ref, x, y in items:
            for c in fixed:
                if math.hypot(x - c.x, y - c.y) < c.r + d.min_bar + dia / 2:
                    raise BoardError(f"{where}: {what} {ref} at ({x:.1f}, {board_h - y:.1f}) is under a lid screw "
                                     f"or stacking pad at ({c.x:.1f}, {board_h - c.y:.1f}); move the {what} "
                                     "(the lid needs its hole there)")
    holes, windows = _led_openings(d, [[x, y] for _, x, y in leds])
    pins = sorted([r4(x), r4(y)] for _, x, y in buttons)
    keep = ([Circle(c.x, c.y, c.r + ko) for c in fixed] + [Circle(x, y, d.led_hole_d / 2 + ko) for x, y in holes]
            + [Circle(x, y, d.pin_hole_d / 2 + ko) for x, y in pins])
    keep_r = [_grow(w, ko) for w in windows]
    usable = _grow(interior, -ko)
    fields = [[max(w[0] - d.vent_margin, usable[0]), max(w[1] - d.vent_margin, usable[1]),
               min(w[2] + d.vent_margin, usable[2]), min(w[3] + d.vent_margin, usable[3])] for w in warm]
    vents = [s for f in _merge(fields) for s in _slots(f, keep, keep_r, d)]
    lid_top = _grow(interior, d.wall - ko)
    placed = _place_name(d, name, lid_top, keep, keep_r + [_grow(v, ko) for v in vents])
    if placed is None:
        raise BoardError(f"{where}: no room on the lid for the name {name!r} even at size "
                         f"{d.name_sizes[-1]} between the vents, LED holes and pads")
    return Lid(holes, windows, pins, vents, placed)


def _led_openings(d: Design, leds: list[list[float]]) -> tuple[list[list[float]], list[Rect]]:
    """LEDs closer than a hole and a bar apart share one window (a row of status LEDs)."""
    groups: list[list[list[float]]] = []
    for led in leds:
        near = [g for g in groups
                if any(math.hypot(led[0] - o[0], led[1] - o[1]) < d.led_hole_d + d.min_bar for o in g)]
        for g in near:
            groups.remove(g)
        groups.append(sum(near, []) + [led])
    rl = d.led_hole_d / 2
    holes = sorted([r4(g[0][0]), r4(g[0][1])] for g in groups if len(g) == 1)
    windows = sorted([r4(min(p[0] for p in g) - rl), r4(min(p[1] for p in g) - rl),
                      r4(max(p[0] for p in g) + rl), r4(max(p[1] for p in g) + rl)] for g in groups if len(g) > 1)
    return holes, windows


def _merge(rects: list[Rect]) -> list[Rect]:
    """Merges overlapping rectangles into their bounding boxes until none overlap."""
    rects = [list(r) for r in rects]
    i = 0
    while i < len(rects):
        j = next((j for j in range(i + 1, len(rects)) if rects_overlap(rects[i], rects[j])), None)
        if j is None:
            i += 1
            continue
        b = rects.pop(j)
        a = rects[i]
        rects[i] = [min(a[0], b[0]), min(a[1], b[1]), max(a[2], b[2]), max(a[3], b[3])]
        i = 0
    return sorted(rects)


def _slots(field: Rect, keep: list[Circle], keep_r: list[Rect], d: Design) -> list[Rect]:
    """Slots along X across `field`, centred in it, each cut where it passes a keep-out."""
    x0, y0, x1, y1 = field
    n = int((y1 - y0 - d.vent_w) // d.vent_pitch) + 1
    if n < 1:
        return []
    first = y0 + (y1 - y0 - ((n - 1) * d.vent_pitch + d.vent_w)) / 2 + d.vent_w / 2
    out = []
    for i in range(n):
        yc = first + i * d.vent_pitch
        lo, hi = yc - d.vent_w / 2, yc + d.vent_w / 2
        blocked = []
        for c in keep:
            yb = min(max(c.y, lo), hi)             # the band's point nearest the centre
            if abs(c.y - yb) < c.r:
                half = math.sqrt(c.r ** 2 - (c.y - yb) ** 2)
                blocked.append((c.x - half, c.x + half))
        blocked += [(r[0], r[2]) for r in keep_r if r[1] < hi and r[3] > lo]
        segs = [(x0, x1)]
        for a, b in blocked:
            segs = [s for seg in segs for s in ((seg[0], min(seg[1], a)), (max(seg[0], b), seg[1])) if s[1] > s[0]]
        out += [[r4(s0), r4(lo), r4(s1), r4(hi)] for s0, s1 in segs if s1 - s0 >= d.vent_min_len]
    return out


def _place_name(d: Design, name: str, lid_top: Rect, keep: list[Circle], keep_r: list[Rect]) -> dict | None:
    """The largest size that fits, nearest the lid's middle (0.5 mm grid search)."""
    cx, cy = (lid_top[0] + lid_top[2]) / 2, (lid_top[1] + lid_top[3]) / 2
    for size in d.name_sizes:
        ink = textfit.ink_box(name, size, d.font_file)        # about its anchor, centred
        best = None
        span = int((lid_top[3] - lid_top[1]) / 2 / 0.5) + 1
        for iy in range(-span, span + 1):
            for ix in range(-30, 31):
                x, y = cx + ix * 0.5, cy + iy * 0.5
                r = [x + ink[0], y + ink[1], x + ink[2], y + ink[3]]
                if r[0] < lid_top[0] or r[2] > lid_top[2] or r[1] < lid_top[1] or r[3] > lid_top[3]:
                    continue
                if any(_circle_hits_rect(c, r) for c in keep) or any(rects_overlap(r, k) for k in keep_r):
                    continue
                score = (abs(y - cy), abs(x - cx), y, x)
                if best is None or score < best[0]:
                    best = (score, x, y)
        if best:
            return {"text": name, "x": r4(best[1]), "y": r4(best[2]), "size": size}
    return None
