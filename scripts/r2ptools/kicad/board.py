"""PCB stage of the generator: netlist + description → a placed board with its fixed copper.

The shared form factor (docs/bus.md, docs/hardware.md): 60 x 50 mm, 2 mm corner radius, four M3
holes on a 52 x 42 mm grid at (4, 4) from each corner, bus edge on top. Coordinates in the
descriptions are mm from the board's top-left corner; the board sits at ORIGIN on the KiCad page
and the aux (drill/place) origin and grid origin are set to that corner, so fab outputs are in
board coordinates.

This stage places every footprint, assigns every pad its net from KiCad's netlist, writes the
design rules (fab capability and net classes), the ground pours, the hand-routed power copper
and the silkscreen. Signal routing is `route.py`'s job.
"""
from __future__ import annotations

import math
from pathlib import Path

import pcbnew

from . import fabcap
from .design import Module, Text
from .netlist import Netlist

FP_DIR = Path("/usr/share/kicad/footprints")
ORIGIN = (100.0, 60.0)          # the board's top-left corner on the KiCad page, mm
BOARD_W, BOARD_H, CORNER_R = 60.0, 50.0, 2.0
HOLES = [(4.0, 4.0), (56.0, 4.0), (4.0, 46.0), (56.0, 46.0)]
HOLE_FP = ("MountingHole", "MountingHole_3.2mm_M3")
FIDUCIAL_FP = ("Fiducial", "Fiducial_1mm_Mask2mm")
"""Global fiducials for the assembler's vision system: 1 mm copper in a 2 mm mask opening, three
per board (`Module.fiducials`), board-only (no symbol), on no BOM and in no placement file."""
NOT_ASSEMBLED = pcbnew.FP_EXCLUDE_FROM_BOM | pcbnew.FP_EXCLUDE_FROM_POS_FILES


LAYERS = {"F.Cu": pcbnew.F_Cu, "In1.Cu": pcbnew.In1_Cu, "In2.Cu": pcbnew.In2_Cu, "B.Cu": pcbnew.B_Cu, "F.SilkS": pcbnew.F_SilkS,
          "B.SilkS": pcbnew.B_SilkS, "F.Fab": pcbnew.F_Fab, "B.Fab": pcbnew.B_Fab}


def mm(v: float) -> int:
    return pcbnew.FromMM(v)


def pt(x: float, y: float) -> pcbnew.VECTOR2I:
    """Board coordinates (mm from the top-left corner) to KiCad internal units."""
    return pcbnew.VECTOR2I(mm(ORIGIN[0] + x), mm(ORIGIN[1] + y))


PROJECT_FP_DIR = Path(__file__).resolve().parents[3] / "hardware" / "core"
"""Where the project's own library (`R2P.pretty`, r2ptools.kicad.fplib) lives."""


def load_footprint(lib_id: str) -> pcbnew.FOOTPRINT:
    """A footprint by lib id: KiCad's library, or the project's own (`R2P:`, fplib.LIB)."""
    lib, name = lib_id.split(":", 1)
    where = PROJECT_FP_DIR if (PROJECT_FP_DIR / f"{lib}.pretty").is_dir() else FP_DIR
    fp = pcbnew.FootprintLoad(str(where / f"{lib}.pretty"), name)
    if fp is None:
        raise FileNotFoundError(f"footprint {lib_id} not found under {where}")
    fp.SetFPID(pcbnew.LIB_ID(lib, name))
    return fp


