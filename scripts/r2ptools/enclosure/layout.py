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
  entry); notches closer than `min_pillar` merge; a notch on the dovetail's stretch of a side
  wall cuts the rail or groove pad too (recorded as the cut-out's `dovetail`);
- the floor opens under power packages that shed their heat through the board's bottom (D2PAK
  tabs on thermal vias): a window the heat path (heatpath.py: pad, blocks, heatsink and its
  screws) reaches the board through;
- the M5 pattern (floor and stacking pads) is centred on the bus end (the standard 60 x 50 mm),
  the same place on every module;
- the lid's holes, vents and name: lidplan.py.
"""
from __future__ import annotations

import math
import re

from .board_facts import HEAT_DOWN, Board, BoardError, Part
from .case_rules import Design
from . import heatpath, lidplan
from .lidplan import r4, rects_overlap


def _ceil_to(v: float, step: float) -> float:
    return math.ceil(v / step - 1e-9) * step


class Frame:
    """Board frame (y down from the top-left corner) to case frame (Y up from the front)."""

    def __init__(self, b: Board):
        self.h = b.height

    def Y(self, y: float) -> float:
        return r4(self.h - y)

    def box(self, x0: float, y0: float, x1: float, y1: float) -> list[float]:
        return [r4(x0), self.Y(y1), r4(x1), self.Y(y0)]

    def part(self, p: Part) -> list[float]:
        return self.box(p.x0, p.y0, p.x1, p.y1)


def layout(b: Board, d: Design) -> dict:
    where = b.source
    F = Frame(b)
    cx, cy = min(b.width, d.bus_end_w) / 2, b.height / 2
    mounts = [(cx - d.tslot_dx, cy), (cx + d.tslot_dx, cy), (cx, cy - d.tslot_dy), (cx, cy + d.tslot_dy)]
    holes = [(h.x, F.Y(h.y), h.d) for h in b.holes]
    for mx, my in mounts:
        for hx, hy, _ in holes:
            if math.hypot(mx - hx, my - hy) < d.m5_head_d / 2 + d.boss_d / 2 + d.min_clearance:
                raise BoardError(f"{where}: a mounting hole at ({hx:.1f}, {F.Y(hy):.1f}) is too close to the "
                                 f"floor/stack mount at ({mx:.1f}, {F.Y(my):.1f}): move the hole")
    boss_h, standoff = _heights(b, d, F, mounts)
    z_bot = d.floor + boss_h
    z_top = z_bot + b.thickness
    z_rim = z_top + standoff
    z = {"floor_top": r4(d.floor), "board_bot": r4(z_bot), "board_top": r4(z_top), "rim": r4(z_rim),
         "lid_top": r4(z_rim + d.lid)}
    inner = [-d.board_gap, -d.board_gap, b.width + d.board_gap, b.height + d.board_gap]

    def centre(p: Part) -> tuple[str, float, float]:
        return p.ref, r4((p.x0 + p.x1) / 2), F.Y((p.y0 + p.y1) / 2)

    lid = lidplan.plan(d, where, b.height, inner, [(x, y) for x, y, _ in holes], mounts,
                       [centre(p) for p in b.parts if p.kind == "led"],
                       [centre(p) for p in b.parts if p.kind == "button"],
                       [F.part(p) for p in b.parts if p.kind == "warm"], b.module.upper())
    windows = _floor_windows(b, d, F, holes, mounts)
    heat = heatpath.plan(b, d, F, z, inner, windows, holes, mounts)
    case = {
        "module": b.module,
        "interior": [r4(v) for v in inner],
        "inner_r": r4(b.corner_r + d.board_gap),
        "outer": [r4(inner[0] - d.wall), r4(inner[1] - d.wall), r4(inner[2] + d.wall), r4(inner[3] + d.wall)],
        "outer_r": r4(b.corner_r + d.board_gap + d.wall),
        "z": z,
        "boss_h": r4(boss_h),
        "standoff": standoff,
        "holes": [[r4(x), r4(y), r4(dd)] for x, y, dd in holes],
        "mounts": [[r4(x), r4(y)] for x, y in mounts],
        "dove_y": r4(cy),
        "cutouts": _notches(b, d, F, z_bot, z_top),
        "floor_windows": windows,
        "leds": lid.leds,
        "led_windows": lid.windows,
        "pins": lid.pins,
        "vents": lid.vents,
        "name": lid.name,
        "standin": _standin(b, d, F, holes, z_bot, z_top),
    }
    if heat is not None:                      # only under a floor window (the motor's)
        case["heat_path"] = heat
    return case


def _heights(b: Board, d: Design, F: Frame, mounts) -> tuple[float, float]:
    """(boss height, standoff length): the least that clear what is under and over the board."""
    heads = [lidplan._grow([mx, my, mx, my], d.m5_head_d / 2 + d.min_clearance) for mx, my in mounts]
    below: list[tuple[list[float], float]] = []     # (case-frame XY box, depth below the board)
    above: list[float] = []
    for p in b.parts:
        if p.side == "top":
            above.append(p.h)
        else:
            below.append((F.part(p), p.h))
        if p.leads:
            if p.side == "top":
                below.append((F.box(*p.leads), d.lead_protrusion))
            else:
                above.append(d.lead_protrusion)
    need = d.boss_h_min
    for xy, depth in below:
        under_head = any(rects_overlap(xy, h) for h in heads)
        need = max(need, depth + d.min_clearance + (d.m5_head_h + d.min_clearance if under_head else 0))
    tallest = max(above, default=0.0)
    fits = [L for L in d.standoff_lengths if L >= tallest + d.min_clearance]
    if not fits:
        tall = max((p for p in b.parts if p.side == "top"), key=lambda p: p.h)
        raise BoardError(f"{b.source}: {tall.ref} is {tall.h} mm tall; the longest standoff "
                         f"({d.standoff_lengths[-1]} mm) leaves no {d.min_clearance} mm above it")
    return _ceil_to(need, 0.5), fits[0]


def _notches(b: Board, d: Design, F: Frame, z_bot: float, z_top: float) -> list[dict]:
    """A connector's (or switch's) extent along its wall and its body's bottom; notches that would
    leave less than min_pillar of wall between them become one."""
    def along(p: Part) -> tuple[float, float]:
        xy = F.part(p)
        return (xy[0], xy[2]) if p.edge in ("top", "bottom") else (xy[1], xy[3])

    cutouts: list[dict] = []
    for p in sorted((p for p in b.parts if p.edge is not None), key=lambda p: (p.edge, along(p), p.ref)):
        a0, a1 = along(p)
        zlow = r4(z_top if p.side == "top" else z_bot - p.h)
        last = cutouts[-1] if cutouts else None
        if last and last["edge"] == p.edge and a0 - last["a1"] - 2 * d.cutout_gap < d.min_pillar:
            last.update(ref=f"{last['ref']}+{p.ref}", a1=max(last["a1"], a1), z0=min(last["z0"], zlow))
        else:
            cutouts.append({"ref": p.ref, "edge": p.edge, "a0": a0, "a1": a1, "z0": zlow})
    # A connector on the dovetail's stretch of a side wall (the motor's battery XT60): its notch
    # goes through the rail (right) or the groove pad (left) like through the wall, from below
    # its body to the rim; the dovetail keeps the part under the notch and beside it, so the
    # module still slides onto a neighbour there (with less engagement) and the plug is reachable.
    # The dovetail's place stays the same on every module: it is what makes them line up.
    cy = b.height / 2
    lo, hi = cy - d.dove_pad_w / 2 - d.cutout_gap, cy + d.dove_pad_w / 2 + d.cutout_gap
    for c in cutouts:
        if c["edge"] in ("left", "right") and c["a0"] - d.cutout_gap < hi and c["a1"] + d.cutout_gap > lo:
            c["dovetail"] = "rail" if c["edge"] == "right" else "groove pad"
    return cutouts


_HEAT_DOWN = HEAT_DOWN


def _floor_windows(b: Board, d: Design, F: Frame, holes, mounts) -> list[list[float]]:
    """The floor opens under the power packages that shed their heat downwards (one window over
    all of them, min_clearance beyond them), so the heat path (heatpath.py: gap pad, aluminium
    blocks, heatsink) reaches the board's bottom from outside the case."""
    boxes = [F.part(p) for p in b.parts if p.side == "top" and _HEAT_DOWN.match(p.fpid)]
    if not boxes:
        return []
    # min_clearance beyond the packages: the aluminium blocks under their tabs (heatpath.py) may
    # be as large as the tabs and still keep that clearance from the window's edges.
    g = d.min_clearance
    w = [r4(min(x[0] for x in boxes) - g), r4(min(x[1] for x in boxes) - g),
         r4(max(x[2] for x in boxes) + g), r4(max(x[3] for x in boxes) + g)]
    keep = [(hx, hy, d.boss_d / 2 + d.min_clearance) for hx, hy, _ in holes] + \
           [(mx, my, d.m5_head_d / 2 + d.min_clearance) for mx, my in mounts]
    for x, y, r in keep:
        nx, ny = min(max(x, w[0]), w[2]), min(max(y, w[1]), w[3])
        if math.hypot(nx - x, ny - y) < r:
            raise BoardError(f"{b.source}: the heatsink window under the power packages "
                             f"({w[0]:.1f}..{w[2]:.1f} x {w[1]:.1f}..{w[3]:.1f} mm in the case) meets the "
                             f"boss or mount at ({x:.1f}, {y:.1f}): move the packages or the hole")
    return [w]


def _standin(b: Board, d: Design, F: Frame, holes, z_bot: float, z_top: float) -> dict:
    """The board for CAD and the fit check: outline x thickness, parts as boxes, leads under THT."""
    parts, leads = [], []
    for p in b.parts:
        xy = F.part(p)
        zz = [z_top, z_top + p.h] if p.side == "top" else [z_bot - p.h, z_bot]
        parts.append({"ref": p.ref, "kind": p.kind, "box": [xy[0], xy[1], r4(zz[0]), xy[2], xy[3], r4(zz[1])]})
        if p.leads:
            lb = F.box(*p.leads)
            lz = [z_bot - d.lead_protrusion, z_bot] if p.side == "top" else [z_top, z_top + d.lead_protrusion]
            leads.append({"ref": p.ref, "box": [lb[0], lb[1], r4(lz[0]), lb[2], lb[3], r4(lz[1])]})
    return {"outline": [[r4(x), F.Y(y)] for x, y in b.outline], "z0": r4(z_bot), "z1": r4(z_top),
            "holes": [[r4(x), r4(y), r4(dd)] for x, y, dd in holes], "parts": parts, "leads": leads}
