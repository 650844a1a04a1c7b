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
  (touching: distance 0, no overlap) — the one place contact is the point.
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
    return rep
