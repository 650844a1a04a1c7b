"""Proves a module's board fits its case, exactly, on the cadquery solids.

Bodies on the case side: the base walls and floor (with every cut-out), the bosses, the lid, the
four standoffs (as the cylinder a hex sweeps: a user may turn it any way) and the M5 screw heads
of the floor mounts. On the board side: the board (outline x thickness, holes drilled), every
part as a box of its body (Fab drawing + pads) x height, and boxes under THT parts where leads
and pegs come through.

The rules (`min_clearance` from the design, 0.5 mm):
- no board-side body intersects a case-side body (OpenCASCADE boolean, volume > 1e-9 mm^3);
- every part and lead box keeps >= min_clearance from every case-side body
  (BRepExtrema distance, exact for these solids);
- the board keeps >= min_clearance from walls, floor, lid and screw heads, and rests on every boss
  (touching: distance 0, no overlap) — the one place contact is the point;
- under a floor window, the heat path (heatpath.py): pads touching board and blocks, blocks in the
  window and on the heatsink, the sink on the case's underside, its screws' engagement
  (`_heat_path`).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import cadquery as cq

from . import solid

CONTACT = 1e-6      # mm: closer than this is touching
OVERLAP = 1e-9      # mm^3


@dataclass
class Finding:
    item: str
    body: str
    problem: str

    def __str__(self) -> str:
        return f"{self.item} vs {self.body}: {self.problem}"


@dataclass
class Report:
    module: str
    min_clearance: float
    nearest: dict[str, tuple[float, str]] = field(default_factory=dict)   # item -> (mm, body)
    findings: list[Finding] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return not self.findings

    def table(self) -> str:
        rows = [f"{'part':<10} {'clearance mm':>12}  nearest"]
        for item, (d, body) in sorted(self.nearest.items(), key=lambda kv: kv[1][0]):
            rows.append(f"{item:<10} {d:>12.3f}  {body}")
        return "\n".join(rows)


def _shape(w: cq.Workplane) -> cq.Shape:
    return w.val() if len(w.vals()) == 1 else cq.Compound.makeCompound(w.vals())


def _box_gap(a, b) -> float:
    """Distance between two bounding boxes: a lower bound of the solids' distance."""
    dx = max(a.xmin - b.xmax, b.xmin - a.xmax, 0.0)
    dy = max(a.ymin - b.ymax, b.ymin - a.ymax, 0.0)
    dz = max(a.zmin - b.zmax, b.zmin - a.zmax, 0.0)
    return (dx * dx + dy * dy + dz * dz) ** 0.5


def _overlap(a: cq.Shape, b: cq.Shape) -> float:
    return a.intersect(b).Volume()


def check(K: solid.Case) -> Report:
    P = K.P
    need = P.min_clearance
    rep = Report(P.c["module"], need)
    shell, bosses, holes = K.pieces
    case: dict[str, cq.Shape] = {"base": _shape(K.base), "lid": _shape(K.lid)}
    for k, w in enumerate(solid.standoffs(P, swept=True), 1):
        case[f"standoff{k}"] = _shape(w)
    for k, w in enumerate(solid.m5_heads(P), 1):
        case[f"m5 head{k}"] = _shape(w)
    heat = {name: _shape(w) for name, w in K.heat_path.items()}
    case.update(heat)                 # every part and lead keeps min_clearance from them too
    st = K.standin

    items = {ref: _shape(w) for ref, w in st.parts.items()}
    items.update({f"{ref} leads": _shape(w) for ref, w in st.leads.items()})
    boxes = {body: c.BoundingBox() for body, c in case.items()}
    for name, s in items.items():
        best = (float("inf"), "")
        sb = s.BoundingBox()
        # Exact distances, nearest bounding box first; a body whose box is already farther than
        # both the best so far and the clearance asked for cannot change the outcome.
        for lower, body in sorted((_box_gap(sb, boxes[b]), b) for b in case):
            if lower >= best[0] and lower >= need:
                break
            c = case[body]
            d = s.distance(c)
            if d < best[0]:
                best = (d, body)
            if d < CONTACT and _overlap(s, c) > OVERLAP:
                rep.findings.append(Finding(name, body, f"overlaps by {_overlap(s, c):.3f} mm^3"))
            elif d < need - 1e-9:
                rep.findings.append(Finding(name, body, f"clearance {d:.3f} mm < {need} mm"))
        rep.nearest[name] = (round(best[0], 4), best[1])

    # The board: clear of walls, floor, lid and heads; resting on, not sunk into, every boss.
    board = _shape(st.board)
    walls = _shape(shell.cut(holes))
    others = {"walls/floor": walls, "lid": case["lid"],
              **{k: v for k, v in case.items() if k.startswith("m5 head")}}
    best = (float("inf"), "")
    for body, c in others.items():
        d = board.distance(c)
        best = min(best, (d, body))
        if d < need - 1e-9:
            problem = (f"overlaps by {_overlap(board, c):.3f} mm^3" if d < CONTACT
                       else f"clearance {d:.3f} mm < {need} mm")
            rep.findings.append(Finding("board", body, problem))
    rep.nearest["board"] = (round(best[0], 4), best[1])
    for k, b in enumerate(bosses, 1):
        boss = _shape(b.cut(holes))
        d = board.distance(boss)
        if d > CONTACT:
            rep.findings.append(Finding("board", f"boss{k}", f"does not rest on it (gap {d:.3f} mm)"))
        elif _overlap(board, boss) > OVERLAP:
            rep.findings.append(Finding("board", f"boss{k}", "sinks into it"))
    for k in range(1, len(P.holes) + 1):
        if _overlap(board, case[f"standoff{k}"]) > OVERLAP:
            rep.findings.append(Finding("board", f"standoff{k}", "overlaps"))
    if heat:
        _heat_path(K, rep, board, _shape(K.base), heat, items)
    return rep


