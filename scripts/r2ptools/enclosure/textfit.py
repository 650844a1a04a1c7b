"""The module name's ink extents, for placing it on the lid before either CAD tool draws it.

OpenSCAD's `text(size=s)` sets the font's em to s / 0.72 mm (FreeType at 72 dpi over OpenSCAD's
100 dpi), cadquery's `text(fontsize=f)` sets it to f mm: the cadquery model draws with
`size / OPENSCAD_EM` so both draw the same glyphs. Letter spacing differs slightly (about 2 %
wider in cadquery): the layout measures with cadquery and keeps `keepout` around the ink.
"""
from __future__ import annotations

import functools

OPENSCAD_EM = 0.72


@functools.cache
def ink_box(text: str, size: float, font_file: str) -> tuple[float, float, float, float]:
    """(x0, y0, x1, y1) of `text` centred on the origin, at OpenSCAD size `size`."""
    import cadquery as cq
    s = cq.Workplane().text(text, size / OPENSCAD_EM, 1.0, fontPath=font_file,
                            halign="center", valign="center").val()
    bb = s.BoundingBox()
    return round(bb.xmin, 4), round(bb.ymin, 4), round(bb.xmax, 4), round(bb.ymax, 4)
