"""One module's case, from its board to every committed file, and the fit that proves it.

    enclosures/<m>/<m>.json        parameters: design rules, board facts, case layout
    enclosures/<m>/board.scad      the same numbers for OpenSCAD
    enclosures/<m>/<m>.scad        top file: include the library and the numbers, pick a part
    enclosures/<m>/<m>-base.stl    printed parts, print orientation (OpenSCAD, facets sorted)
    enclosures/<m>/<m>-lid.stl
    enclosures/<m>/<m>-assembly.step   base, lid, board stand-in, standoffs, heat path (cadquery)
    enclosures/<m>/<m>.png         exploded preview (OpenSCAD)
    enclosures/<m>/<m>-heat-path.png   the heat path's stack in section (a case with one)
    enclosures/<m>/README.md       sizes, clearances, hardware, print settings
"""
from __future__ import annotations

import shutil
import time
from dataclasses import dataclass, field
from pathlib import Path

from . import ROOT_LIB, board_facts, fit, heatpath_section, layout, mesh, params, render, solid
from .case_rules import DESIGN, Design

PLA_DENSITY = 1.24   # g/cm^3, for the README's mass estimate (PETG: 1.27)


@dataclass
class Result:
    module: str
    out: Path
    seconds: dict[str, float] = field(default_factory=dict)
    fit: fit.Report | None = None
    volumes: dict[str, tuple[float, float]] = field(default_factory=dict)   # part: (stl, cadquery)


def files(module: str, heat_path: bool = False) -> list[str]:
    """The files a generated case consists of; `heat_path`: the case has one (its section)."""
    return [f"{module}.json", "board.scad", f"{module}.scad", f"{module}-base.stl", f"{module}-lid.stl",
            f"{module}-assembly.step", f"{module}.png", "README.md"] + \
        ([f"{module}-heat-path.png"] if heat_path else [])


def has_heat_path(out: Path, module: str) -> bool:
    """True if the case in `out` was generated with a heat path (its parameters say)."""
    return params.read_json(out / f"{module}.json")["case"].get("heat_path") is not None


def parameters(pcb: Path, source: str, design: Design = DESIGN) -> dict:
    b = board_facts.read(pcb, design)
    return params.document(source, design.as_dict(), b.as_dict(), layout.layout(b, design))


def generate(pcb: Path, source: str, enclosures: Path, png: bool = True, design: Design = DESIGN) -> Result:
    """Writes module `pcb.stem`'s case into `enclosures/<m>/` (the library is copied beside it
    when `enclosures` is not the repository's, so the .scad files resolve)."""
    module = pcb.stem
    out = enclosures / module
    out.mkdir(parents=True, exist_ok=True)
    lib = enclosures / "lib" / ROOT_LIB.name
    if lib.resolve() != ROOT_LIB.resolve():
        lib.parent.mkdir(exist_ok=True)
        shutil.copyfile(ROOT_LIB, lib)
    r = Result(module, out)
    t = time.monotonic()
    doc = parameters(pcb, source, design)
    params.write_json(doc, out / f"{module}.json")
    params.write_scad(doc, out / "board.scad")
    params.write_top(module, source, out / f"{module}.scad")
    r.seconds["parameters"] = time.monotonic() - t

    top = out / f"{module}.scad"
    t = time.monotonic()
    procs = {part: (render.start(top, part, out / f".{module}-{part}.raw.stl"), out / f".{module}-{part}.raw.stl")
             for part in ("base", "lid")}
    # cadquery works while OpenSCAD renders (two cores).
    K = solid.Case(solid.Params(params.read_json(out / f"{module}.json")))
    tc = time.monotonic()
    solid.write_step(K.assembly(), out / f"{module}-assembly.step", module)
    r.seconds["cadquery STEP"] = time.monotonic() - tc
    tf = time.monotonic()
    r.fit = fit.check(K)
    r.seconds["fit check"] = time.monotonic() - tf
    for part, (p, raw) in procs.items():
        render.finish(p, f"{top.name} part={part}")
        mesh.canonical_stl(raw, out / f"{module}-{part}.stl", f"R2P {module} {part}: OpenSCAD 2021.01, facets sorted")
        raw.unlink()
    r.seconds["OpenSCAD STL (both parts, in parallel with the above)"] = time.monotonic() - t
    for part, shape in (("base", K.base), ("lid", K.lid)):
        r.volumes[part] = (mesh.volume(out / f"{module}-{part}.stl"), shape.val().Volume())
    if png:
        t = time.monotonic()
        render.preview(top, out / f"{module}.png")
        r.seconds["OpenSCAD PNG"] = time.monotonic() - t
    if doc["case"].get("heat_path"):
        heatpath_section.draw(doc, out / f"{module}-heat-path.png")
    (out / "README.md").write_text(readme(doc, r, source))
    return r


