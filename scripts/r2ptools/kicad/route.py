"""Signal routing with freerouting 2.4.1, cached so regeneration needs neither Java nor time.

The board with its fixed copper (power tracks and pours, locked) is exported as a Specctra DSN;
freerouting routes the remaining connections single-threaded (`-mt 1`, deterministic) and KiCad
imports its session (SES). The SES is committed beside the board as `route.ses`, with the
SHA-256 of the DSN it answers in `route.key`: while the routing problem is unchanged the
generator replays the SES (identical tracks, no Java), and any change to parts, placement, nets
or rules changes the DSN and so asks for a fresh route (`scripts/hwgen --route` to force one).
"""
from __future__ import annotations

import hashlib
import json
import os
import re
import shutil
import subprocess
import tempfile
from pathlib import Path

import pcbnew

from .. import ROOT

FREEROUTING_VERSION = "2.4.1"


class RoutingError(RuntimeError):
    pass


def freerouting_dir() -> Path:
    env = os.environ.get("FREEROUTING_DIR")
    candidates = [Path(env)] if env else []
    candidates.append(ROOT / ".tools" / f"freerouting-{FREEROUTING_VERSION}")
    for c in candidates:
        if (c / "lib").is_dir():
            return c
    raise RoutingError(
        "the routing problem changed and freerouting is not installed: run scripts/setup (needs a "
        "Java 25 JDK under /usr/lib/jvm) or set FREEROUTING_DIR to a freerouting-2.4.1 folder")


def java() -> str:
    d = freerouting_dir()
    home = (d / "java-home").read_text().strip() if (d / "java-home").exists() else ""
    for cand in ([Path(home) / "bin" / "java"] if home else []) + sorted(Path("/usr/lib/jvm").glob("*25*/bin/java")):
        if cand.exists():
            return str(cand)
    raise RoutingError("freerouting 2.4.1 needs Java 25: none found under /usr/lib/jvm")


def dsn_key(dsn: str) -> str:
    """SHA-256 of the routing problem; KiCad's first line names the (temporary) DSN file."""
    return hashlib.sha256(re.sub(r"\A\(pcb [^\n]*", "(pcb", dsn).encode()).hexdigest()


def run_freerouting(dsn: Path, ses: Path, passes: int = 20, log=print) -> None:
    with tempfile.TemporaryDirectory() as user:
        # freerouting writes its settings here; written first so telemetry is off from the start
        (Path(user) / "freerouting.json").write_text(json.dumps({
            "version": FREEROUTING_VERSION,
            "profile": {"id": "00000000-0000-0000-0000-000000000000", "email": "",
                        "allow_telemetry": False, "allow_contact": False},
            "gui": {"enabled": False},
            "usage_and_diagnostic_data": {"disable_analytics": True, "track_window_changed": False,
                                          "track_button_clicked": False},
            "feature_flags": {"multi_threading": False},
            "api_server": {"enabled": False}, "mcp_server": {"enabled": False},
            "logging": {"console": {"enabled": True, "level": "INFO"}, "file": {"enabled": False}},
        }, indent=2))
        cmd = [java(), "-cp", str(freerouting_dir() / "lib" / "*"), "app.freerouting.Freerouting",
               "-de", str(dsn), "-do", str(ses), "-mp", str(passes), "-mt", "1",
               "--gui.enabled=false", "--api_server.enabled=false",
               "--usage_and_diagnostic_data.disable_analytics=true", f"--user_data_path={user}",
               "--router.automatic_neckdown=false", "--router.fanout.enabled=false"]
        log(f"route: freerouting {dsn.name} (single-threaded, {passes} passes)")
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=1800)
        if p.returncode != 0 or not ses.exists():
            raise RoutingError(f"freerouting failed ({p.returncode}):\n{p.stdout[-3000:]}{p.stderr[-3000:]}")


def route(board: pcbnew.BOARD, ses_cache: Path, module, force: bool = False, passes: int = 20,
          log=print) -> bool:
    """Routes `board` in place; returns True if freerouting ran, False if the cache was replayed."""
    key_file = ses_cache.with_suffix(".key")
    with tempfile.TemporaryDirectory() as tmp:
        dsn = Path(tmp) / f"{module.name}.dsn"
        if not pcbnew.ExportSpecctraDSN(board, str(dsn)):
            raise RoutingError(f"{module.name}: KiCad could not export the DSN")
        key = dsn_key(dsn.read_text())
        fresh = force or not ses_cache.exists() or not key_file.exists() \
            or key_file.read_text().strip() != key
        if fresh:
            ses = Path(tmp) / f"{module.name}.ses"
            run_freerouting(dsn, ses, passes, log)
            shutil.copyfile(ses, ses_cache)
            key_file.write_text(key + "\n")
        pcbnew.KIID.SeedGenerator(module.seed * 1000 + 7)
        if not pcbnew.ImportSpecctraSES(board, str(ses_cache)):
            raise RoutingError(f"{module.name}: KiCad could not import {ses_cache}")
        return fresh


def unrouted(board: pcbnew.BOARD) -> int:
    """Connections still missing after the import (freerouting can give up on a few)."""
    board.BuildConnectivity()
    return board.GetConnectivity().GetUnconnectedCount(True)