def _outline(board: pcbnew.BOARD, size: tuple[float, float] = (BOARD_W, BOARD_H)) -> None:
    r = CORNER_R
    w, h = size
    segs = [((r, 0), (w - r, 0)), ((w, r), (w, h - r)), ((w - r, h), (r, h)), ((0, h - r), (0, r))]
    for a, b in segs:
        s = pcbnew.PCB_SHAPE(board)
        s.SetShape(pcbnew.SHAPE_T_SEGMENT)
        s.SetLayer(pcbnew.Edge_Cuts)
        s.SetWidth(mm(0.05))
        s.SetStart(pt(*a))
        s.SetEnd(pt(*b))
        board.Add(s)
    # corner arcs: centre, start, end (counter-clockwise in screen coordinates)
    for cx, cy, start in ((r, r, (0, r)), (w - r, r, (w - r, 0)), (w - r, h - r, (w, h - r)),
                          (r, h - r, (r, h))):
        s = pcbnew.PCB_SHAPE(board)
        s.SetShape(pcbnew.SHAPE_T_ARC)
        s.SetLayer(pcbnew.Edge_Cuts)
        s.SetWidth(mm(0.05))
        s.SetCenter(pt(cx, cy))
        s.SetStart(pt(*start))
        s.SetArcAngleAndEnd(pcbnew.EDA_ANGLE(90, pcbnew.DEGREES_T), True)
        board.Add(s)


def outline_size(board: pcbnew.BOARD) -> tuple[float, float]:
    """Width and height of the board outline in mm, from its Edge.Cuts segments' end points."""
    xs, ys = [], []
    for d in board.GetDrawings():
        if d.GetLayer() == pcbnew.Edge_Cuts and d.GetShape() == pcbnew.SHAPE_T_SEGMENT:
            for p in (d.GetStart(), d.GetEnd()):
                xs.append(pcbnew.ToMM(p.x) - ORIGIN[0])
                ys.append(pcbnew.ToMM(p.y) - ORIGIN[1])
    return (round(max(xs), 4), round(max(ys), 4)) if xs else (BOARD_W, BOARD_H)


def _text(board: pcbnew.BOARD, t: Text) -> None:
    x = pcbnew.PCB_TEXT(board)
    x.SetText(t.text)
    x.SetLayer(LAYERS[t.layer])
    x.SetPosition(pt(t.x, t.y))
    x.SetTextSize(pcbnew.VECTOR2I(mm(t.size), mm(t.size)))
    x.SetTextThickness(mm(max(0.15, t.size * 0.15)))
    x.SetTextAngleDegrees(t.rot)
    if t.layer.startswith("B."):
        x.SetMirrored(True)
    board.Add(x)


def _zone(board: pcbnew.BOARD, nets: dict[str, pcbnew.NETINFO_ITEM], z, resolve=lambda n: n) -> pcbnew.ZONE:
    zone = pcbnew.ZONE(board)
    zone.SetLayer(LAYERS[z.layer])
    if z.net:
        zone.SetNet(nets[z.net] if z.net in nets else nets[resolve(z.net)])
    ol = zone.Outline()
    ol.NewOutline()
    for x, y in z.polygon:
        p = pt(x, y)
        ol.Append(p.x, p.y)
    zone.SetAssignedPriority(z.priority)
    zone.SetMinThickness(mm(z.min_width))
    zone.SetThermalReliefGap(mm(z.thermal_gap))
    zone.SetThermalReliefSpokeWidth(mm(z.spoke))
    zone.SetLocalClearance(mm(fabcap.POUR_CLEARANCE))
    # SMD pads join pours solid (reflow needs no relief); THT pads by spokes, solid for power
    zone.SetPadConnection(pcbnew.ZONE_CONNECTION_FULL if z.solid else pcbnew.ZONE_CONNECTION_THT_THERMAL)
    zone.SetIslandRemovalMode(pcbnew.ISLAND_REMOVAL_MODE_ALWAYS)
    board.Add(zone)
    return zone


