"""The case's design rules: wall thicknesses, fit gaps and the standard hardware it is built around.

These are the only hand-chosen numbers in a case; everything board-specific comes from the
`.kicad_pcb`. They are written into every module's parameter file (`enclosures/<m>/<m>.json`,
`board.scad`), so the OpenSCAD library and the cadquery model read the same values, and
docs/enclosures.md states them for printing and assembly.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, field


@dataclass(frozen=True)
class Design:
    # --- printed walls (0.4 mm nozzle: 2.0 mm = 5 perimeters) ------------------------------
    wall: float = 2.0            # side walls
    floor: float = 2.0           # base floor
    lid: float = 3.0             # lid plate (holds the 1.7 mm countersunk M3 heads)

    # --- fit gaps (printed part to board/parts); the fit check demands >= min_clearance ----
    min_clearance: float = 0.5   # what the fit check proves, everywhere but the boss contacts
    board_gap: float = 0.6       # board edge to wall inner face, per side
    cutout_gap: float = 0.6      # connector body to the sides and bottom of its wall cut-out
    lead_protrusion: float = 2.5  # THT leads below the board (IPC-A-610 class 2 maximum)

    # --- PCB mounting: boss with an M3 heat-set insert, M-F hex standoff, lid screw --------
    boss_d: float = 7.0
    boss_h_min: float = 5.0      # floor to board underside; >= M5 button head + gap
    insert_m3_d: float = 4.0     # hole for an M3 x 5.7 heat-set insert (e.g. Ruthex RX-M3x5.7)
    insert_m3_depth: float = 6.0
    # M3 male-female hex standoff, 5 mm across flats (SW5): in any rotation its corners stay
    # inside KiCad's M3 hole courtyard (r 3.5) less min_clearance; the 5.5 mm kind does not.
    standoff_af: float = 5.0
    standoff_male: float = 6.0   # its thread: 1.6 mm board + 4.4 mm into the insert
    standoff_lengths: tuple[float, ...] = (8.0, 10.0, 12.0, 15.0, 20.0, 25.0, 30.0)
    lid_screw_d: float = 3.4     # M3 clearance
    lid_csk_d: float = 6.4       # 90 deg countersink for ISO 10642 M3 (head 6.0 mm)

    # --- mounting pattern shared by floor (T-slot) and lid (stacking), about the centre of the
    # bus end (the form factor's 60 x 50 mm, docs/bus.md: the whole board on a standard module),
    # so a longer board (the motor's) stacks and mounts like the others, its power end free
    bus_end_w: float = 60.0
    tslot_dx: float = 15.0       # two M5 holes at centre +/- dx: profile along the 60 mm side
    tslot_dy: float = 12.0       # two M5 holes at centre +/- dy: profile across it
    m5_d: float = 5.5            # M5 clearance
    m5_head_d: float = 9.5       # ISO 7380 M5 button head, on the floor inside the case
    m5_head_h: float = 2.75
    pad_d: float = 10.0          # stacking pads on the lid, same pattern as the floor holes
    pad_h: float = 4.0           # the module above stands on them (clears name and vents)
    insert_m5_d: float = 6.4     # M5 x 5.8 heat-set insert (e.g. Ruthex RX-M5x5.8), through

    # --- side-by-side: vertical dovetail, rail on the right wall, groove on the left -------
    dove_root: float = 6.0       # rail width at the wall
    dove_tip: float = 9.0        # rail width at its face
    dove_depth: float = 2.5
    dove_gap: float = 0.2        # sliding fit, per face
    dove_pad_w: float = 15.0     # the left wall's pad that carries the groove
    dove_pad_t: float = 3.5

    # --- lid features ------------------------------------------------------------------------
    led_hole_d: float = 3.2      # a 3 mm acrylic light pipe, or left open
    min_bar: float = 1.0         # least lid between two holes; closer LEDs share a window
    pin_hole_d: float = 2.0      # over a push button: press it with a pin or a paperclip
    vent_w: float = 1.6          # slot width (keeps out a 2.5 mm probe)
    vent_pitch: float = 3.6      # slot + 2.0 mm bar
    vent_margin: float = 3.0     # vent field beyond a warm part's courtyard
    vent_min_len: float = 4.0
    keepout: float = 1.5         # vents and the name keep this far from other lid features
    name_sizes: tuple[float, ...] = (6.0, 5.0, 4.0)  # OpenSCAD text size, largest that fits
    name_relief: float = 0.8     # raised by this much on the lid
    font: str = "DejaVu Sans:style=Bold"
    font_file: str = "/usr/share/fonts/truetype/dejavu/DejaVuSans-Bold.ttf"  # fonts-dejavu-core

    # --- board reading -----------------------------------------------------------------------
    edge_near: float = 2.0       # a connector or switch courtyard this close to an edge faces it
    min_pillar: float = 3.0      # notches closer than this on one wall merge (no slivers of wall)
    fn: int = 96                 # OpenSCAD facets per circle ($fn)

    standard_parts: dict[str, str] = field(default_factory=lambda: {
        "board insert": "M3 x 5.7 heat-set insert (Ruthex RX-M3x5.7 or equal), 4 per case",
        "standoff": "M3 male-female hex standoff, 5 mm AF (SW5), 6 mm thread, 4 per case",
        "lid screw": "M3 x 6 countersunk ISO 10642, 4 per case",
        "stack insert": "M5 x 5.8 heat-set insert (Ruthex RX-M5x5.8 or equal), 4 per lid",
        "mount screw": "M5 x 8 button head ISO 7380 + M5 slot-6 T-nut (20x20 B-type profile)",
    })

    def as_dict(self) -> dict:
        d = asdict(self)
        d["standard_parts"] = dict(sorted(d["standard_parts"].items()))
        return d


DESIGN = Design()
