"""The heat path under the power packages, from the board and the case: what carries the heat of
the tabs' B.Cu islands through the floor window to a heatsink outside the case.

The board's bottom is `z.board_bot` above the case's underside (boss + floor: 8.5 mm on the
motor), and a bottom-side obstacle (the motor XT60's leads, between the two legs) stands in the
window, so a flat sink base cannot reach the islands. The stack, bottom up:

    heatsink base  flat against the case's underside (Z = 0), held by screws from inside the case
                   through the floor into tapped holes in its base (heads on the floor, under the
                   board: fitted before the board; nothing passes through the board)
    grease         between sink and block (a film: no height here)
    block          aluminium, one per group of tabs whose common rectangle no bottom-side
                   obstacle crosses; its top face is the tabs' extent; height = gap - compressed pad
    putty pad      the insulator (the islands are at VMOT and the phase nodes): block, grease,
                   sink and screws are on the sink's side of it, at no circuit's potential
    B.Cu islands   the tabs' thermal vias land on them

The pad's compression is set by geometry: block height = gap - pad_t x (1 - compression). The
gap comes from printed parts (boss + floor), whose height is good to a layer, and the pad's own
thickness is good to 10 %, so the pad is a putty pad thick enough that both worst cases keep it
inside the range its maker gives (`compression_window`): never loose (a film compressed a few
hundredths would open an air gap on a tall print), never crushed into the board, and soft enough
that it flows rather than bows the board. The thermal calculation takes its least-compressed
thickness. Every size is derived here; a board or case it cannot be
made for gets a BoardError that says what to move.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass

from .board_facts import Board, BoardError
from .lidplan import r4, rects_overlap


@dataclass(frozen=True)
class Stack:
    # --- the pad (hardware/motor/off-board.csv HS102: Honeywell TGP 8000PT, a thermal putty pad) ---
    # CAPLINQ's listing (repository jerardpelaez/caplinq-ecommerce at c50b429, tgp8000pt.md):
    # "Thickness range: 1.0-5.0mm with 0.25mm incremental", "Thickness Tolerance: >=1mm, ±10%".
    pad_thicknesses: tuple[float, ...] = tuple(1.0 + 0.25 * i for i in range(17))
    pad_thickness_tol: float = 0.10     # of the pad's thickness, either way
    # "With 10~70% compression, the final BLT could reach a minimum of 0.5mm" (the same listing):
    # the range every tolerance extreme must stay in. A Shore 00 60 gap pad's 20-45 % (T-Global's
    # rule, Digi-Key TIM tutorial slide 13) cannot take +/-10 % of pad on +/-0.3 mm of stack below
    # 5.2 mm: one reason for a putty pad.
    compression_window: tuple[float, float] = (0.10, 0.70)
    # --- what moves the board's bottom against the sink's face under a block (worst case, +/- mm) ---
    print_z_tol: float = 0.2            # boss + floor, FDM: one 0.2 mm layer (estimate)
    block_h_tol: float = 0.05           # the blocks are faced to it (HS104's drawing)
    sink_flatness: float = 0.05         # the extrusion's base over a block's footprint: NOT VERIFIED
    # --- the blocks: EN AW-6060 flat bar, sawn to length and faced to size ---------------------
    bar_widths: tuple[float, ...] = (10.0, 12.0, 15.0, 20.0, 25.0, 30.0, 40.0, 50.0)
    bar_thicknesses: tuple[float, ...] = (4.0, 5.0, 6.0, 8.0, 10.0, 12.0, 15.0, 20.0)
    machining: float = 0.5              # stock beyond the finished size, per dimension (faced both sides)
    # Block (at the sink's potential) to live metal under the board (leads at VMOT, MOT_A/B):
    # IPC-2221B Table 6-1 B2, external uncoated at sea level, 31-150 V: 0.6 mm (as remembered,
    # NOT VERIFIED); the same figure keeps it from any other bottom-side part.
    live_clearance: float = 0.6
    # --- the heatsink (HS101: Fischer SK 88 100 SA, 100 x 100 x 50 mm by the distributors) -----
    sink_x: float = 100.0               # along the board's x
    sink_y: float = 100.0
    sink_h: float = 50.0
    sink_base: float = 6.0              # ASSUMED (calc/heatsink.py BASE_T); Fischer's profile NOT VERIFIED
    # --- sink screws: ISO 7045 M3 pan head, A2, into M3 tapped blind holes in the sink base -----
    screw_d: float = 3.0
    screw_hole_d: float = 3.4           # clearance hole in the floor
    screw_head_d: float = 5.5           # ISO 7045 M3 d_k
    screw_head_h: float = 2.4           # ISO 7045 M3 k
    screw_lengths: tuple[float, ...] = (4.0, 5.0, 6.0, 8.0, 10.0, 12.0)
    tap_floor: float = 1.0              # base left under a blind tapped hole
    # A steel screw in wrought aluminium holding a light clamp (the pad's, tens of newtons):
    # 1.25 d of thread (rule of thumb, as remembered: NOT VERIFIED against VDI 2230).
    min_engagement: float = 1.25        # x screw_d

    def as_dict(self) -> dict:
        return asdict(self)


STACK = Stack()


def _inside(inner, outer, margin: float) -> bool:
    return (inner[0] >= outer[0] + margin - 1e-9 and inner[1] >= outer[1] + margin - 1e-9
            and inner[2] <= outer[2] - margin + 1e-9 and inner[3] <= outer[3] - margin + 1e-9)


def _grow(r, g: float) -> list[float]:
    return [r[0] - g, r[1] - g, r[2] + g, r[3] + g]


def _union(a, b) -> list[float]:
    return [min(a[0], b[0]), min(a[1], b[1]), max(a[2], b[2]), max(a[3], b[3])]


def _stock(s: Stack, across: float, height: float, where: str) -> list[float]:
    """The smallest flat bar (width x thickness) a block `across` wide and `height` tall is faced from."""
    bars = [(w * t, w, t) for w in s.bar_widths for t in s.bar_thicknesses
            if w >= across + s.machining and t >= height + s.machining]
    if not bars:
        raise BoardError(f"{where}: a heat-path block {across:.2f} mm across and {height:.2f} mm tall is "
                         f"larger than the flat bar sizes ({max(s.bar_widths)} x {max(s.bar_thicknesses)} mm)")
    _, w, t = min(bars)
    return [w, t]


def pad_for(s: Stack) -> tuple[float, float, float]:
    """The thinnest stocked pad whose compression stays inside the window at every extreme of the
    stack's and the pad's own worst-case tolerance: (thickness, nominal squeeze, stack tolerance),
    mm. The loosest case is the thinnest pad on the widest gap, the tightest the thickest pad on
    the narrowest; the nominal gap sits midway between the two limits they set. Thinnest, because
    the pad is the stack's largest thermal resistance."""
    tol = s.print_z_tol + s.block_h_tol + s.sink_flatness
    lo, hi = s.compression_window
    r = s.pad_thickness_tol
    for t in sorted(s.pad_thicknesses):
        widest = t * (1 - r) * (1 - lo) - tol       # the nominal gap's largest value: still lo
        narrowest = t * (1 + r) * (1 - hi) + tol    # and its smallest: still hi
        if narrowest <= widest + 1e-9:
            return t, t - (widest + narrowest) / 2, tol
    raise BoardError(f"no pad of {max(s.pad_thicknesses)} mm or less keeps a +/-{tol:.2f} mm stack and "
                     f"+/-{r:.0%} of its own thickness within {lo:.0%}-{hi:.0%} compression: tighten the "
                     "case's or the blocks' tolerance")