def _count(n: int, what: str) -> str:
    return f"{n} {what}{'' if n == 1 else 's'}"


def readme(doc: dict, r: Result, source: str) -> str:
    d, c = doc["design"], doc["case"]
    m = c["module"]
    o, z = c["outer"], c["z"]
    width = o[2] - o[0]
    led_h = [p["h"] for p in doc["board"]["parts"] if p["kind"] == "led"]
    # A light pipe runs from just above the LED (0.5 mm) to the lid's top face.
    pipe = (f"Ø3 mm acrylic, {z['lid_top'] - z['board_top'] - max(led_h) - 0.5:.1f} mm long"
            if led_h else "none")
    lines = [
        f"# {m} case",
        "",
        f"<!-- {doc['generated_by']} -->",
        f"Generated from `{source}` by `make enclosures`; how to print, assemble and mount it:",
        "[docs/enclosures.md](../../docs/enclosures.md).",
        "",
        f"![{m} case, exploded, with the board stand-in]({m}.png)",
        "",
        "| | |",
        "|---|---|",
        f"| outside (walls) | {width:.1f} × {o[3] - o[1]:.1f} × {z['lid_top']:.1f} mm "
        f"(+{d['dove_depth']} mm dovetail rail right, +{d['dove_pad_t']} mm groove pad left, "
        f"+{d['pad_h']} mm stacking pads on top) |",
        f"| board | rests on {len(c['holes'])} bosses {c['boss_h']} mm above the floor, "
        f"{d['board_gap']} mm from the walls |",
        f"| lid | {c['standoff']:.0f} mm standoffs above the board |",
        f"| cut-outs | " + (", ".join(f"{k['ref']} ({k['edge']} edge" + (
            f", through the dovetail {k['dovetail']}: it stays below and beside the notch" if "dovetail" in k else "")
            + ")" for k in c["cutouts"]) or "none") + " |",
        f"| lid openings | {_count(len(c['leds']), 'light-pipe hole')} Ø{d['led_hole_d']} mm, "
        f"{_count(len(c['led_windows']), 'window')} over a row of LEDs, "
        f"{_count(len(c['pins']), 'pin hole')} Ø{d['pin_hole_d']} mm over push buttons; light pipes: {pipe} |",
        f"| vents | {_count(len(c['vents']), 'slot')} {d['vent_w']} mm wide over the warm parts |" if c["vents"]
        else "| vents | none (no warm parts) |",
    ]
    for w in c.get("floor_windows", []):
        lines.append(f"| heatsink window | {w[2] - w[0]:.1f} × {w[3] - w[1]:.1f} mm open in the floor under the "
                     "power packages (their tabs on thermal vias), min_clearance beyond them |")
    hp = c.get("heat_path")
    if hp:
        lines += _heat_rows(hp, d, z)
    if r.fit:
        worst = sorted(r.fit.nearest.items(), key=lambda kv: kv[1][0])[:3]
        lines.append("| fit (cadquery, exact) | " + ("passes" if r.fit.ok else "**FAILS**") + "; closest: " +
                     ", ".join(f"{k} {v[0]:.2f} mm to {v[1]}" for k, v in worst) + " |")
    lines += ["", "| printed part | file | volume | mass (PLA) |", "|---|---|---|---|"]
    for part, (v_stl, _) in r.volumes.items():
        lines.append(f"| {part} | [{m}-{part}.stl]({m}-{part}.stl) | {v_stl / 1000:.1f} cm³ | "
                     f"{v_stl / 1000 * PLA_DENSITY:.0f} g |")
    lines += ["", f"CAD: [{m}-assembly.step]({m}-assembly.step) (base, lid, board stand-in, standoffs"
              f"{', pads, blocks, heatsink envelope and its screws' if c.get('heat_path') else ''}, "
              f"as mounted); parameters: [{m}.json]({m}.json), OpenSCAD: [{m}.scad]({m}.scad).", "",
              "Hardware:", ""]
    sp = dict(d["standard_parts"])
    sp["standoff"] = sp["standoff"].replace("hex standoff,", f"hex standoff, {c['standoff']:.0f} mm,")
    lines += [f"- {k}: {v}" for k, v in sp.items()]
    if hp:
        sc = hp["screw"]
        lines += [f"- heatsink screw: M3 x {sc['length']:g} pan head ISO 7045, A2, {len(hp['screws'])} per case, "
                  f"from inside the base (before the board) through the floor into M3 holes tapped "
                  f"{sc['tapped_depth']:g} mm deep in the heatsink's base"]
        for k, b in enumerate(hp["blocks"], 1):
            x0, y0, z0, x1, y1, z1 = b["box"]
            lines.append(f"- heat-path block {k}: EN AW-6060 flat bar {b['bar'][0]:g} × {b['bar'][1]:g} mm, "
                         f"sawn and faced to {x1 - x0:.2f} × {y1 - y0:.2f} × {z1 - z0:.2f} mm (± 0.05 mm on the height)")
        lines.append(f"- thermal putty pad: {hp['pad_t']} mm, {len(hp['pads'])} pieces cut to the blocks' top faces "
                     "(putty does not spring back: a new piece whenever the heatsink comes off)")
        lines += ["", "The heat path in section (heatsink, floor, blocks, pads, board):", "",
                  f"![{m} heat path in section]({m}-heat-path.png)"]
    return "\n".join(lines) + "\n"


