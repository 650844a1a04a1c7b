"""The case as exact solids (cadquery/OpenCASCADE), the board stand-in, and the STEP assembly.

Built from a module's parameter file with the same construction as enclosures/lib/r2p_case.scad,
step for step (same order of unions and cuts, same overlaps), so the two agree; the tests compare
their volumes. Circles are exact here and 96-gons in OpenSCAD.

The STEP assembly places everything as mounted: base, lid, board stand-in (outline x thickness,
every part a box of its body x height), the standoffs and, under a floor window, the heat path
(pads, blocks, heatsink, its screws), for people placing a module in a robot's CAD. It is byte-stable: OpenCASCADE's header (time stamp, author, organisation,
originating system) is set to fixed values, and its per-process usage counter renumbered.
"""
from __future__ import annotations

import functools
import math
import re
from dataclasses import dataclass
from pathlib import Path

import cadquery as cq

from .textfit import OPENSCAD_EM

E = 0.01


def _rounded(box, r: float, z0: float, h: float) -> cq.Workplane:
    x0, y0, x1, y1 = box
    return (cq.Workplane("XY").box(x1 - x0, y1 - y0, h, centered=False)
            .edges("|Z").fillet(r).translate((x0, y0, z0)))


def _prism(pts, z0: float, h: float) -> cq.Workplane:
    return cq.Workplane("XY").polyline(pts).close().extrude(h).translate((0, 0, z0))


def _cyl(x: float, y: float, z0: float, d: float, h: float) -> cq.Workplane:
    return cq.Workplane("XY").circle(d / 2).extrude(h).translate((x, y, z0))


def _cube(x0, y0, z0, x1, y1, z1) -> cq.Workplane:
    return cq.Workplane("XY").box(x1 - x0, y1 - y0, z1 - z0, centered=False).translate((x0, y0, z0))


def _union(items: list[cq.Workplane]) -> cq.Workplane:
    """One multi-argument fuse (much faster than fusing pairwise)."""
    if len(items) == 1:
        return items[0]
    first, *rest = (w.val() for w in items)
    return cq.Workplane("XY").add(first.fuse(*rest).clean())


class Params:
    """Attribute access to a module's parameter document: design values, then case values."""

    def __init__(self, doc: dict):
        self.doc = doc
        self.d = doc["design"]
        self.c = doc["case"]

    def __getattr__(self, k: str):
        if k in ("d", "c", "doc"):
            raise AttributeError(k)
        return self.d[k] if k in self.d else self.c[k]


def base_pieces(P: Params) -> tuple[cq.Workplane, list[cq.Workplane], cq.Workplane]:
    """(walls and floor with their cut-outs, the bosses, the holes drilled into both); the base
    is (shell + bosses) - holes, the fit check looks at shell and bosses apart."""
    z = P.c["z"]
    o, i = P.outer, P.interior
    rim = z["rim"]
    # Dovetail rail (right) and the pad carrying the groove (left), as in r2p_case.scad.
    xr, y = o[2], P.dove_y
    r, t, dd = P.dove_root / 2, P.dove_tip / 2, P.dove_depth
    rail = _prism([(xr - 0.5, y - r), (xr, y - r), (xr + dd, y - t), (xr + dd, y + t), (xr, y + r), (xr - 0.5, y + r)], 0, rim)
    pad = _cube(o[0] - P.dove_pad_t, y - P.dove_pad_w / 2, 0, o[0] + 0.5, y + P.dove_pad_w / 2, rim)
    shell = _union([_rounded(o, P.outer_r, 0, rim), rail, pad])
    cuts = [_rounded(i, P.inner_r, P.floor, rim)]
    g, ri = P.cutout_gap, P.inner_r
    for c in P.cutouts:
        z0, z1 = c["z0"] - g, rim + 1
        a0, a1 = c["a0"] - g, c["a1"] + g
        e = c["edge"]
        if e == "top":
            cuts.append(_cube(a0, i[3] - ri - E, z0, a1, o[3] + 1, z1))
        elif e == "bottom":
            cuts.append(_cube(a0, o[1] - 1, z0, a1, i[1] + ri + E, z1))
        elif e == "left":
            cuts.append(_cube(o[0] - P.dove_pad_t - 1, a0, z0, i[0] + ri + E, a1, z1))
        else:
            cuts.append(_cube(i[2] - ri - E, a0, z0, o[2] + P.dove_depth + 1, a1, z1))
    for w in P.floor_windows:                 # a heatsink reaches the board through the floor
        cuts.append(_cube(w[0], w[1], -1, w[2], w[3], P.floor + 1))
    xg = o[0] - P.dove_pad_t
    gr, gt, gd = P.dove_root / 2 + P.dove_gap, P.dove_tip / 2 + P.dove_gap, P.dove_depth + P.dove_gap
    cuts.append(_prism([(xg - 1, y - gr), (xg, y - gr), (xg + gd, y - gt), (xg + gd, y + gt), (xg, y + gr), (xg - 1, y + gr)],
                       -1, rim + 2))
    shell = shell.cut(_union(cuts))
    zb = z["board_bot"]
    bosses = [_cyl(h[0], h[1], P.floor / 2, P.boss_d, zb - P.floor / 2) for h in P.holes]
    holes = [_cyl(h[0], h[1], zb - P.insert_m3_depth, P.insert_m3_d, P.insert_m3_depth + 1) for h in P.holes]
    holes += [_cyl(m[0], m[1], -1, P.m5_d, P.floor + 2) for m in P.mounts]
    hp = P.c.get("heat_path")
    if hp:                                    # the heatsink's screws, down through the floor
        holes += [_cyl(x, y, -1, hp["screw"]["hole_d"], P.floor + 2) for x, y in hp["screws"]]
    return shell, bosses, _union(holes)