def _heat_path(K: solid.Case, rep: Report, board: cq.Shape, base: cq.Shape, heat: dict[str, cq.Shape],
               items: dict[str, cq.Shape]) -> None:
    """The stack under the floor window (heatpath.py) as mounted: each gap pad touches the board
    and its block and covers its tabs' islands; each block stands in the window with
    min_clearance to the case and live_clearance to every part and lead (they may be live; the
    block is on the sink's side of the pad) and on the heatsink's base; that base lies on the
    case's underside; the screws' heads rest on the floor, clear of the board, and their
    threads reach into the sink's tapped holes by at least the engagement asked for."""
    hp = K.heat_params
    need = K.P.min_clearance

    def add(a: str, b: str, problem: str) -> None:
        rep.findings.append(Finding(a, b, problem))

    def inside(sa: cq.Shape, sb: cq.Shape) -> float:
        """Overlap volume; checked whenever the boxes meet: a body wholly inside another is
        as far from its faces as it is deep (BRepExtrema measures between boundaries)."""
        return _overlap(sa, sb) if _box_gap(sa.BoundingBox(), sb.BoundingBox()) == 0 else 0.0

    def touch(a: str, sa: cq.Shape, b: str, sb: cq.Shape) -> None:
        v = inside(sa, sb)
        d = sa.distance(sb)
        if v > OVERLAP:
            add(a, b, f"overlaps by {v:.3f} mm^3")
        elif d > CONTACT:
            add(a, b, f"does not touch it (gap {d:.3f} mm)")

    def clear(a: str, sa: cq.Shape, b: str, sb: cq.Shape, c: float) -> None:
        v = inside(sa, sb)
        d = sa.distance(sb)
        if v > OVERLAP:
            add(a, b, f"overlaps by {v:.3f} mm^3")
        elif d < c - 1e-9:
            add(a, b, f"clearance {d:.3f} mm < {c} mm")

    sink = heat["heatsink base"]
    touch("heatsink base", sink, "base", base)
    clear("heatsink fins", heat["heatsink fins"], "base", base, need)
    for k, bl in enumerate(hp["blocks"], 1):
        block, pad = heat[f"block{k}"], heat[f"gap pad{k}"]
        touch(f"gap pad{k}", pad, "board", board)
        touch(f"gap pad{k}", pad, f"block{k}", block)
        touch(f"block{k}", block, "heatsink base", sink)
        clear(f"block{k}", block, "base", base, need)
        clear(f"gap pad{k}", pad, "base", base, need)
        clear(f"block{k}", block, "board", board, hp["pad_compressed"])
        rep.nearest[f"block{k}"] = (round(block.distance(base), 4), "base")
        for name, s in items.items():
            clear(f"block{k}", block, name, s, hp["live_clearance"])
        x0, y0, _, x1, y1, _ = hp["pads"][k - 1]
        for ref in bl["tabs"]:
            t = next(t for t in hp["tabs"] if t[0] == ref)
            if not (x0 <= t[1] + 1e-9 and y0 <= t[2] + 1e-9 and t[3] <= x1 + 1e-9 and t[4] <= y1 + 1e-9):
                add(f"gap pad{k}", f"{ref} island", "does not cover it")
    covered = {ref for bl in hp["blocks"] for ref in bl["tabs"]}
    for t in hp["tabs"]:
        if t[0] not in covered:
            add("heat path", f"{t[0]} island", "no block under it")
    sc = hp["screw"]
    for k in range(1, len(hp["screws"]) + 1):
        s = heat[f"sink screw{k}"]
        touch(f"sink screw{k}", s, "base", base)              # head on the floor
        clear(f"sink screw{k}", s, "board", board, need)
        depth = -s.BoundingBox().zmin                          # thread below the sink's top face
        if depth < sc["min_engagement"] - 1e-6:
            add(f"sink screw{k}", "heatsink base", f"engages {depth:.2f} mm < {sc['min_engagement']} mm")
        elif depth > sc["tapped_depth"] + 1e-6:
            add(f"sink screw{k}", "heatsink base", f"bottoms out: {depth:.2f} mm > the {sc['tapped_depth']} mm "
                "tapped hole")
