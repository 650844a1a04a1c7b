"""One module's case, from its board to every committed file, and the fit that proves it.

    enclosures/<m>/<m>.json        parameters: design rules, board facts, case layout
    enclosures/<m>/board.scad      the same numbers for OpenSCAD
    enclosures/<m>/<m>.scad        top file: include the library and the numbers, pick a part
    enclosures/<m>/<m>-base.stl    printed parts, print orientation (OpenSCAD, facets sorted)
    enclosures/<m>/<m>-lid.stl
    enclosures/<m>/<m>-assembly.step   base, lid, board stand-in, standoffs (cadquery)
    enclosures/<m>/<m>.png         exploded preview (OpenSCAD)
    enclosures/<m>/README.md       sizes, clearances, hardware, print settings
"""
from __future__ import annotations

import shutil
import time
from dataclasses import dataclass, field
from pathlib import Path

from . import ROOT_LIB, board_facts, fit, layout, mesh, params, render, solid
from .case_rules import DESIGN, Design

PLA_DENSITY = 1.24   # g/cm^3, for the README's mass estimate (PETG: 1.27)


@dataclass
class Result:
    module: str
    out: Path
    seconds: dict[str, float] = field(default_factory=dict)
    fit: fit.Report | None = None
    volumes: dict[str, tuple[float, float]] = field(default_factory=dict)   # part: (stl, cadquery)


def files(module: str) -> list[str]:
    return [f"{module}.json", "board.scad", f"{module}.scad", f"{module}-base.stl", f"{module}-lid.stl",
            f"{module}-assembly.step", f"{module}.png", "README.md"]


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
                     "power packages (their tabs on thermal vias): a heatsink with an insulating gap pad "
                     "presses against the board's bottom from outside |")
    if r.fit:
        worst = sorted(r.fit.nearest.items(), key=lambda kv: kv[1][0])[:3]
        lines.append("| fit (cadquery, exact) | " + ("passes" if r.fit.ok else "**FAILS**") + "; closest: " +
                     ", ".join(f"{k} {v[0]:.2f} mm to {v[1]}" for k, v in worst) + " |")
    lines += ["", "| printed part | file | volume | mass (PLA) |", "|---|---|---|---|"]
    for part, (v_stl, _) in r.volumes.items():
        lines.append(f"| {part} | [{m}-{part}.stl]({m}-{part}.stl) | {v_stl / 1000:.1f} cm³ | "
                     f"{v_stl / 1000 * PLA_DENSITY:.0f} g |")
    lines += ["", f"CAD: [{m}-assembly.step]({m}-assembly.step) (base, lid, board stand-in, standoffs, "
              f"as mounted); parameters: [{m}.json]({m}.json), OpenSCAD: [{m}.scad]({m}.scad).", "",
              "Hardware:", ""]
    sp = dict(d["standard_parts"])
    sp["standoff"] = sp["standoff"].replace("hex standoff,", f"hex standoff, {c['standoff']:.0f} mm,")
    lines += [f"- {k}: {v}" for k, v in sp.items()]
    return "\n".join(lines) + "\n"