def base(P: Params, pieces=None) -> cq.Workplane:
    shell, bosses, holes = pieces or base_pieces(P)
    return _union([shell, *bosses]).cut(holes)


def lid(P: Params) -> cq.Workplane:
    z = P.c["z"]
    z0, z1 = z["rim"], z["lid_top"]
    t = z1 - z0
    n = P.c["name"]
    plate = _rounded(P.outer, P.outer_r, z0, t)
    pads = [_cyl(m[0], m[1], z1 - 1, P.pad_d, P.pad_h + 1) for m in P.mounts]
    text = (cq.Workplane("XY").text(n["text"], n["size"] / OPENSCAD_EM, P.name_relief + 0.5,
                                    fontPath=P.font_file, halign="center", valign="center")
            .translate((n["x"], n["y"], z1 - 0.5)))
    body = _union([plate, *pads, text])
    csk = (P.lid_csk_d - P.lid_screw_d) / 2
    cuts = []
    for h in P.holes:
        cuts.append(_cyl(h[0], h[1], z0 - 1, P.lid_screw_d, t + 2))
        cuts.append(cq.Workplane("XY").add(cq.Solid.makeCone(P.lid_screw_d / 2, P.lid_csk_d / 2, csk,
                                                             cq.Vector(h[0], h[1], z1 - csk))))
        cuts.append(_cyl(h[0], h[1], z1 - E, P.lid_csk_d, 1))
    cuts += [_cyl(l[0], l[1], z0 - 1, P.led_hole_d, t + 2) for l in P.leds]
    cuts += [_cyl(b[0], b[1], z0 - 1, P.pin_hole_d, t + 2) for b in P.pins]
    cuts += [_cube(v[0], v[1], z0 - 1, v[2], v[3], z1 + 1) for v in P.vents + P.led_windows]
    cuts += [_cyl(m[0], m[1], z0 - 1, P.insert_m5_d, t + P.pad_h + 2) for m in P.mounts]
    return body.cut(_union(cuts))


@dataclass
class Standin:
    board: cq.Workplane
    parts: dict[str, cq.Workplane]      # ref -> body box
    leads: dict[str, cq.Workplane]      # ref -> box under (over) the board where leads poke out


def standin(P: Params) -> Standin:
    s = P.c["standin"]
    pts = [tuple(p) for p in s["outline"]]
    if pts[0] == pts[-1]:
        pts = pts[:-1]
    board = _prism(pts, s["z0"], s["z1"] - s["z0"])
    board = board.cut(_union([_cyl(h[0], h[1], s["z0"] - 1, h[2], s["z1"] - s["z0"] + 2) for h in s["holes"]]))
    parts = {p["ref"]: _cube(*p["box"]) for p in s["parts"]}
    leads = {p["ref"]: _cube(*p["box"]) for p in s["leads"]}
    return Standin(board, parts, leads)


def standoffs(P: Params, swept: bool = False) -> list[cq.Workplane]:
    """The hex standoffs between board and lid; `swept`: the cylinder a hex fills turned any way."""
    z = P.c["z"]
    rc = P.standoff_af / math.sqrt(3)          # circumradius of the hexagon
    h = z["rim"] - z["board_top"]
    if swept:
        return [_cyl(x, y, z["board_top"], 2 * rc, h) for x, y, _ in P.holes]
    return [cq.Workplane("XY").polygon(6, 2 * rc).extrude(h).translate((x, y, z["board_top"]))
            for x, y, _ in P.holes]


def heat_path(P: Params, hp: dict | None) -> dict[str, cq.Workplane]:
    """The heat path under the floor window (layout's `heat_path`, heatpath.py), as mounted:
    gap pads, aluminium blocks, the heatsink (its base, and the fins' envelope below it: the
    profile is not known) and its screws (pan head on the floor, shank into the tapped base)."""
    if not hp:
        return {}
    out: dict[str, cq.Workplane] = {}
    for k, (bl, pad) in enumerate(zip(hp["blocks"], hp["pads"]), 1):
        out[f"block{k}"] = _cube(*bl["box"])
        out[f"gap pad{k}"] = _cube(*pad)
    x0, y0, z0, x1, y1, z1 = hp["sink"]
    out["heatsink base"] = _cube(x0, y0, z1 - hp["sink_base"], x1, y1, z1)
    out["heatsink fins"] = _cube(x0, y0, z0, x1, y1, z1 - hp["sink_base"])
    sc = hp["screw"]
    for k, (x, y) in enumerate(hp["screws"], 1):
        head = _cyl(x, y, P.floor, sc["head_d"], sc["head_h"])
        shank = _cyl(x, y, P.floor - sc["length"], sc["d"], sc["length"])
        out[f"sink screw{k}"] = _union([head, shank])
    return out


