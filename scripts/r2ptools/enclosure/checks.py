"""Everything a committed case must satisfy, as one list of problems (empty: it passes).

Used by `scripts/enclosures check` and tests/test_enclosures.py: the fit (fit.py), every STL a
2-manifold with nothing overhanging past 45 degrees in its print orientation, and the OpenSCAD
parts within 0.1 % of the cadquery solids' volumes.
"""
from __future__ import annotations

from pathlib import Path

from . import fit, generate, mesh, params, solid

VOLUME_TOLERANCE = 0.001


def all_problems(out: Path, module: str) -> list[str]:
    missing = [f for f in generate.files(module) if not (out / f).exists()]
    if not missing and generate.has_heat_path(out, module):
        missing = [f for f in generate.files(module, heat_path=True) if not (out / f).exists()]
    if missing:
        return [f"{out}: missing {', '.join(missing)}: run scripts/enclosures generate {module}"]
    K = solid.Case(solid.Params(params.read_json(out / f"{module}.json")))
    problems = [str(f) for f in fit.check(K).findings]
    for part, shape in (("base", K.base), ("lid", K.lid)):
        stl = out / f"{module}-{part}.stl"
        problems += [f"{stl.name}: {p}" for p in mesh.manifold_problems(stl)]
        o = mesh.overhangs(stl)
        if o.facets:
            problems.append(f"{stl.name}: {o.area:.1f} mm² in {o.facets} facets overhang past 45° "
                            f"(off the bed) within {o.box}")
        v_stl, v_cq = mesh.volume(stl), shape.val().Volume()
        if abs(v_stl - v_cq) > VOLUME_TOLERANCE * v_cq:
            problems.append(f"{stl.name}: volume {v_stl:.1f} mm³ vs cadquery {v_cq:.1f} mm³ "
                            f"({(v_stl - v_cq) / v_cq * 100:+.3f} %, limit 0.1 %)")
    return problems