def compression_range(s: Stack, pad_t: float, gap: float, tol: float) -> tuple[float, float]:
    """The pad's least and most compression over the tolerances, for a nominal gap (mm)."""
    r = s.pad_thickness_tol
    return 1 - (gap + tol) / (pad_t * (1 - r)), 1 - (gap - tol) / (pad_t * (1 + r))


def plan(b: Board, d, F, z: dict, interior: list[float], windows: list[list[float]], holes,
         mounts, s: Stack = STACK) -> dict | None:
    """The heat path's parts in the case frame (mm), or None when the floor has no window."""
    if not windows:
        return None
    where = b.source
    (win,) = windows
    tabs = [(t.ref, F.box(t.x0, t.y0, t.x1, t.y1)) for t in b.tabs]
    if not tabs:
        raise BoardError(f"{where}: the floor opens for power packages but none has a tab pad to press on")
    # What stands below the board: bottom-side parts, and THT leads of top-side parts.
    below = [(p.ref, F.part(p)) for p in b.parts if p.side == "bottom"]
    below += [(f"{p.ref} leads", F.box(*p.leads)) for p in b.parts if p.side == "top" and p.leads]
    keep = [(ref, _grow(box, s.live_clearance)) for ref, box in below]
    for ref, box in tabs:
        for other, k in keep:
            if rects_overlap(box, k):
                raise BoardError(f"{where}: {other} stand(s) under {ref}'s tab island (within "
                                 f"{s.live_clearance} mm): no block can press a pad on it; move them apart")
    # Tabs grouped: two groups become one block when their common rectangle stays clear.
    groups = [([ref], box) for ref, box in tabs]
    merged = True
    while merged:
        merged = False
        for i in range(len(groups)):
            for j in range(i + 1, len(groups)):
                u = _union(groups[i][1], groups[j][1])
                if not any(rects_overlap(u, k) for _, k in keep):
                    groups[i] = (groups[i][0] + groups[j][0], u)
                    del groups[j]
                    merged = True
                    break
            if merged:
                break
    gap = z["board_bot"]                 # case underside (Z = 0) to the board's bottom
    pad_t, squeeze, tol = pad_for(s)
    pad_c = pad_t - squeeze
    h = gap - pad_c
    if h <= d.floor:
        raise BoardError(f"{where}: the board's bottom is {gap} mm above the case's underside: a "
                         f"{pad_t} mm pad leaves a block of {h:.2f} mm, not through the {d.floor} mm floor")
    blocks, pads = [], []
    for refs, box in groups:
        if not _inside(box, win, d.min_clearance):
            raise BoardError(
                f"{where}: the heat-path block under {'+'.join(refs)} ({box[0]:.2f}..{box[2]:.2f} x "
                f"{box[1]:.2f}..{box[3]:.2f} mm) does not fit the floor window ({win[0]:.2f}..{win[2]:.2f} x "
                f"{win[1]:.2f}..{win[3]:.2f} mm) with {d.min_clearance} mm around it: widen the window")
        dx, dy = box[2] - box[0], box[3] - box[1]
        blocks.append({"tabs": refs, "box": [r4(box[0]), r4(box[1]), 0.0, r4(box[2]), r4(box[3]), r4(h)],
                       "bar": _stock(s, min(dx, dy), h, where), "length": r4(max(dx, dy))})
        pads.append([r4(box[0]), r4(box[1]), r4(h), r4(box[2]), r4(box[3]), r4(gap)])

    # The sink: centred on the blocks, kept off the bus end's mounting pattern (the T-slot
    # profile and the M5 heads are there), its top face on the case's underside.
    bx0, by0 = min(bl["box"][0] for bl in blocks), min(bl["box"][1] for bl in blocks)
    bx1, by1 = max(bl["box"][3] for bl in blocks), max(bl["box"][4] for bl in blocks)
    x_min = max(m[0] for m in mounts) + d.m5_head_d / 2 + d.min_clearance
    sx0 = max((bx0 + bx1) / 2 - s.sink_x / 2, x_min)
    sy0 = (by0 + by1) / 2 - s.sink_y / 2
    sink = [r4(sx0), r4(sy0), r4(-s.sink_h), r4(sx0 + s.sink_x), r4(sy0 + s.sink_y), 0.0]
    if not _inside([bx0, by0, bx1, by1], [sink[0], sink[1], sink[3], sink[4]], 0):
        raise BoardError(f"{where}: a {s.sink_x:g} mm heatsink kept clear of the mounts (x >= {x_min:.2f} mm) "
                         f"does not cover the blocks (x {bx0:.2f}..{bx1:.2f} mm): move the power stage")

    # Screws: one at the middle of each side of the window, its head bearing on the floor.
    hr = s.screw_head_d / 2
    off = hr + d.min_clearance
    cx, cy = (win[0] + win[2]) / 2, (win[1] + win[3]) / 2
    screws = [[r4(cx), r4(win[1] - off)], [r4(win[2] + off), r4(cy)], [r4(cx), r4(win[3] + off)],
              [r4(win[0] - off), r4(cy)]]
    for x, y in screws:
        problem = None
        if not _inside([x, y, x, y], interior, hr + d.min_clearance):
            problem = "too close to the wall"
        elif any(math.hypot(x - hx, y - hy) < d.boss_d / 2 + hr + d.min_clearance for hx, hy, _ in holes):
            problem = "on a boss"
        elif any(math.hypot(x - mx, y - my) < d.m5_head_d / 2 + hr + d.min_clearance for mx, my in mounts):
            problem = "on an M5 mount"
        elif not _inside([x, y, x, y], [sink[0], sink[1], sink[3], sink[4]], s.screw_d):
            problem = "off the heatsink's base"
        if problem:
            raise BoardError(f"{where}: the heatsink screw at ({x:.2f}, {y:.2f}) beside the floor window is "
                             f"{problem}: move the power packages or the hole")
    fits = [L for L in s.screw_lengths if L - d.floor <= s.sink_base - s.tap_floor]
    need = s.min_engagement * s.screw_d
    if not fits or max(fits) - d.floor < need:
        raise BoardError(f"{where}: a {s.sink_base} mm heatsink base under a {d.floor} mm floor leaves an M3 "
                         f"screw less than {need:.2f} mm ({s.min_engagement} d) of thread: a thicker base")
    length = max(fits)
    return {
        "tabs": [[ref, *map(r4, box)] for ref, box in tabs],
        "pad_t": pad_t, "pad_compressed": r4(pad_c), "compression": r4(squeeze / pad_t),
        "stack_tolerance": r4(tol), "pad_thickest": r4(pad_c + tol),
        "pad_thickness_tol": s.pad_thickness_tol,
        "compression_range": [r4(c) for c in compression_range(s, pad_t, pad_c, tol)],
        "blocks": blocks, "pads": pads,
        "obstacles": [[ref, *map(r4, box)] for ref, box in below],
        "sink": sink, "sink_base": s.sink_base,
        "screws": screws,
        "screw": {"d": s.screw_d, "hole_d": s.screw_hole_d, "head_d": s.screw_head_d, "head_h": s.screw_head_h,
                  "length": length, "engagement": r4(length - d.floor),
                  "tapped_depth": r4(s.sink_base - s.tap_floor), "min_engagement": r4(need)},
        "live_clearance": s.live_clearance,
    }
