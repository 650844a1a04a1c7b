"""Are two schematics the same circuit? Their KiCad netlists compared net by net, pin by pin.

    scripts/py -m r2ptools.kicad.netcompare A.kicad_sch B.kicad_sch

Used to prove that a redrawn sheet is the circuit it replaces: every net (by name) joins the
same pins, and every component has the same value, footprint and symbol path (so the board
stays in parity). Exit status 1 and one line per difference otherwise.
"""
from __future__ import annotations

import sys
from pathlib import Path

from . import netlist


def differences(a: netlist.Netlist, b: netlist.Netlist) -> list[str]:
    out = []
    na = {k: sorted(v) for k, v in a.nets.items()}
    nb = {k: sorted(v) for k, v in b.nets.items()}
    for k in sorted(set(na) | set(nb)):
        if na.get(k) != nb.get(k):
            out.append(f"net {k}: {na.get(k)} != {nb.get(k)}")
    ca = {r: (c.value, c.footprint, c.path) for r, c in a.components.items()}
    cb = {r: (c.value, c.footprint, c.path) for r, c in b.components.items()}
    for r in sorted(set(ca) | set(cb)):
        if ca.get(r) != cb.get(r):
            out.append(f"component {r}: {ca.get(r)} != {cb.get(r)}")
    return out


def main(argv: list[str] | None = None) -> int:
    args = argv if argv is not None else sys.argv[1:]
    if len(args) != 2:
        print("usage: netcompare A.kicad_sch B.kicad_sch", file=sys.stderr)
        return 2
    missing = [x for x in args if not Path(x).is_file()]
    if missing:
        print(f"netcompare: no schematic {', '.join(missing)}: give two .kicad_sch files "
              "(e.g. hardware/psu/psu.kicad_sch)", file=sys.stderr)
        return 2
    a, b = (netlist.export(Path(x)) for x in args)
    diffs = differences(a, b)
    for d in diffs:
        print(d)
    print(f"{len(a.nets)} and {len(b.nets)} nets, {len(diffs)} differences")
    return 1 if diffs else 0


if __name__ == "__main__":
    sys.exit(main())
