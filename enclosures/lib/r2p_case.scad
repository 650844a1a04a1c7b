// R2P module case: a base (tray) and a lid (plate), parametric in one list of parameters.
//
// Every number comes from a module's generated enclosures/<module>/board.scad
// (scripts/enclosures generate: board facts read from the .kicad_pcb + the design rules in
// scripts/r2ptools/enclosure/case_rules.py); this file only turns them into solids. The cadquery
// model (scripts/r2ptools/enclosure/solid.py) builds the same solids from the same numbers and
// the tests hold the two to 0.1 % in volume.
//
//   include <../lib/r2p_case.scad>   include <board.scad>   r2p_part(R2P, "base");
//
// Case frame: X = board x, Y = board height - board y (the bus edge is the back), Z up from the
// bed. Parts come out in print orientation: "base" floor down, "lid" underside down (its name
// and stacking pads on top), so neither needs support: every face is vertical, faces up, or
// lies on the bed. "preview" shows the assembly exploded, with the board stand-in.
//
// Parameters (name: meaning):
//   wall floor lid: wall / floor / lid-plate thickness      outer interior: [x0,y0,x1,y1]
//   outer_r inner_r: corner radii                           z_*: levels (floor_top, board_bot,
//   board_top, rim, lid_top)   holes: [[x,y,d]] board mounting holes   boss_d boss_h
//   insert_m3_d insert_m3_depth: bosses and their heat-set insert holes   mounts: [[x,y]] the
//   M5 pattern (floor holes, lid stacking pads)   m5_d pad_d pad_h insert_m5_d
//   cutouts: [[edge, a0, a1, z0]] connector extent along its wall and body bottom; cutout_gap
//   floor_windows: [[x0,y0,x1,y1]] openings in the floor under power packages (a heatsink)
//   dove_*: side-by-side dovetail (rail right, groove left) at dove_y
//   leds: [[x,y]] led_hole_d   pins: [[x,y]] pin_hole_d (push buttons)
//   led_windows vents: [[x0,y0,x1,y1]]   lid_screw_d lid_csk_d
//   name: [text, x, y, size] name_relief font   standin_*: the board stand-in (preview only)
//   only under a floor window (scripts/r2ptools/enclosure/heatpath.py): sink_screws [[x,y]] and
//   sink_screw [hole_d, d, head_d, head_h, length] (holes in the floor); heat_blocks heat_pads
//   heat_sink [x0,y0,z0,x1,y1,z1] heat_sink_base (preview only, dropped 25 mm: exploded)
//   fn: facets per circle

function r2p(P, k) =
    let (v = [for (kv = P) if (kv[0] == k) kv[1]])
    assert(len(v) == 1, str("r2p_case: parameter '", k, "' missing from board.scad"))
    v[0];

// A parameter only some cases have (the heat path under a floor window), or `dflt`.
function r2p_or(P, k, dflt) =
    let (v = [for (kv = P) if (kv[0] == k) kv[1]])
    len(v) == 1 ? v[0] : dflt;

E = 0.01;          // overlap that keeps coplanar faces out of every boolean

module r2p_rounded(box, r, fn) {
    translate([box[0] + r, box[1] + r])
        offset(r = r, $fn = fn) square([box[2] - box[0] - 2 * r, box[3] - box[1] - 2 * r]);
}

// --- base ------------------------------------------------------------------------------------

module r2p_dove_rail(P) {       // on the right wall, slides into a neighbour's groove
    x = r2p(P, "outer")[2]; y = r2p(P, "dove_y");
    r = r2p(P, "dove_root") / 2; t = r2p(P, "dove_tip") / 2; d = r2p(P, "dove_depth");
    linear_extrude(r2p(P, "z_rim"))
        polygon([[x - 0.5, y - r], [x, y - r], [x + d, y - t], [x + d, y + t], [x, y + r], [x - 0.5, y + r]]);
}

module r2p_dove_pad(P) {        // on the left wall, carries the groove
    x = r2p(P, "outer")[0]; y = r2p(P, "dove_y"); w = r2p(P, "dove_pad_w");
    translate([x - r2p(P, "dove_pad_t"), y - w / 2, 0])
        cube([r2p(P, "dove_pad_t") + 0.5, w, r2p(P, "z_rim")]);
}

