"""The fab capability every board is checked against: JLCPCB standard 2-layer, 1 oz outer copper.

Minimums are the fab's published capability (JLCPCB "PCB capabilities", standard 2-layer, 1.6 mm
FR-4): 0.127 mm (5 mil) track and space, 0.3 mm minimum drill, 0.6 mm minimum via diameter
(0.15 mm annular ring, above their 0.13 mm minimum), 0.5 mm hole to hole, 0.3 mm copper to the
board edge, 0.15 mm silkscreen line and 1 mm text. They go into the board's design rules
(`.kicad_pro` → board.design_settings.rules) and `.kicad_dru`, so KiCad's DRC fails a board the
fab could not make. Net classes then ask for more than the minimum where it is cheap: 0.2 mm
signal tracks with 0.15 mm clearance (0.65 mm-pitch pins leave 0.19 mm), 0.4 mm local power,
0.7/0.3 mm vias (two vias at 0.15 mm copper clearance keep their holes the fab's 0.5 mm apart);
the 4 A paths are drawn by hand (module descriptions), not autorouted.
"""
from __future__ import annotations

import json
from pathlib import Path

import pcbnew

MIN_TRACK = 0.127
MIN_CLEARANCE = 0.127
MIN_DRILL = 0.3
MIN_VIA = 0.6
MIN_ANNULAR = 0.13
HOLE_TO_HOLE = 0.5
EDGE_CLEARANCE = 0.3
HOLE_CLEARANCE = 0.25
SILK_CLEARANCE = 0.0
MIN_TEXT_HEIGHT = 0.8
MIN_TEXT_THICKNESS = 0.15
POUR_CLEARANCE = 0.25

NETCLASSES = {
    # name: (clearance, track width, via diameter, via drill)
    "Default": (0.15, 0.2, 0.7, 0.3),
    "Power": (0.2, 0.4, 0.8, 0.4),
}

DRU = """(version 1)
# JLCPCB standard 2-layer capability (r2ptools/kicad/fabcap.py). Generated; do not edit.
(rule "fab: minimum track width"
    (constraint track_width (min {track}mm)))
(rule "fab: minimum copper clearance"
    (constraint clearance (min {clearance}mm)))
(rule "fab: minimum drill"
    (constraint hole_size (min {drill}mm)))
(rule "fab: minimum via diameter"
    (condition "A.Type == 'Via'")
    (constraint via_diameter (min {via}mm)))
(rule "fab: minimum annular ring"
    (constraint annular_width (min {annular}mm)))
(rule "fab: hole to hole"
    (constraint hole_to_hole (min {h2h}mm)))
(rule "fab: copper to board edge"
    (constraint edge_clearance (min {edge}mm)))
"""


def apply(board: pcbnew.BOARD, extra: dict[str, tuple[float, float, float, float]] | None = None) -> None:
    """The fab's minimums and the net classes; `extra` adds a board's own classes (the PSU's
    high-voltage class, so the autorouter keeps its spacing)."""
    ds = board.GetDesignSettings()
    mm = pcbnew.FromMM
    ds.m_TrackMinWidth = mm(MIN_TRACK)
    ds.m_MinClearance = mm(MIN_CLEARANCE)
    ds.m_MinThroughDrill = mm(MIN_DRILL)
    ds.m_ViasMinSize = mm(MIN_VIA)
    ds.m_ViasMinAnnularWidth = mm(MIN_ANNULAR)
    ds.m_HoleToHoleMin = mm(HOLE_TO_HOLE)
    ds.m_CopperEdgeClearance = mm(EDGE_CLEARANCE)
    ds.m_HoleClearance = mm(HOLE_CLEARANCE)
    ds.m_SilkClearance = mm(SILK_CLEARANCE)
    ds.m_MinSilkTextHeight = mm(MIN_TEXT_HEIGHT)
    ds.m_MinSilkTextThickness = mm(MIN_TEXT_THICKNESS)
    ds.m_MinResolvedSpokes = 1     # a THT pad between two other-net pins may keep a single spoke
    ns = ds.m_NetSettings
    for name, (cl, tw, vd, vdr) in {**NETCLASSES, **(extra or {})}.items():
        nc = ns.GetDefaultNetclass() if name == "Default" else pcbnew.NETCLASS(name)
        nc.SetClearance(mm(cl))
        nc.SetTrackWidth(mm(tw))
        nc.SetViaDiameter(mm(vd))
        nc.SetViaDrill(mm(vdr))
        if name != "Default":
            ns.SetNetclass(name, nc)


def assign(board: pcbnew.BOARD, classes: dict[str, list[str]]) -> None:
    """Net class of each net (exact names): {"Power": ["+3V3", ...]}."""
    ns = board.GetDesignSettings().m_NetSettings
    for cls, names in classes.items():
        for n in names:
            ns.SetNetclassPatternAssignment(n, cls)


def write_dru(path: Path, extra: str = "") -> None:
    path.write_text(DRU.format(track=MIN_TRACK, clearance=MIN_CLEARANCE, drill=MIN_DRILL,
                               via=MIN_VIA, annular=MIN_ANNULAR, h2h=HOLE_TO_HOLE,
                               edge=EDGE_CLEARANCE) + extra)


def normalise_project(path: Path, classes: dict[str, list[str]]) -> None:
    """Re-writes KiCad's .kicad_pro with sorted keys and the net-class table made explicit.

    KiCad saves what it holds in memory; writing it back sorted makes the file byte-stable and
    lets a reader see the rules, the classes and which nets they apply to in one place."""
    d = json.loads(path.read_text())
    rules = d["board"]["design_settings"]["rules"]
    rules.update({
        "min_clearance": MIN_CLEARANCE, "min_track_width": MIN_TRACK,
        "min_through_hole_diameter": MIN_DRILL, "min_via_diameter": MIN_VIA,
        "min_via_annular_width": MIN_ANNULAR, "min_hole_to_hole": HOLE_TO_HOLE,
        "min_copper_edge_clearance": EDGE_CLEARANCE, "min_hole_clearance": HOLE_CLEARANCE,
        "min_silk_clearance": SILK_CLEARANCE, "min_text_height": MIN_TEXT_HEIGHT,
        "min_text_thickness": MIN_TEXT_THICKNESS, "min_resolved_spokes": 1,
    })
    ns = d.setdefault("net_settings", {})
    ns["netclass_patterns"] = [{"netclass": c, "pattern": n}
                               for c, names in sorted(classes.items()) for n in sorted(names)]
    path.write_text(json.dumps(d, indent=2, sort_keys=True) + "\n")
