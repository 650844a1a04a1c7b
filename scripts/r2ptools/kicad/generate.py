"""`scripts/hwgen`: regenerate KiCad projects from their descriptions.

    scripts/hwgen [MODULE…] [--out DIR] [--route]

For each module (default: all of `modules.MODULES`) it writes, under DIR (default hardware/):
    <module>/<module>.kicad_sch, .kicad_pcb, .kicad_pro, .kicad_dru, sym-lib-table, fp-lib-table
    <module>/route.ses       freerouting's result, the cache of the autorouted signal tracks
    core/R2P.pretty/         the project footprint variants with trimmed silkscreen (fplib.py)
    core/core.kicad_sch      the shared core sheet
Steps: schematic (label per pin) → KiCad netlist → placed board with power copper → signal
routing (replayed from route.ses when the routing problem is unchanged; --route, or a changed
problem, runs freerouting, which needs Java 25) → zone fill → trimmed footprint silk (fplib.py) →
silkscreen layout (silk.py) → save.
Same description, same bytes.
"""
from __future__ import annotations

import argparse
import subprocess
import sys
import time
from pathlib import Path

from .. import ROOT
from . import board as board_mod
from . import fabcap, fplib, libtables, netlist, route, sch_gen, silk
from .modules import MODULES, build_all, core
from .design import Module

HARDWARE = ROOT / "hardware"
ROUTE_PASSES = (20, 40, 60)
"""freerouting's pass limit for a fresh route, raised when a run leaves connections unrouted."""


def power_classes(m: Module) -> dict[str, list[str]]:
    nets = set()
    for _, p in m.all_parts():
        nets.update(n for n in p.nets.values() if n)
    # 0.4 mm for the 5 V rails; +3V3 and GND stay 0.2 mm so they can enter 0.5 mm-pitch pins
    # (the pours widen GND afterwards, and +3V3 carries at most the LDO's 600 mA)
    power = sorted(n for n in nets if n.startswith("+5V"))
    extra = {k: v for k, v in m.netclasses.items() if k != "Power"}
    return {"Power": sorted(set(power) | set(m.netclasses.get("Power", []))), **extra}


def generate(m: Module, modules: list[Module], out: Path, force_route: bool = False,
             log=print) -> dict[str, float]:
    times = {}
    t0 = time.monotonic()
    sch_gen.write_core(modules[0].root.children[0].sheet if modules[0].root.children else core.build(),
                       modules, out)
    sch = sch_gen.write_module(m, out)
    folder = sch.parent
    symbols = {p.item.symbol.split(":")[0] for _, p in m.all_parts()} | {"power"}
    footprints = {p.item.footprint.split(":")[0] for _, p in m.all_parts()} | \
        {board_mod.HOLE_FP[0], board_mod.FIDUCIAL_FP[0]}
    libtables.write(folder, sorted(symbols), sorted(footprints))
    times["schematic"] = time.monotonic() - t0

    t0 = time.monotonic()
    net = netlist.export(sch)
    b = board_mod.build(m, net)
    classes = {c: sorted(net.resolve(n) for n in names) for c, names in power_classes(m).items()}
    fabcap.assign(b, classes)
    pcb = folder / f"{m.name}.kicad_pcb"
    board_mod.save(b, pcb, classes, m.dru_rules)
    times["board"] = time.monotonic() - t0

    t0 = time.monotonic()
    for attempt, passes in enumerate(ROUTE_PASSES):
        b = board_mod.load(pcb)
        routed = route.route(b, folder / "route.ses", m, force=force_route or attempt > 0,
                             passes=passes, log=log)
        board_mod.ground_pours(b)
        board_mod.fill(b)
        missing = route.unrouted(b)          # counted with every pour filled
        if not missing:
            break
        if not routed:
            raise route.RoutingError(f"{m.name}: route.ses leaves {missing} connections unrouted: "
                                     "rerun with --route")
        log(f"route: {m.name}: {missing} connections left unrouted after {passes} passes")
    else:
        board_mod.save(b, pcb, classes, m.dru_rules)     # kept for inspection: `scripts/py -m r2ptools.kicad.check`
        raise route.RoutingError(f"{m.name}: freerouting left {missing} connections unrouted "
                                 f"after {ROUTE_PASSES[-1]} passes: loosen the placement")
    # trimmed silk for the routed board (fplib.py)
    fplib.apply(b, {r: c.footprint for r, c in net.components.items()}, fplib.build(out))
    log(f"{m.name}: " + silk.layout(b).summary())
    board_mod.save(b, pcb, classes, m.dru_rules)
    times["route" if routed else "route (replayed)"] = time.monotonic() - t0
    return times


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="scripts/hwgen", description=__doc__.split("\n")[0])
    ap.add_argument("modules", nargs="*", help=f"modules to generate (default: all: {', '.join(MODULES)})")
    ap.add_argument("--out", type=Path, default=HARDWARE, help="hardware folder to write (default hardware/)")
    ap.add_argument("--route", action="store_true", help="run freerouting even if route.ses is current")
    args = ap.parse_args(argv)
    names = args.modules or list(MODULES)
    unknown = [n for n in names if n not in MODULES]
    if unknown:
        print(f"hwgen: unknown module(s) {', '.join(unknown)}; known: {', '.join(MODULES)}",
              file=sys.stderr)
        return 2
    try:                                     # before minutes of building: is --out usable?
        args.out.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        print(f"hwgen: cannot write {e.filename or args.out}: {e.strerror}; pass a writable "
              "folder with --out", file=sys.stderr)
        return 1
    if len(names) > 1:
        # one fresh process per module: pcbnew's footprint-library cache draws on the seeded
        # UUID generator, so a module built after another in the same process would get other
        # UUIDs (and another footprint order, DSN and route key) than one built alone
        for n in names:
            cmd = [sys.executable, "-m", "r2ptools.kicad.generate", n, "--out", str(args.out.resolve())]
            if subprocess.run(cmd + (["--route"] if args.route else []),
                              cwd=Path(__file__).resolve().parents[2]).returncode:
                return 1
        return 0
    modules = build_all()
    by_name = {m.name: m for m in modules}
    for n in names:
        try:
            t = generate(by_name[n], modules, args.out, force_route=args.route)
        except route.RoutingError as e:          # the message says what to do
            print(f"hwgen: {n}: {e}", file=sys.stderr)
            return 1
        except OSError as e:
            print(f"hwgen: {n}: cannot write {e.filename or args.out}: {e.strerror}; pass a "
                  "writable folder with --out", file=sys.stderr)
            return 1
        print(f"hwgen: {n}: " + ", ".join(f"{k} {v:.1f} s" for k, v in t.items()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
