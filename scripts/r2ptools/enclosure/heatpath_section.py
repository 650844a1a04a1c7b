"""A drawing of the heat path's stack (heatpath.py) in section, for the person assembling it:
which part goes where, how tall, and how much the pad is squeezed. Drawn from the case's own
parameters (`enclosures/<m>/<m>.json`), so it changes with the board and the case; matplotlib
with pictures.style/save, so the PNG regenerates byte for byte.

The section is vertical, along the board's x, through the centre of the first group's first tab
island: the power packages on the board, their islands, the pads, the blocks, the case's floor
around its window and the heatsink's base under it. The sink's screws and the leads that stand
below the board lie elsewhere along y: they are drawn dashed, where they are along x.
"""
from __future__ import annotations

from pathlib import Path

from ..pictures import save, style

FIN_STUB = 6.0       # mm of the fins drawn below the base; the rest is cut away (not to scale)
COLOURS = {"board": "#2e7d32", "pad": "#ef6c00", "block": "#90a4ae", "floor": "#fff3c4",
           "sink": "#455a64", "fet": "#212121", "screw": "#6d4c41", "lead": "#b71c1c"}


def draw(doc: dict, out: Path) -> Path:
    """Writes the section of `doc`'s heat path (a case document with `case.heat_path`) to `out`."""
    c, d = doc["case"], doc["design"]
    hp, z = c["heat_path"], c["z"]
    win = c["floor_windows"][0]
    blocks, sink = hp["blocks"], hp["sink"]
    # The window, the screws beside it along x, and room for the labels either side.
    beside = [s for s in hp["screws"] if not win[0] < s[0] < win[2]]
    x_lo = min([s[0] for s in beside] + [win[0]]) - 16
    x_hi = max([s[0] for s in beside] + [win[2]]) + 16
    y_cut = (hp["tabs"][0][2] + hp["tabs"][0][4]) / 2
    tabs_cut = [t for t in hp["tabs"] if t[2] <= y_cut <= t[4]]
    base_bot = -hp["sink_base"]
    with style(**{"font.size": 8}) as plt:
        fig, ax = plt.subplots(figsize=(9.0, 5.2), dpi=100)

        def box(x0, x1, z0, z1, colour, **kw):
            ax.add_patch(plt.Rectangle((x0, z0), x1 - x0, z1 - z0, facecolor=colour,
                                       **{"edgecolor": "black", "linewidth": 0.6, **kw}))

        # Heatsink: base, then its fins, cut off below (their profile is the maker's).
        sx0, sx1 = max(sink[0], x_lo), min(sink[3], x_hi)
        box(sx0, sx1, base_bot, 0.0, COLOURS["sink"])
        box(sx0, sx1, base_bot - FIN_STUB, base_bot, "white", hatch="||", edgecolor=COLOURS["sink"])
        ax.text(x_lo + 1.0, base_bot - FIN_STUB - 0.6,
                f"heatsink: {hp['sink_base']:g} mm base (assumed), {-sink[2]:g} mm deep with its fins (cut off here)",
                va="top")
        # The case's floor, open over the window.
        box(x_lo, win[0], 0.0, d["floor"], COLOURS["floor"], hatch="//")
        box(win[2], x_hi, 0.0, d["floor"], COLOURS["floor"], hatch="//")
        # Blocks and pads.
        for b in blocks:
            x0, _, z0, x1, _, z1 = b["box"]
            box(x0, x1, z0, z1, COLOURS["block"])
            ax.text((x0 + x1) / 2, (z0 + z1) / 2,
                    f"block\n{x1 - x0:.2f} × {b['length']:.2f}\n× {z1 - z0:.2f} mm\n"
                    f"(from {b['bar'][0]:g} × {b['bar'][1]:g} bar)", ha="center", va="center")
        for p in hp["pads"]:
            box(p[0], p[3], p[2], p[5], COLOURS["pad"])
        # The board, its tab islands' packages above it.
        box(x_lo, x_hi, z["board_bot"], z["board_top"], COLOURS["board"])
        for ref, x0, _, x1, _ in tabs_cut:
            box(x0, x1, z["board_top"], z["board_top"] + 4.8, COLOURS["fet"])
            ax.text((x0 + x1) / 2, z["board_top"] + 2.4, ref, ha="center", va="center", color="white")
        # What lies off the section: the leads below the board, the sink's screws.
        for ref, x0, _, x1, _ in hp.get("obstacles", []):
            box(x0, x1, z["board_bot"] - d["lead_protrusion"], z["board_bot"], "none",
                linestyle="--", edgecolor=COLOURS["lead"])
        sc = hp["screw"]
        for sx, _ in beside:
            if x_lo < sx < x_hi:
                box(sx - sc["d"] / 2, sx + sc["d"] / 2, d["floor"] - sc["length"], d["floor"], "none",
                    linestyle="--")
                box(sx - sc["head_d"] / 2, sx + sc["head_d"] / 2, d["floor"], d["floor"] + sc["head_h"],
                    "none", linestyle="--")

        # Dimensions on the left: the gap the stack fills; labels where the drawing is empty.
        gx = x_lo + 2.0
        ax.annotate("", (gx, 0.0), (gx, z["board_bot"]),
                    arrowprops={"arrowstyle": "<->", "linewidth": 0.8})
        ax.text(gx + 0.6, z["board_bot"] - 0.4, f"{z['board_bot']:g} mm: case\nunderside\nto board",
                va="top")
        lo, hi = hp["compression_range"]
        b0 = blocks[0]["box"]
        ax.annotate(f"putty pad {hp['pad_t']:g} mm, squeezed to {hp['pad_compressed']:g} mm "
                    f"({hp['compression']:.0%}); {lo:.0%}–{hi:.0%} over the stack's ±{hp['stack_tolerance']:g} mm "
                    f"and the pad's ±{hp['pad_thickness_tol']:.0%}: the only insulator",
                    (b0[0] + 1.0, (b0[5] + z["board_bot"]) / 2), (x_lo + 1.0, z["board_top"] + 8.0),
                    arrowprops={"arrowstyle": "->", "linewidth": 0.6})
        mid = (blocks[0]["box"][3] + blocks[-1]["box"][0]) / 2 if len(blocks) > 1 else win[2] + 4
        ax.text(mid, 0.4, "paste film under\neach block (the\nwindow open here)",
                ha="center", va="bottom")
        ax.text(x_hi - 1.0, d["floor"] + 0.3, f"printed\nfloor {d['floor']:g} mm", ha="right", va="bottom")
        ax.text(x_hi - 1.0, z["board_top"] + 0.3, "board: tabs on thermal vias\nto B.Cu islands",
                ha="right", va="bottom")
        ax.text(x_lo + 1.0, base_bot - FIN_STUB - 2.4,
                f"dashed, off this section: M3 × {sc['length']:g} screws through the floor into the sink's "
                f"tapped base" + ("; leads standing below the board" if hp.get("obstacles") else ""),
                va="top")

        ax.set_xlim(x_lo, x_hi)
        ax.set_ylim(base_bot - FIN_STUB - 5.0, z["board_top"] + 10.0)
        ax.set_aspect("equal")
        ax.set_xlabel("x along the board (mm, case frame)")
        ax.set_ylabel("z above the case's underside (mm)")
        ax.set_title(f"{c['module']} heat path, section at y = {y_cut:g} mm")
        fig.tight_layout()
        return save(fig, out)
