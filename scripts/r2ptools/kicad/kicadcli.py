"""kicad-cli for the fab package, with a clean user configuration.

kicad-cli reads the user's KiCad settings (~/.config/kicad/9.0): a colour theme or 3D-viewer
setting saved by KiCad's GUI, or by a tool that drives it (KiBot's render step writes a colour
theme there), changes the renders' pixels. The package must not depend on who runs it, so every
call gets a fresh, empty configuration folder (KICAD_CONFIG_HOME), i.e. KiCad's defaults.
"""
from __future__ import annotations

import os
import subprocess
import tempfile


def run(*args: str, env: dict[str, str] | None = None) -> None:
    with tempfile.TemporaryDirectory(prefix="kicad-config-") as config:
        full = dict(os.environ, **(env or {}), KICAD_CONFIG_HOME=config)
        p = subprocess.run(["kicad-cli", *args], capture_output=True, text=True, env=full)
    if p.returncode != 0:
        raise RuntimeError(f"kicad-cli {' '.join(args)} failed:\n{p.stdout}{p.stderr}")
