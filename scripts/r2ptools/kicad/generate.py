"""`scripts/hwgen`: scaffold a new board's KiCad project from its description, once.

    scripts/hwgen [MODULE…] [--out DIR] [--route] [--force] [--core]

The KiCad files under hardware/ are the hardware's source: a person edits them in KiCad 9 and
the checks read them (docs/hardware.md, "Changing a board"). This tool writes the first version
of a new board from a Python description (`hardware/<module>/<module>.py`, its drawing in
`<module>_sheet.py`; psu's still in `modules/`) and then steps aside: a board that already has its `.kicad_sch` is refused,
unless `--force` (which overwrites it and every edit made in KiCad since; meant for a board
still being scaffolded). For each module (default: every description without a board yet) it
writes, under DIR (default hardware/):
    <module>/<module>.kicad_sch, .kicad_pcb, .kicad_pro, .kicad_dru, sym-lib-table, fp-lib-table
    <module>/route.ses       freerouting's result, the cache of the autorouted signal tracks
    core/R2P.pretty/         project footprint variants with trimmed silkscreen (fplib.py; new
                             variants only: the existing ones are the boards')
and records the new board in the shared core sheet (core/core.kicad_sch keeps each project's
references), leaving the sheet's drawing alone; `--core` rewrites the core sheet from
`modules/core.py` instead (every project's references kept).
Steps: drawn schematic → KiCad netlist → placed board with power copper → signal routing
(replayed from route.ses when the routing problem is unchanged; --route, or a changed problem,
runs freerouting, which needs Java 25) → zone fill → trimmed footprint silk → silkscreen layout
(silk.py) → save. Same description, same bytes.
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


def generate(m: Module, out: Path, force_route: bool = False, rewrite_core: bool = False,
             log=print) -> dict[str, float]:
    times = {}
    t0 = time.monotonic()
    core_sch = out / "core" / "core.kicad_sch"
    if rewrite_core or not core_sch.exists():
        projects = sch_gen.core_projects(core_sch) if core_sch.exists() else []
        sch_gen.write_core(core.build(), [m], out, projects=projects)
    elif any(u.sheet.name == "core" for u in m.root.children):
        sch_gen.add_project(core_sch, m.name)     # a board without the core sheet (the gateway) is not recorded
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
    ap.add_argument("modules", nargs="*",
                    help=f"modules to scaffold (default: every description without a board; "
                         f"descriptions: {', '.join(MODULES)})")
    ap.add_argument("--out", type=Path, default=HARDWARE, help="hardware folder to write (default hardware/)")
    ap.add_argument("--route", action="store_true", help="run freerouting even if route.ses is current")
    ap.add_argument("--force", action="store_true",
                    help="overwrite an existing board from its description (its KiCad edits are lost)")
    ap.add_argument("--core", action="store_true",
                    help="rewrite the shared core sheet from modules/core.py (keeps every project)")
    args = ap.parse_args(argv)
    unknown = [n for n in args.modules if n not in MODULES]
    if unknown:
        print(f"hwgen: no description for {', '.join(unknown)} (hardware/<module>/<module>.py, listed in modules.toml); "
              f"known: {', '.join(MODULES)}. A board without one is edited in KiCad (docs/hardware.md).",
              file=sys.stderr)
        return 2
    exists = [n for n in (args.modules or MODULES) if (args.out / n / f"{n}.kicad_sch").exists()]
    names = args.modules or [n for n in MODULES if n not in exists]
    if not names:
        print("hwgen: nothing to scaffold: every description already has its board under "
              f"{args.out} (edit those in KiCad; --force regenerates one from its description)")
        return 0
    try:                                     # before minutes of building: is --out usable?
        args.out.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        print(f"hwgen: cannot write {e.filename or args.out}: {e.strerror}; pass a writable "
              "folder with --out", file=sys.stderr)
        return 1
    refused = [n for n in names if n in exists]
    if refused and not args.force:
        print(f"hwgen: {', '.join(str(args.out / n) for n in refused)}: the board exists and its KiCad files "
              "are the source now (edit them in KiCad 9, docs/hardware.md). --force overwrites them "
              "from the description, losing every edit made in KiCad.", file=sys.stderr)
        return 2
    if len(names) > 1:
        # one fresh process per module: pcbnew's footprint-library cache draws on the seeded
        # UUID generator, so a module built after another in the same process would get other
        # UUIDs (and another footprint order, DSN and route key) than one built alone
        flags = [f for f, on in (("--route", args.route), ("--force", args.force), ("--core", args.core)) if on]
        for n in names:
            cmd = [sys.executable, "-m", "r2ptools.kicad.generate", n, "--out", str(args.out.resolve())]
            if subprocess.run(cmd + flags, cwd=Path(__file__).resolve().parents[2]).returncode:
                return 1
        return 0
    modules = build_all()
    by_name = {m.name: m for m in modules}
    for n in names:
        try:
            t = generate(by_name[n], args.out, force_route=args.route, rewrite_core=args.core)
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
