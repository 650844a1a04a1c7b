"""The interactive HTML BOM of a fab package (InteractiveHtmlBom, pinned in requirements.in).

One self-contained HTML file: both sides of the board, each BOM line highlighting its parts,
pin 1 marked on every part, with the LCSC and MPN columns, for whoever assembles or inspects the
board by hand. InteractiveHtmlBom stamps the board file's modification time into the page when
the title block has no date (ours have none): it is run on a copy whose time is pinned, so the
page is byte for byte the same on every run and every checkout. The board data is written as
plain JSON (`--no-compression`): git compresses it better than InteractiveHtmlBom's LZString
(204 KB against 298 KB gzipped for psu), its diffs are readable, and the tests can read it.
"""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

PINNED_MTIME = 315532800
"""1980-01-01 00:00:00 UTC, the date the zip and PDFs of a package carry too."""


def interactive_bom(pcb: Path, dest: Path) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        copy = Path(tmp) / pcb.name
        shutil.copyfile(pcb, copy)
        os.utime(copy, (PINNED_MTIME, PINNED_MTIME))
        env = dict(os.environ, INTERACTIVE_HTML_BOM_NO_DISPLAY="1", TZ="UTC")
        cmd = [sys.executable, "-m", "InteractiveHtmlBom.generate_interactive_bom",
               "--no-browser", "--dest-dir", tmp, "--name-format", "ibom",
               "--highlight-pin1", "all", "--extra-fields", "LCSC,MPN,Manufacturer",
               "--include-nets", "--include-tracks", "--dark-mode", "--no-compression", str(copy)]
        p = subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=tmp)
        out = Path(tmp) / "ibom.html"
        if p.returncode != 0 or not out.exists():
            raise RuntimeError(f"InteractiveHtmlBom failed on {pcb}:\n{p.stdout}{p.stderr}")
        shutil.copyfile(out, dest)
