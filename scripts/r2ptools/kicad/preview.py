"""A quick placement plot (courtyards, pads, references, tracks) for working on a layout.

    scripts/py -m r2ptools.kicad.preview hardware/proximity/proximity.kicad_pcb out.png
"""
from __future__ import annotations

import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pcbnew  # noqa: E402

from .board import ORIGIN  # noqa: E402


def _mm(v) -> float:
    return pcbnew.ToMM(v)


def plot(pcb: str, png: str) -> None:
    b = pcbnew.LoadBoard(pcb)
    from .board import outline_size as _size
    fig, ax = plt.subplots(figsize=(12 * max(1.0, _size(b)[0] / 60 * 0.6), 10), dpi=110)
    ox, oy = ORIGIN
    for t in b.GetTracks():
        col = "#c33" if t.GetLayer() == pcbnew.F_Cu else "#36c"
        if isinstance(t, pcbnew.PCB_VIA):
            p = t.GetPosition()
            ax.add_patch(plt.Circle((_mm(p.x) - ox, _mm(p.y) - oy), _mm(t.GetWidth(pcbnew.F_Cu)) / 2,
                                    color="#777"))
            continue
        s, e = t.GetStart(), t.GetEnd()
        ax.plot([_mm(s.x) - ox, _mm(e.x) - ox], [_mm(s.y) - oy, _mm(e.y) - oy], color=col,
                lw=max(0.5, _mm(t.GetWidth()) * 8), alpha=0.6, solid_capstyle="round")
    for z in b.Zones():
        if z.GetIsRuleArea() or z.GetNetname() == "GND" and z.GetAssignedPriority() == 0:
            continue
        o = z.Outline().Outline(0)
        pts = [(_mm(o.CPoint(j).x) - ox, _mm(o.CPoint(j).y) - oy) for j in range(o.PointCount())]
        pts.append(pts[0])
        col = "#e66" if z.GetLayer() == pcbnew.F_Cu else "#69e"
        ax.fill(*zip(*pts), color=col, alpha=0.25)
        ax.text(pts[0][0], pts[0][1], z.GetNetname(), fontsize=5, color=col)
    for fp in b.GetFootprints():
        for layer, col in ((pcbnew.F_CrtYd, "#a0a"), (pcbnew.B_CrtYd, "#0aa")):
            poly = fp.GetCourtyard(layer)
            for i in range(poly.OutlineCount()):
                o = poly.Outline(i)
                pts = [(_mm(o.CPoint(j).x) - ox, _mm(o.CPoint(j).y) - oy) for j in range(o.PointCount())]
                if pts:
                    pts.append(pts[0])
                    ax.plot(*zip(*pts), color=col, lw=0.6)
        for pad in fp.Pads():
            bb = pad.GetBoundingBox()
            ax.add_patch(plt.Rectangle((_mm(bb.GetLeft()) - ox, _mm(bb.GetTop()) - oy),
                                       _mm(bb.GetWidth()), _mm(bb.GetHeight()),
                                       color="#d90" if pad.GetNetname() else "#999", alpha=0.7))
        p = fp.GetPosition()
        ax.text(_mm(p.x) - ox, _mm(p.y) - oy, fp.GetReference(), fontsize=6, ha="center",
                va="center", color="k")
    from .board import outline_size
    w, h = outline_size(b)
    ax.plot([0, w, w, 0, 0], [0, 0, h, h, 0], color="k", lw=1)
    ax.set_xlim(-3, w + 3)
    ax.set_ylim(h + 3, -3)
    ax.set_aspect("equal")
    ax.grid(True, lw=0.3)
    ax.set_xticks(range(0, int(w) + 1, 5))
    ax.set_yticks(range(0, int(h) + 1, 5))
    fig.savefig(png, bbox_inches="tight")


if __name__ == "__main__":
    plot(sys.argv[1], sys.argv[2])
