"""A schematic sheet (or a region of it) as a PNG, to look at a drawing or show it in a README.

    scripts/py -m r2ptools.kicad.sheet_png SCHEMATIC OUT.png [--page N] [--crop X0 Y0 X1 Y1] [--dpi D]

The sheet is plotted by KiCad itself (`kicad-cli sch export pdf`, the same plot as the fab
package's schematic PDF) and rasterised by poppler's pdftoppm; `--crop` takes millimetres on the
page (a block's frame: grid units × 2.54).
"""
from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path


def render(sch: Path, png: Path, page: int = 1, crop: tuple[float, float, float, float] | None = None,
           dpi: int = 100) -> None:
    if not sch.exists():
        raise FileNotFoundError(f"{sch}: no such schematic")
    if shutil.which("pdftoppm") is None:
        raise RuntimeError("pdftoppm not found: install poppler-utils (scripts/setup does)")
    with tempfile.TemporaryDirectory() as tmp:
        pdf = Path(tmp) / "sheet.pdf"
        p = subprocess.run(["kicad-cli", "sch", "export", "pdf", "--no-background-color",
                            "-o", str(pdf), sch.name], cwd=sch.parent, capture_output=True, text=True)
        if p.returncode != 0 or not pdf.exists():
            raise RuntimeError(f"kicad-cli could not plot {sch}:\n{p.stdout}{p.stderr}")
        cmd = ["pdftoppm", "-png", "-r", str(dpi), "-f", str(page), "-l", str(page), "-singlefile"]
        if crop:
            k = dpi / 25.4
            x0, y0, x1, y1 = crop
            cmd += ["-x", str(round(x0 * k)), "-y", str(round(y0 * k)),
                    "-W", str(round((x1 - x0) * k)), "-H", str(round((y1 - y0) * k))]
        out = Path(tmp) / "out"
        subprocess.run(cmd + [str(pdf), str(out)], check=True)
        png.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(out.with_suffix(".png"), png)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="sheet_png", description=__doc__.split("\n")[0])
    ap.add_argument("schematic", type=Path)
    ap.add_argument("png", type=Path)
    ap.add_argument("--page", type=int, default=1, help="page of the plot (1: root sheet)")
    ap.add_argument("--crop", type=float, nargs=4, metavar=("X0", "Y0", "X1", "Y1"),
                    help="region in mm from the page's top-left corner")
    ap.add_argument("--dpi", type=int, default=100)
    a = ap.parse_args(argv)
    try:
        render(a.schematic, a.png, a.page, tuple(a.crop) if a.crop else None, a.dpi)
    except (FileNotFoundError, RuntimeError) as e:
        print(f"sheet_png: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
