"""From a board's facts and the design rules to the case's parameters (the per-module JSON).

Case frame (mm): X = board x, Y = board height - board y (the bus edge, "top" on the board, is the
back of the case at high Y), Z up from the bed under the base. Both the OpenSCAD library and the
cadquery model build from these numbers; they decide nothing the board does not imply:

- the board floats `board_gap` inside the walls and rests on bosses `boss_h` tall, the least that
  keeps `min_clearance` under everything below the board (leads, bottom parts, the M5 heads of
  the floor mounts where they are underneath);
- the lid's underside is a standard standoff length above the board: the shortest that clears
  the tallest part by `min_clearance`;
- every connector (or switch) that faces an edge gets a notch in that wall, from below its body
  to the rim (open at the top, so it prints without support and cables leave whatever their
  entry); notches closer than `min_pillar` merge;
- LEDs get light-pipe holes (a row of close LEDs one window), push buttons a pin hole, warm
  parts a field of vent slots, and the name goes where it fits.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from .board import Board, BoardError
from .design import Design
from . import textfit


@dataclass(frozen=True)
class Circle:
    x: float
    y: float
    r: float


def _r(v: float) -> float:
    return round(v, 4)


def _ceil_to(v: float, step: float) -> float:
    return math.ceil(v / step - 1e-9) * step


def _rects_overlap(a, b) -> bool:
    return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]


def _circle_hits_rect(c: Circle, r) -> bool:
    nx, ny = min(max(c.x, r[0]), r[2]), min(max(c.y, r[1]), r[3])
    return (nx - c.x) ** 2 + (ny - c.y) ** 2 < c.r ** 2


def _merge(rects: list[list[float]]) -> list[list[float]]:
    """Merges overlapping rectangles into their bounding boxes until none overlap."""
    rects = [list(r) for r in rects]
    merged = True
    while merged:
        merged = False
        for i in range(len(rects)):
            for j in range(i + 1, len(rects)):
                if _rects_overlap(rects[i], rects[j]):
                    a, b = rects[i], rects.pop(j)
                    rects[i] = [min(a[0], b[0]), min(a[1], b[1]), max(a[2], b[2]), max(a[3], b[3])]
                    merged = True
                    break
            if merged:
                break
    return sorted(rects)


def _slots(field: list[float], keep: list[Circle], keep_r: list[list[float]], d: Design) -> list[list[float]]:
    """Slots along X across `field`, each cut where it passes a keep-out circle or rectangle."""
    x0, y0, x1, y1 = field
    n = int((y1 - y0 - d.vent_w) // d.vent_pitch) + 1
    if n < 1:
        return []
    span = (n - 1) * d.vent_pitch + d.vent_w
    first = y0 + (y1 - y0 - span) / 2 + d.vent_w / 2          # centre the slot pattern
    out = []
    for i in range(n):
        yc = first + i * d.vent_pitch
        lo, hi = yc - d.vent_w / 2, yc + d.vent_w / 2
        segs = [(x0, x1)]
        for c in keep:
            yb = min(max(c.y, lo), hi)
            if abs(c.y - yb) >= c.r:
                continue
            half = math.sqrt(c.r ** 2 - (c.y - yb) ** 2)
            a, b = c.x - half, c.x + half
            segs = [s for seg in segs for s in ((seg[0], min(seg[1], a)), (max(seg[0], b), seg[1]))
                    if s[1] > s[0]]
        for r in keep_r:
            if r[1] < hi and r[3] > lo:
                segs = [s for seg in segs for s in ((seg[0], min(seg[1], r[0])), (max(seg[0], r[2]), seg[1]))
                        if s[1] > s[0]]
        out += [[_r(s0), _r(lo), _r(s1), _r(hi)] for s0, s1 in segs if s1 - s0 >= d.vent_min_len]
    return out


def layout(b: Board, d: Design) -> dict:
    where = b.source
    W, H = b.width, b.height
    g = d.board_gap

    def Y(y: float) -> float:
        return _r(H - y)

    def box(x0, y0, x1, y1) -> list[float]:
        return [_r(x0), Y(y1), _r(x1), Y(y0)]

    cx, cy = W / 2, H / 2
    mounts = [(cx - d.tslot_dx, cy), (cx + d.tslot_dx, cy), (cx, cy - d.tslot_dy), (cx, cy + d.tslot_dy)]
    holes = [(h.x, Y(h.y), h.d) for h in b.holes]
    for mx, my in mounts:
        for hx, hy, _ in holes:
            if math.hypot(mx - hx, my - hy) < d.m5_head_d / 2 + d.boss_d / 2 + d.min_clearance:
                raise BoardError(f"{where}: a mounting hole at ({hx:.1f}, {H - hy:.1f}) is too close to the "
                                 f"floor/stack mount at ({mx:.1f}, {H - my:.1f}): move the hole")

    # Heights: below the board (bosses) and above it (standoffs).
    heads = [[mx - d.m5_head_d / 2, my - d.m5_head_d / 2, mx + d.m5_head_d / 2, my + d.m5_head_d / 2]
             for mx, my in mounts]
    below: list[tuple[list[float], float]] = []     # (case-frame XY box, depth below the board)
    above: list[float] = []
    for p in b.parts:
        if p.side == "top":
            above.append(p.h)
        else:
            below.append((box(p.x0, p.y0, p.x1, p.y1), p.h))
        if p.leads:
            lb = box(*p.leads)
            if p.side == "top":
                below.append((lb, d.lead_protrusion))
            else:
                above.append(d.lead_protrusion)
    need = d.boss_h_min
    for xy, depth in below:
        under_head = any(_rects_overlap(xy, [h[0] - d.min_clearance, h[1] - d.min_clearance,
                                             h[2] + d.min_clearance, h[3] + d.min_clearance]) for h in heads)
        need = max(need, depth + d.min_clearance + (d.m5_head_h + d.min_clearance if under_head else 0))
    boss_h = _ceil_to(need, 0.5)
    tallest = max(above, default=0.0)
    fits = [L for L in d.standoff_lengths if L >= tallest + d.min_clearance]
    if not fits:
        tall = max((p for p in b.parts if p.side == "top"), key=lambda p: p.h)
        raise BoardError(f"{where}: {tall.ref} is {tall.h} mm tall; the longest standoff "
                         f"({d.standoff_lengths[-1]} mm) leaves no {d.min_clearance} mm above it")
    standoff = fits[0]
    z_floor = d.floor
    z_bot = z_floor + boss_h
    z_top = z_bot + b.thickness
    z_rim = z_top + standoff
    z = {"floor_top": _r(z_floor), "board_bot": _r(z_bot), "board_top": _r(z_top), "rim": _r(z_rim),
         "lid_top": _r(z_rim + d.lid)}

    # Stand-in board: outline x thickness, parts as boxes, leads under THT parts.
    parts, leads = [], []
    for p in b.parts:
        xy = box(p.x0, p.y0, p.x1, p.y1)
        zz = [z_top, z_top + p.h] if p.side == "top" else [z_bot - p.h, z_bot]
        parts.append({"ref": p.ref, "kind": p.kind, "box": [xy[0], xy[1], _r(zz[0]), xy[2], xy[3], _r(zz[1])]})
        if p.leads:
            lb = box(*p.leads)
            lz = [z_bot - d.lead_protrusion, z_bot] if p.side == "top" else [z_top, z_top + d.lead_protrusion]
            leads.append({"ref": p.ref, "box": [lb[0], lb[1], _r(lz[0]), lb[2], lb[3], _r(lz[1])]})

    # Notches: a connector's (or switch's) extent along its wall, from below its body up through
    # the rim; notches that would leave less than min_pillar of wall between them become one.
    def along(p) -> tuple[float, float]:
        xy = box(p.x0, p.y0, p.x1, p.y1)
        return (xy[0], xy[2]) if p.edge in ("top", "bottom") else (xy[1], xy[3])

    cutouts: list[dict] = []
    for p in sorted((p for p in b.parts if p.edge is not None), key=lambda p: (p.edge, along(p), p.ref)):
        a0, a1 = along(p)
        zlow = _r(z_top if p.side == "top" else z_bot - p.h)
        last = cutouts[-1] if cutouts else None
        if last and last["edge"] == p.edge and a0 - last["a1"] - 2 * d.cutout_gap < d.min_pillar:
            last.update(ref=f"{last['ref']}+{p.ref}", a1=max(last["a1"], a1), z0=min(last["z0"], zlow))
        else:
            cutouts.append({"ref": p.ref, "edge": p.edge, "a0": a0, "a1": a1, "z0": zlow})
    dove_lo, dove_hi = cy - d.dove_pad_w / 2 - d.cutout_gap, cy + d.dove_pad_w / 2 + d.cutout_gap
    for c in cutouts:
        if c["edge"] in ("left", "right") and c["a0"] - d.cutout_gap < dove_hi and c["a1"] + d.cutout_gap > dove_lo:
            raise BoardError(f"{where}: {c['ref']} faces the {c['edge']} edge where the side-by-side "
                             f"dovetail is (y {H - dove_hi:.1f}..{H - dove_lo:.1f} mm on the board): move it")

    # Lid: countersinks, LED holes, stacking pads; then vents and the name around them.
    ko = d.keepout
    csk = [Circle(hx, hy, d.lid_csk_d / 2 + ko) for hx, hy, _ in holes]
    pads = [Circle(mx, my, d.pad_d / 2 + ko) for mx, my in mounts]
    leds, pins = [], []
    for p in b.parts:
        if p.kind not in ("led", "button"):
            continue
        lx, ly = _r((p.x0 + p.x1) / 2), Y((p.y0 + p.y1) / 2)
        what, dia = (("LED", d.led_hole_d) if p.kind == "led" else ("button", d.pin_hole_d))
        for c in csk + pads:        # a hole may come within min_bar of a screw or pad (not keepout)
            if math.hypot(lx - c.x, ly - c.y) < c.r - ko + d.min_bar + dia / 2:
                raise BoardError(f"{where}: {what} {p.ref} at ({(p.x0 + p.x1) / 2:.1f}, {(p.y0 + p.y1) / 2:.1f}) "
                                 f"is under a lid screw or stacking pad at ({c.x:.1f}, {H - c.y:.1f}); "
                                 f"move the {what} (the lid needs its hole there)")
        (leds if p.kind == "led" else pins).append([lx, ly])
    # LEDs closer than a hole and a bar apart share one window (a row of status LEDs).
    groups: list[list[list[float]]] = []
    for led in leds:
        near = [grp for grp in groups
                if any(math.hypot(led[0] - o[0], led[1] - o[1]) < d.led_hole_d + d.min_bar for o in grp)]
        for grp in near:
            groups.remove(grp)
        groups.append(sum(near, []) + [led])
    rl = d.led_hole_d / 2
    holes_led = sorted(grp[0] for grp in groups if len(grp) == 1)
    windows = sorted([_r(min(p[0] for p in grp) - rl), _r(min(p[1] for p in grp) - rl),
                      _r(max(p[0] for p in grp) + rl), _r(max(p[1] for p in grp) + rl)]
                     for grp in groups if len(grp) > 1)
    led_keep = [Circle(x, y, rl + ko) for x, y in holes_led] + [Circle(x, y, d.pin_hole_d / 2 + ko) for x, y in pins]
    window_keep = [[w[0] - ko, w[1] - ko, w[2] + ko, w[3] + ko] for w in windows]
    inner = [-g, -g, W + g, H + g]
    usable = [inner[0] + ko, inner[1] + ko, inner[2] - ko, inner[3] - ko]
    fields = []
    for p in b.parts:
        if p.kind == "warm":
            xy = box(p.x0, p.y0, p.x1, p.y1)
            m = d.vent_margin
            f = [max(xy[0] - m, usable[0]), max(xy[1] - m, usable[1]), min(xy[2] + m, usable[2]),
                 min(xy[3] + m, usable[3])]
            fields.append(f)
    vents = [s for f in _merge(fields) for s in _slots(f, csk + pads + led_keep, window_keep, d)]

    name = module_label(b.module)
    blocked_r = [[v[0] - ko, v[1] - ko, v[2] + ko, v[3] + ko] for v in vents] + window_keep
    lid = [inner[0] - d.wall + ko, inner[1] - d.wall + ko, inner[2] + d.wall - ko, inner[3] + d.wall - ko]
    placed = None
    for size in d.name_sizes:
        ink = textfit.ink_box(name, size, d.font_file)        # about the anchor, centred
        best = None
        for iy in range(int(H / 0.5) + 1):
            for ix in range(-30, 31):
                x, y = cx + ix * 0.5, iy * 0.5
                r = [x + ink[0], y + ink[1], x + ink[2], y + ink[3]]
                if r[0] < lid[0] or r[2] > lid[2] or r[1] < lid[1] or r[3] > lid[3]:
                    continue
                if any(_circle_hits_rect(c, r) for c in csk + pads + led_keep):
                    continue
                if any(_rects_overlap(r, v) for v in blocked_r):
                    continue
                score = (abs(y - cy), abs(x - cx), y, x)
                if best is None or score < best[0]:
                    best = (score, x, y)
        if best:
            placed = {"text": name, "x": _r(best[1]), "y": _r(best[2]), "size": size}
            break
    if placed is None:
        raise BoardError(f"{where}: no room on the lid for the name {name!r} even at size "
                         f"{d.name_sizes[-1]} between the vents, LED holes and pads")

    return {
        "module": b.module,
        "interior": [_r(v) for v in inner],
        "inner_r": _r(b.corner_r + g),
        "outer": [_r(inner[0] - d.wall), _r(inner[1] - d.wall), _r(inner[2] + d.wall), _r(inner[3] + d.wall)],
        "outer_r": _r(b.corner_r + g + d.wall),
        "z": z,
        "boss_h": _r(boss_h),
        "standoff": standoff,
        "holes": [[_r(x), _r(y), _r(dd)] for x, y, dd in holes],
        "mounts": [[_r(x), _r(y)] for x, y in mounts],
        "dove_y": _r(cy),
        "cutouts": cutouts,
        "leds": holes_led,
        "led_windows": windows,
        "pins": sorted(pins),
        "vents": vents,
        "name": placed,
        "standin": {
            "outline": [[_r(x), Y(y)] for x, y in b.outline],
            "z0": _r(z_bot), "z1": _r(z_top),
            "holes": [[_r(x), _r(y), _r(dd)] for x, y, dd in holes],
            "parts": parts,
            "leads": leads,
        },
    }


def module_label(module: str) -> str:
    return module.upper()