def m5_heads(P: Params) -> list[cq.Workplane]:
    return [_cyl(m[0], m[1], P.floor, P.m5_head_d, P.m5_head_h) for m in P.mounts]


class Case:
    """A module's case and stand-in, each solid built once, on first use."""

    def __init__(self, P: Params):
        self.P = P

    @functools.cached_property
    def pieces(self):
        return base_pieces(self.P)

    @functools.cached_property
    def base(self) -> cq.Workplane:
        return base(self.P, self.pieces)

    @functools.cached_property
    def lid(self) -> cq.Workplane:
        return lid(self.P)

    @functools.cached_property
    def heat_params(self) -> dict | None:
        """The layout's `heat_path` this case's heat-path solids are built from."""
        return self.P.c.get("heat_path")

    @functools.cached_property
    def heat_path(self) -> dict[str, cq.Workplane]:
        return heat_path(self.P, self.heat_params)

    @functools.cached_property
    def standin(self) -> Standin:
        return standin(self.P)

    def with_standin(self, doc: dict) -> "Case":
        """This case, already built, around the stand-in and heat path of another parameter
        document (the fit check's own tests change the board or the stack, not the case)."""
        k = Case(self.P)
        k.__dict__.update({n: v for n, v in self.__dict__.items() if n in ("pieces", "base", "lid")})
        k.__dict__["standin"] = standin(Params(doc))
        k.__dict__["heat_params"] = doc["case"].get("heat_path")
        return k

    def assembly(self) -> cq.Assembly:
        a = cq.Assembly(name=f"r2p-{self.P.c['module']}")
        a.add(self.base, name="base")
        a.add(self.lid, name="lid")
        a.add(self.standin.board, name="board")
        for ref, w in self.standin.parts.items():
            a.add(w, name=ref)
        for k, w in enumerate(standoffs(self.P), 1):
            a.add(w, name=f"standoff{k}")
        for name, w in self.heat_path.items():
            a.add(w, name=name)
        return a


def write_step(a: cq.Assembly, path: Path, module: str) -> None:
    """STEP AP214 with part names; header fields fixed so the file is byte-stable.

    No colours: OpenCASCADE writes their styled items in a hash order that changes from run to
    run (measured: two writes in one process differ), and a STEP that changes is worse than a
    grey one."""
    from OCP.APIHeaderSection import APIHeaderSection_MakeHeader
    from OCP.IFSelect import IFSelect_ReturnStatus
    from OCP.Interface import Interface_Static
    from OCP.STEPCAFControl import STEPCAFControl_Writer
    from OCP.STEPControl import STEPControl_StepModelType
    from OCP.TCollection import TCollection_HAsciiString
    from OCP.XSControl import XSControl_WorkSession
    from cadquery.occ_impl.assembly import toCAF

    _, doc = toCAF(a, False)
    session = XSControl_WorkSession()
    writer = STEPCAFControl_Writer(session, False)
    writer.SetColorMode(False)
    writer.SetLayerMode(False)
    writer.SetNameMode(True)
    Interface_Static.SetIVal_s("write.surfacecurve.mode", 1)
    Interface_Static.SetIVal_s("write.precision.mode", 0)
    Interface_Static.SetCVal_s("xstep.cascade.unit", "MM")
    Interface_Static.SetCVal_s("write.step.unit", "MM")
    writer.Transfer(doc, STEPControl_StepModelType.STEPControl_AsIs)
    header = APIHeaderSection_MakeHeader(writer.ChangeWriter().Model())
    h = TCollection_HAsciiString
    header.SetName(h(f"r2p-{module}-assembly"))
    header.SetTimeStamp(h("2000-01-01T00:00:00"))
    header.SetAuthorValue(1, h("R2P"))
    header.SetOrganizationValue(1, h("R2P project"))
    header.SetPreprocessorVersion(h("OpenCASCADE via cadquery"))
    header.SetOriginatingSystem(h("scripts/enclosures"))
    header.SetAuthorisation(h(""))
    if writer.Write(str(path)) != IFSelect_ReturnStatus.IFSelect_RetDone:
        raise RuntimeError(f"could not write {path}")
    # OpenCASCADE numbers assembly usages from a counter that lives as long as the process:
    # number them from 1 in file order so the file does not depend on what was written before.
    n = iter(range(1, 1 << 30))
    text = re.sub(r"NEXT_ASSEMBLY_USAGE_OCCURRENCE\('\d+'",
                  lambda _: f"NEXT_ASSEMBLY_USAGE_OCCURRENCE('{next(n)}'", path.read_text())
    path.write_text(text)
