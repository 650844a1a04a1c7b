"""The fab-related commands answer a wrong argument with what is wrong, where, and what to do,
never with a Python traceback (docs/hardware.md)."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from r2ptools.kicad import check, fab, generate

ROOT = Path(__file__).resolve().parents[1]


def test_check_names_a_folder_that_is_not_a_board(tmp_path, capsys):
    assert check.main([str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert f"{tmp_path} is not a board folder" in err and "hardware/psu" in err
    assert "Traceback" not in err


def test_fab_names_an_unknown_board_and_the_known_ones(capsys):
    assert fab.main(["nosuch"]) == 2
    err = capsys.readouterr().err
    assert "nosuch is not one of the boards" in err and "psu" in err


def test_hwgen_reports_an_unwritable_output_folder(capsys):
    assert generate.main(["template", "--out", "/proc/r2p-no-such-dir"]) == 1
    err = capsys.readouterr().err
    assert "cannot write" in err and "--out" in err


def test_assembly_cost_run_directly_says_which_command_writes_the_table():
    p = subprocess.run([sys.executable, "-m", "r2ptools.assembly_cost"], capture_output=True,
                       text=True, cwd=ROOT / "scripts")
    assert p.returncode == 2 and "scripts/bom generate" in p.stderr and "Traceback" not in p.stderr
