"""Runs OpenSCAD 2021.01 for the printed parts (binary STL, then canonical) and the preview PNG.

OpenSCAD runs with address randomisation off (`setarch <arch> -R`), the PNG under a virtual X
server (`xvfb-run -a`, software GL: the image is byte-identical run to run, measured). Any
OpenSCAD warning is an error: a missing font or a parameter typo would otherwise pass silently.
"""
from __future__ import annotations

import platform
import shutil
import subprocess
from pathlib import Path

PREVIEW_ARGS = ["--imgsize=1200,900", "--viewall", "--autocenter", "--camera=0,0,0,55,0,25,0",
                "--colorscheme=Tomorrow"]


class RenderError(RuntimeError):
    pass


def _tool(name: str, hint: str) -> str:
    path = shutil.which(name)
    if not path:
        raise RenderError(f"{name} not found: {hint}")
    return path


def start(top: Path, part: str, out: Path, png: bool = False) -> subprocess.Popen:
    """Starts OpenSCAD on `top` (a module's <m>.scad) for `part`; `finish` waits for it."""
    cmd = ["setarch", platform.machine(), "-R",
           _tool("openscad", "install it with scripts/setup (Debian package openscad)"),
           "-D", f'part="{part}"']
    if png:
        cmd = [_tool("xvfb-run", "install xvfb with scripts/setup"), "-a", *cmd, *PREVIEW_ARGS]
    else:
        cmd += ["--export-format", "binstl"]
    cmd += ["-o", str(out), str(top)]
    return subprocess.Popen(cmd, cwd=top.parent, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)


def finish(p: subprocess.Popen, what: str) -> str:
    out, _ = p.communicate()
    warnings = [ln for ln in out.splitlines() if ln.startswith(("WARNING", "ERROR"))]
    if p.returncode != 0 or warnings:
        raise RenderError(f"openscad failed on {what} (exit {p.returncode}):\n" +
                          "\n".join(warnings or out.splitlines()[-15:]))
    return out


def preview(top: Path, out: Path) -> None:
    finish(start(top, "preview", out, png=True), f"{top.name} preview")