module r2p_dove_groove(P) {
    x = r2p(P, "outer")[0] - r2p(P, "dove_pad_t"); y = r2p(P, "dove_y"); g = r2p(P, "dove_gap");
    r = r2p(P, "dove_root") / 2 + g; t = r2p(P, "dove_tip") / 2 + g; d = r2p(P, "dove_depth") + g;
    translate([0, 0, -1]) linear_extrude(r2p(P, "z_rim") + 2)
        polygon([[x - 1, y - r], [x, y - r], [x + d, y - t], [x + d, y + t], [x, y + r], [x - 1, y + r]]);
}

// A connector's notch: its extent along the wall plus cutout_gap, from cutout_gap below its body
// through the rim, and through the wall (from inner_r inside, clear of the rounded corners).
module r2p_notch(P, c) {
    o = r2p(P, "outer"); i = r2p(P, "interior"); g = r2p(P, "cutout_gap"); ri = r2p(P, "inner_r");
    z0 = c[3] - g; z1 = r2p(P, "z_rim") + 1;
    a0 = c[1] - g; a1 = c[2] + g;
    if (c[0] == "top")
        translate([a0, i[3] - ri - E, z0]) cube([a1 - a0, o[3] - i[3] + ri + 1, z1 - z0]);
    else if (c[0] == "bottom")
        translate([a0, o[1] - 1, z0]) cube([a1 - a0, i[1] - o[1] + ri + 1 + E, z1 - z0]);
    else if (c[0] == "left")
        translate([o[0] - r2p(P, "dove_pad_t") - 1, a0, z0])
            cube([i[0] - o[0] + r2p(P, "dove_pad_t") + ri + 1 + E, a1 - a0, z1 - z0]);
    else
        translate([i[2] - ri - E, a0, z0]) cube([o[2] - i[2] + r2p(P, "dove_depth") + ri + 1, a1 - a0, z1 - z0]);
}

module r2p_base(P) {
    fn = r2p(P, "fn"); zb = r2p(P, "z_board_bot");
    difference() {
        union() {
            difference() {
                union() {
                    linear_extrude(r2p(P, "z_rim")) r2p_rounded(r2p(P, "outer"), r2p(P, "outer_r"), fn);
                    r2p_dove_rail(P);
                    r2p_dove_pad(P);
                }
                translate([0, 0, r2p(P, "floor")]) linear_extrude(r2p(P, "z_rim"))
                    r2p_rounded(r2p(P, "interior"), r2p(P, "inner_r"), fn);
                for (c = r2p(P, "cutouts")) r2p_notch(P, c);
                for (w = r2p(P, "floor_windows"))        // a heatsink reaches the board here
                    translate([w[0], w[1], -1]) cube([w[2] - w[0], w[3] - w[1], r2p(P, "floor") + 2]);
                r2p_dove_groove(P);
            }
            for (h = r2p(P, "holes"))
                translate([h[0], h[1], r2p(P, "floor") / 2])
                    cylinder(d = r2p(P, "boss_d"), h = zb - r2p(P, "floor") / 2, $fn = fn);
        }
        for (h = r2p(P, "holes"))
            translate([h[0], h[1], zb - r2p(P, "insert_m3_depth")])
                cylinder(d = r2p(P, "insert_m3_d"), h = r2p(P, "insert_m3_depth") + 1, $fn = fn);
        for (m = r2p(P, "mounts"))
            translate([m[0], m[1], -1]) cylinder(d = r2p(P, "m5_d"), h = r2p(P, "floor") + 2, $fn = fn);
        for (s = r2p_or(P, "sink_screws", []))           // the heatsink's screws, down through the floor
            translate([s[0], s[1], -1])
                cylinder(d = r2p(P, "sink_screw")[0], h = r2p(P, "floor") + 2, $fn = fn);
    }
}

// --- lid (in place on the rim) -----------------------------------------------------------------

