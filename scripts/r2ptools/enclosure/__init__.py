"""Printable cases for R2P modules, made from their KiCad boards (issue 8, docs/enclosures.md).

    board_facts.py  .kicad_pcb -> board facts (pcbnew): outline, holes, parts, heights, edges
    heights.py      where a part's height comes from (field, name, table)
    case_rules.py   the case's design rules and standard hardware
    layout.py       board facts + rules -> case parameters (bosses, standoffs, notches, stand-in)
    lidplan.py      the lid's light-pipe and pin holes, LED windows, vents and name
    textfit.py      the name's extents (cadquery's font engine), for placing it
    params.py       the parameters as <m>.json and board.scad
    render.py       OpenSCAD: STL per printed part, preview PNG (library: enclosures/lib/r2p_case.scad)
    solid.py        cadquery: the same case as exact solids, board stand-in, STEP assembly
    fit.py          exact fit check on the solids
    mesh.py         STL canonical form, 2-manifold and overhang checks
    checks.py       everything a committed case must pass
    generate.py     one module end to end (and its README);  __main__.py: scripts/enclosures
"""
from pathlib import Path

from .. import ROOT

ROOT_LIB = ROOT / "enclosures" / "lib" / "r2p_case.scad"