def build(m: Module, net: Netlist) -> pcbnew.BOARD:
    from .fplib import source as fplib_source      # fplib builds on this module
    pcbnew.KIID.SeedGenerator(m.seed)
    board = pcbnew.BOARD()
    board.SetCopperLayerCount(m.copper_layers)
    for layer in (pcbnew.In1_Cu, pcbnew.In2_Cu)[:m.copper_layers - 2]:
        # inner layers are planes (Module.zones): the router keeps signals off them
        board.SetLayerType(layer, pcbnew.LT_POWER)
    fabcap.apply(board, m.netclass_defs)
    ds = board.GetDesignSettings()
    ds.SetAuxOrigin(pt(0, 0))
    ds.SetGridOrigin(pt(0, 0))
    tb = board.GetTitleBlock()
    tb.SetTitle(m.title)
    tb.SetRevision(m.revision)
    tb.SetCompany("R2P - Rapid Robot Prototyping")
    tb.SetComment(0, "Scaffolded by scripts/hwgen; these KiCad files are the source: edit them in KiCad 9")
    _outline(board, m.size)

    nets: dict[str, pcbnew.NETINFO_ITEM] = {}
    for name in sorted(net.nets):
        ni = pcbnew.NETINFO_ITEM(board, name)
        board.Add(ni)
        nets[name] = ni
    pin_net = net.pin_nets()

    places = {p.ref: p.place for _, p in m.all_parts()}
    not_assembled = {p.ref for _, p in m.all_parts() if not p.item.on_bom}
    places.update(m.places)
    for ref in sorted(net.components, key=lambda r: (r.rstrip("0123456789"), int(r[len(r.rstrip("0123456789")):] or 0))):
        c = net.components[ref]
        if not c.footprint:
            continue
        # a project variant (R2P:) is routed as its KiCad source: fplib.py swaps its silk in later
        fp = load_footprint(fplib_source(c.footprint))
        fp.SetReference(ref)
        fp.SetValue(c.value)
        # a library footprint's own clearance override (0.2 mm on the HTSSOP-20) can be wider than
        # its pad gaps; the net classes and the fab rules set the clearance instead
        fp.SetLocalClearance(None)
        fp.SetPath(pcbnew.KIID_PATH(c.path))
        fp.SetSheetname(c.sheetname)
        fp.SetSheetfile(c.sheetfile)
        for k in ("Datasheet", "Description", "MPN", "Manufacturer", "LCSC"):
            if k in c.fields:
                fp.SetField(k, c.fields[k])
                f = fp.GetFieldByName(k)
                f.SetVisible(False)
                f.SetLayer(pcbnew.F_Fab)
        place = places.get(ref)
        if place is None:
            raise ValueError(f"{m.name}: {ref} has no placement in the description")
        fp.SetPosition(pt(place.x, place.y))
        fp.SetOrientationDegrees(place.rot)
        if ref in not_assembled:        # test pads: copper only, nothing to buy or place
            fp.SetAttributes(fp.GetAttributes() | NOT_ASSEMBLED)
        for pad in fp.Pads():
            n = pin_net.get((ref, pad.GetNumber()))
            if n is not None:
                pad.SetNet(nets[n])
        for txt in (fp.Reference(), fp.Value()):
            txt.SetTextSize(pcbnew.VECTOR2I(mm(0.8), mm(0.8)))
            txt.SetTextThickness(mm(0.15))
        if ref in m.solid_pads:         # power pads: solid pour joins, no thermal spokes
            fp.SetLocalZoneConnection(pcbnew.ZONE_CONNECTION_FULL)
        board.Add(fp)
        if place.back:                  # flipping needs the footprint on a board
            fp.Flip(fp.GetPosition(), pcbnew.FLIP_DIRECTION_LEFT_RIGHT)

    for i, (x, y) in enumerate(HOLES if m.holes is None else m.holes, start=1):
        fp = load_footprint(":".join(HOLE_FP))
        fp.SetReference(f"H{i}")
        fp.SetValue("M3")
        fp.Reference().SetVisible(False)
        fp.SetAttributes(fp.GetAttributes() | pcbnew.FP_BOARD_ONLY | pcbnew.FP_EXCLUDE_FROM_BOM
                         | pcbnew.FP_EXCLUDE_FROM_POS_FILES)
        fp.SetPosition(pt(x, y))
        board.Add(fp)

    if len(m.fiducials) != 3:
        raise ValueError(f"{m.name}: {len(m.fiducials)} fiducials; the assembler wants 3 "
                         "(Module.fiducials, mm from the top-left corner)")
    for i, (x, y) in enumerate(m.fiducials, start=1):
        fp = load_footprint(":".join(FIDUCIAL_FP))
        fp.SetReference(f"FID{i}")
        fp.SetValue("Fiducial")
        fp.Reference().SetVisible(False)
        fp.SetAttributes(fp.GetAttributes() | pcbnew.FP_BOARD_ONLY | NOT_ASSEMBLED)
        fp.SetPosition(pt(x, y))
        board.Add(fp)

    for t in m.texts:
        _text(board, t)
    for z in m.zones:
        _zone(board, nets, z, net.resolve)
    for tr in m.tracks:
        for a, b in zip(tr.points, tr.points[1:]):
            t = pcbnew.PCB_TRACK(board)
            t.SetStart(pt(*a))
            t.SetEnd(pt(*b))
            t.SetWidth(mm(tr.width))
            t.SetLayer(LAYERS[tr.layer])
            t.SetNet(nets[net.resolve(tr.net)])
            t.SetLocked(True)
            board.Add(t)
    for v in m.vias:
        via = pcbnew.PCB_VIA(board)
        via.SetPosition(pt(v.x, v.y))
        via.SetWidth(mm(v.size))
        via.SetDrill(mm(v.drill))
        via.SetViaType(pcbnew.VIATYPE_THROUGH)
        via.SetNet(nets[net.resolve(v.net)])
        via.SetLocked(True)
        board.Add(via)
    for k in m.keepouts:
        z = pcbnew.ZONE(board)
        z.SetIsRuleArea(True)
        z.SetDoNotAllowTracks(k.tracks)
        z.SetDoNotAllowVias(not k.vias)
        z.SetDoNotAllowPads(False)
        z.SetDoNotAllowFootprints(False)
        z.SetDoNotAllowCopperPour(False)
        ls = pcbnew.LSET()
        for layer in k.layers:
            ls.AddLayer(LAYERS[layer])
        z.SetLayerSet(ls)
        ol = z.Outline()
        ol.NewOutline()
        for x, y in k.polygon:
            p = pt(x, y)
            ol.Append(p.x, p.y)
        board.Add(z)
    return board