module r2p_lid(P) {
    fn = r2p(P, "fn"); z0 = r2p(P, "z_rim"); z1 = r2p(P, "z_lid_top"); t = z1 - z0;
    n = r2p(P, "name");
    csk = (r2p(P, "lid_csk_d") - r2p(P, "lid_screw_d")) / 2;      // 90 deg: depth = radius step
    difference() {
        union() {
            translate([0, 0, z0]) linear_extrude(t) r2p_rounded(r2p(P, "outer"), r2p(P, "outer_r"), fn);
            for (m = r2p(P, "mounts"))
                translate([m[0], m[1], z1 - 1]) cylinder(d = r2p(P, "pad_d"), h = r2p(P, "pad_h") + 1, $fn = fn);
            translate([n[1], n[2], z1 - 0.5]) linear_extrude(r2p(P, "name_relief") + 0.5)
                text(n[0], size = n[3], font = r2p(P, "font"), halign = "center", valign = "center", $fn = fn);
        }
        for (h = r2p(P, "holes")) {
            translate([h[0], h[1], z0 - 1]) cylinder(d = r2p(P, "lid_screw_d"), h = t + 2, $fn = fn);
            translate([h[0], h[1], z1 - csk])
                cylinder(d1 = r2p(P, "lid_screw_d"), d2 = r2p(P, "lid_csk_d"), h = csk, $fn = fn);
            translate([h[0], h[1], z1 - E]) cylinder(d = r2p(P, "lid_csk_d"), h = 1, $fn = fn);
        }
        for (l = r2p(P, "leds"))
            translate([l[0], l[1], z0 - 1]) cylinder(d = r2p(P, "led_hole_d"), h = t + 2, $fn = fn);
        for (b = r2p(P, "pins"))
            translate([b[0], b[1], z0 - 1]) cylinder(d = r2p(P, "pin_hole_d"), h = t + 2, $fn = fn);
        for (v = concat(r2p(P, "vents"), r2p(P, "led_windows")))
            translate([v[0], v[1], z0 - 1]) cube([v[2] - v[0], v[3] - v[1], t + 2]);
        for (m = r2p(P, "mounts"))
            translate([m[0], m[1], z0 - 1]) cylinder(d = r2p(P, "insert_m5_d"), h = t + r2p(P, "pad_h") + 2, $fn = fn);
    }
}

// --- board stand-in (preview) -------------------------------------------------------------------

module r2p_standin(P) {
    fn = r2p(P, "fn");
    color("darkgreen") difference() {
        translate([0, 0, r2p(P, "standin_z0")])
            linear_extrude(r2p(P, "standin_z1") - r2p(P, "standin_z0")) polygon(r2p(P, "standin_outline"));
        for (h = r2p(P, "holes")) translate([h[0], h[1], 0]) cylinder(d = h[2], h = 100, $fn = fn);
    }
    for (b = r2p(P, "standin_parts"))
        color(b[6] == "connector" || b[6] == "control" ? "silver" : b[6] == "led" ? "red"
              : b[6] == "warm" ? "orange" : b[6] == "button" ? "black" : "dimgray")
            translate([b[0], b[1], b[2]]) cube([b[3] - b[0], b[4] - b[1], b[5] - b[2]]);
}

module r2p_standoffs(P) {         // M3 M-F hex standoffs, board to lid (preview)
    h = r2p(P, "z_rim") - r2p(P, "z_board_top");
    for (o = r2p(P, "holes")) color("goldenrod") translate([o[0], o[1], r2p(P, "z_board_top")])
        cylinder(d = r2p(P, "standoff_af") * 2 / sqrt(3), h = h, $fn = 6);
}

module r2p_heat_path(P, drop) {   // pads, blocks, heatsink and its screws (preview), `drop` below
    if (len(r2p_or(P, "heat_blocks", [])) > 0) translate([0, 0, -drop]) {
        for (b = r2p(P, "heat_pads")) color("pink") translate([b[0], b[1], b[2]]) cube([b[3] - b[0], b[4] - b[1], b[5] - b[2]]);
        for (b = r2p(P, "heat_blocks")) color("silver") translate([b[0], b[1], b[2]]) cube([b[3] - b[0], b[4] - b[1], b[5] - b[2]]);
        s = r2p(P, "heat_sink"); t = r2p(P, "heat_sink_base");
        color("dimgray") translate([s[0], s[1], s[5] - t]) cube([s[3] - s[0], s[4] - s[1], t]);
        color("darkslategray") translate([s[0], s[1], s[2]]) cube([s[3] - s[0], s[4] - s[1], s[5] - t - s[2]]);
        sc = r2p(P, "sink_screw");
        for (p = r2p(P, "sink_screws")) color("gold") translate([p[0], p[1], r2p(P, "floor") - sc[4]]) {
            cylinder(d = sc[1], h = sc[4], $fn = 24);
            translate([0, 0, sc[4]]) cylinder(d = sc[2], h = sc[3], $fn = 24);
        }
    }
}

module r2p_part(P, part) {
    if (part == "base") r2p_base(P);
    else if (part == "lid") translate([0, 0, -r2p(P, "z_rim")]) r2p_lid(P);
    else if (part == "preview") {
        color("steelblue") r2p_base(P);
        r2p_standin(P);
        r2p_standoffs(P);
        r2p_heat_path(P, 25);
        color("lightsteelblue") translate([0, 0, 25]) r2p_lid(P);
    } else assert(false, str("r2p_part: unknown part '", part, "' (base, lid or preview)"));
}