def _heat_rows(hp: dict, d: dict, z: dict) -> list[str]:
    """The heat path's rows (heatpath.py): what carries the tabs' heat to the heatsink."""
    sc = hp["screw"]
    x0, y0, _, x1, y1, _ = hp["sink"]
    blocks = "; ".join(f"{'+'.join(b['tabs'])}: {b['box'][3] - b['box'][0]:.2f} × {b['box'][4] - b['box'][1]:.2f}"
                       f" × {b['box'][5] - b['box'][2]:.2f} mm" for b in hp["blocks"])
    return [
        f"| heat path | board bottom {z['board_bot']} mm above the case's underside: heatsink base on the "
        f"underside, greased aluminium block through the window ({blocks}), putty pad {hp['pad_t']} mm "
        f"compressed {hp['compression']:.1%} to {hp['pad_compressed']} mm (the stack's ± {hp['stack_tolerance']} mm "
        f"and the pad's ± {hp['pad_thickness_tol']:.0%}: "
        f"{hp['compression_range'][0]:.1%}–{hp['compression_range'][1]:.1%}) on the tabs' B.Cu islands; the pad "
        "is the insulator, block, sink and screws are on its far side |",
        f"| heatsink | {x1 - x0:g} × {y1 - y0:g} × {-hp['sink'][2]:g} mm envelope, base {hp['sink_base']:g} mm "
        f"(assumed), at x {x0:g}..{x1:g} mm (clear of the bus end's mounts), y {y0:g}..{y1:g} mm; "
        f"{len(hp['screws'])} × M3 × {sc['length']:g}: {sc['engagement']:g} mm of thread in its base "
        f"(≥ {sc['min_engagement']:g} mm asked, {sc['tapped_depth']:g} mm tapped) |",
    ]
