"""scripts/enclosures: make, and check, every module's case from its board.

    scripts/enclosures generate [MODULE ...] [--hardware DIR] [--out DIR] [--no-png]
    scripts/enclosures check    [MODULE ...] [--hardware DIR] [--out DIR]
    scripts/enclosures list     [--hardware DIR]

A module is a folder hardware/<m>/ holding <m>.kicad_pcb; its case goes to enclosures/<m>/.
Without MODULE: the modules that modules.toml marks `case = true`.
`generate` writes every file and prints the fit and the OpenSCAD/cadquery volume agreement;
`check` proves the committed files: fit, 2-manifold STLs, no overhang past 45 degrees, volumes
within 0.1 %. Both exit non-zero on any failure, naming the module and what failed.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from .. import ROOT
from . import board_facts, checks, generate, render


def boards(hardware: Path) -> dict[str, Path]:
    """module name -> its .kicad_pcb, for every hardware/<m>/<m>.kicad_pcb."""
    return {d.name: d / f"{d.name}.kicad_pcb" for d in sorted(hardware.iterdir())
            if (d / f"{d.name}.kicad_pcb").exists()} if hardware.is_dir() else {}


def modules(hardware: Path) -> dict[str, Path]:
    """The boards that get a case by default: those whose module the manifest beside
    `hardware` (modules.toml) marks `case = true`; every board where there is no manifest.
    A board still being designed (the motor's: `case = false`) is made only when named."""
    found = boards(hardware)
    if not (hardware.parent / "modules.toml").is_file():
        return found
    from .. import manifest
    cased = {m.name for m in manifest.load(hardware.parent, check_tree=False) if m.case}
    return {m: pcb for m, pcb in found.items() if m in cased}


def source_of(module: str) -> str:
    """The board's path as recorded in generated files: the same whichever checkout it is read from."""
    return f"hardware/{module}/{module}.kicad_pcb"


def _pick(ap: argparse.ArgumentParser, args) -> dict[str, Path]:
    if not args.module:
        return modules(args.hardware)
    found = boards(args.hardware)
    missing = [m for m in args.module if m not in found]
    if missing:
        ap.error(f"no board for {', '.join(missing)} in {args.hardware} "
                 f"(have: {', '.join(found) or 'none'}); a module needs hardware/<m>/<m>.kicad_pcb")
    return {m: found[m] for m in args.module}


def cmd_generate(ap, args) -> int:
    chosen = _pick(ap, args)
    if not chosen:
        print(f"enclosures: no boards in {args.hardware} (hardware/<m>/<m>.kicad_pcb): nothing to make")
        return 0
    failed = []
    rows = []
    for m, pcb in chosen.items():
        t = time.monotonic()
        try:
            r = generate.generate(pcb, source_of(m), args.out, png=not args.no_png)
        except (board_facts.BoardError, render.RenderError) as e:
            print(f"enclosures: {m}: {e}", file=sys.stderr)
            failed.append(m)
            continue
        total = time.monotonic() - t
        print(f"\n=== {m}: {r.out}")
        for k, v in r.seconds.items():
            print(f"  {k:<55} {v:6.1f} s")
        print(f"  {'total':<55} {total:6.1f} s")
        print("  fit:", "passes" if r.fit.ok else "FAILS")
        for f in r.fit.findings:
            print("   ", f)
        worst = min(r.fit.nearest.items(), key=lambda kv: kv[1][0])
        vol = []
        for part, (v_stl, v_cq) in r.volumes.items():
            rel = (v_stl - v_cq) / v_cq
            vol.append(f"{part} {v_stl:.0f}/{v_cq:.0f} mm³ ({rel * 100:+.4f} %)")
            if abs(rel) > checks.VOLUME_TOLERANCE:
                r.fit.findings.append(f"{part}: OpenSCAD and cadquery volumes differ by {rel * 100:.3f} %")
        if not r.fit.ok:
            failed.append(m)
        rows.append((m, worst, "; ".join(vol), total))
    print("\n=== enclosures")
    print(f"{'module':<11} {'closest (mm, part)':<24} {'volume STL/cadquery':<64} time")
    for m, worst, vol, total in rows:
        print(f"{m:<11} {worst[1][0]:<6.3f} {worst[0]:<17} {vol:<64} {total:.0f} s")
    if failed:
        print(f"enclosures: FAILED for {', '.join(failed)} (above)", file=sys.stderr)
        return 1
    return 0


def cmd_check(ap, args) -> int:
    chosen = _pick(ap, args)
    if not chosen:
        print(f"enclosures: no boards in {args.hardware} (hardware/<m>/<m>.kicad_pcb): nothing to check")
    bad = 0
    for m in chosen:
        problems = checks.all_problems(args.out / m, m)
        print(f"{m}: " + ("ok" if not problems else "FAILED"))
        for p in problems:
            print("   ", p)
        bad += bool(problems)
    return 1 if bad else 0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="enclosures", description=__doc__.split("\n")[0])
    ap.add_argument("--hardware", type=Path, default=ROOT / "hardware", help="folder of module boards")
    ap.add_argument("--out", type=Path, default=ROOT / "enclosures", help="where cases go")
    sub = ap.add_subparsers(dest="cmd", required=True)
    g = sub.add_parser("generate", help="make every file of each module's case")
    g.add_argument("module", nargs="*")
    g.add_argument("--no-png", action="store_true", help="skip the preview images")
    c = sub.add_parser("check", help="check the committed cases")
    c.add_argument("module", nargs="*")
    sub.add_parser("list", help="list the modules with boards")
    args = ap.parse_args(argv)
    if args.cmd == "generate":
        return cmd_generate(ap, args)
    if args.cmd == "check":
        return cmd_check(ap, args)
    for m, pcb in modules(args.hardware).items():
        print(f"{m:<12} {pcb}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