def ground_pours(board: pcbnew.BOARD) -> None:
    """GND on both sides over the whole board, lowest priority: everything else cuts into them.

    Added after routing: the router connects every GND pad with real copper first (so no pad
    depends on a pour surviving between tracks), then the pours join and shield it all."""
    from .design import Zone
    nets = {board.FindNet("GND").GetNetname(): board.FindNet("GND")}
    inset = 0.3
    w, h = outline_size(board)
    poly = [(inset, inset), (w - inset, inset), (w - inset, h - inset), (inset, h - inset)]
    for layer in ("F.Cu", "B.Cu"):
        _zone(board, nets, Zone("GND", layer, poly, priority=0, min_width=0.25, thermal_gap=0.3,
                                spoke=0.4))


def fill(board: pcbnew.BOARD) -> None:
    pcbnew.ZONE_FILLER(board).Fill(board.Zones())


def save(board: pcbnew.BOARD, path: Path, classes: dict[str, list[str]], rules: str = "") -> None:
    """Saves the board and its project (rules, net classes) in a byte-stable form; `rules` are
    the board's own custom design rules, written after the fab's."""
    pcbnew.SaveBoard(str(path), board)
    fabcap.normalise_project(path.with_suffix(".kicad_pro"), classes)
    fabcap.write_dru(path.with_suffix(".kicad_dru"), rules)
    prl = path.with_suffix(".kicad_prl")
    if prl.exists():
        prl.unlink()


def load(path: Path) -> pcbnew.BOARD:
    return pcbnew.LoadBoard(str(path))
