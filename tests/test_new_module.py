"""`scripts/new-module`: a new module, scaffolded in a copy of the repository, passes the module
checks with no edit; the files it writes are docs/adding-a-module.md's list; bad names are refused."""
from __future__ import annotations

import hashlib
import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest

from conftest import ROOT, run
from r2ptools import manifest, newmodule
from r2ptools.kicad import check, sch_gen

NAME = "servo"
SKIP = {".git", ".venv", "target", ".cache", ".setup", "__pycache__", ".pytest_cache"}


def copy_repo(dst: Path) -> Path:
    """The working tree as git sees it (tracked and untracked, not ignored), without build dirs."""
    files = subprocess.run(["git", "ls-files", "-z", "--cached", "--others", "--exclude-standard"],
                           cwd=ROOT, capture_output=True, check=True).stdout.decode().split("\0")
    for f in filter(None, files):
        src = ROOT / f
        if src.is_file() or src.is_symlink():
            (dst / f).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(src, dst / f, follow_symlinks=False)
    (dst / ".venv").symlink_to(ROOT / ".venv")
    return dst


def snapshot(root: Path) -> dict[str, str]:
    out = {}
    for dirpath, dirs, files in os.walk(root):
        dirs[:] = [d for d in dirs if d not in SKIP]
        for f in files:
            p = Path(dirpath) / f
            if not p.is_symlink():
                out[str(p.relative_to(root))] = hashlib.sha256(p.read_bytes()).hexdigest()
    return out


def documented(name: str) -> list[str]:
    doc = (ROOT / "docs" / "adding-a-module.md").read_text()
    block = re.search(r"<!-- new-module files: begin -->\n(.*?)<!-- new-module files: end -->", doc, re.S)
    assert block, "docs/adding-a-module.md lost its list of the scaffold's files"
    return [m.replace("NAME", name) for m in re.findall(r"^- `([^`]+)`$", block.group(1), re.M)]


def changed(before: dict[str, str], after: dict[str, str], listed: list[str]) -> set[str]:
    """Each file that is new or changed, as the entry of `listed` that covers it (a folder entry
    ends in /), or as itself when none does."""
    out = set()
    for f in sorted(set(after) - set(before) | {f for f in before if after.get(f) != before[f]}):
        out.add(next((e for e in listed if f == e or (e.endswith("/") and f.startswith(e))), f))
    return out


WORK = ROOT / ".cache" / "new-module"
"""Where the copy goes: always the same folder, so that cargo's target dir beside it stays valid
across runs (a test binary keeps the CARGO_MANIFEST_DIR it was built with, and cargo does not
rebuild it when only the checkout's path changes)."""


@pytest.fixture(scope="module")
def scaffolded():
    repo = WORK / "repo"
    if repo.exists():
        shutil.rmtree(repo)
    repo.mkdir(parents=True)
    copy_repo(repo)
    before = snapshot(repo)
    p = run([str(repo / "scripts" / "new-module"), NAME], cwd=repo)
    assert p.returncode == 0, p.stdout
    return repo, before, snapshot(repo)


def test_it_writes_exactly_the_documented_files(scaffolded):
    repo, before, after = scaffolded
    listed = documented(NAME)
    assert listed == newmodule.written(NAME)
    assert changed(before, after, listed) == set(listed)


def test_every_reader_of_the_manifest_sees_the_new_module(scaffolded):
    repo, _, _ = scaffolded
    m = {m.name: m for m in manifest.load(repo)}[NAME]
    assert (m.board_file, m.app, m.emulator, m.case, m.fab) == (
        f"firmware/boards/{NAME}.toml", f"firmware/apps/{NAME}", "template", True, False)
    # make's summary, the images, make fab: each reads the copy's manifest in its own process.
    probe = ("from r2ptools import build, firmware; from r2ptools.kicad import fab; "
             "print(sorted(build.module_images()), [i.name for i in firmware.manifest()], fab.FAB_BOARDS)")
    out = run([str(repo / "scripts" / "py"), "-c", probe], cwd=repo).stdout
    fab_boards = [m.name for m in manifest.load(repo) if m.fab]   # not the new module: no board yet
    assert NAME not in fab_boards
    assert out.count(f"'{NAME}'") == 2 and out.rstrip().endswith(str(fab_boards)), out


def test_the_board_passes_its_checks_and_the_pins_agree(scaffolded):
    repo, _, _ = scaffolded
    r = check.check(repo / "hardware" / NAME)
    assert r.problems == [], r.problems
    assert NAME in sch_gen.core_projects(repo / "hardware" / "core" / "core.kicad_sch")
    p = run([str(repo / "scripts" / "check-pins"), NAME], cwd=repo)
    assert p.returncode == 0 and f"{NAME}: ok" in p.stdout, p.stdout
    p = run([str(repo / "scripts" / "bom"), "check"], cwd=repo)
    assert p.returncode == 0, p.stdout


def test_the_application_tests_and_the_image_build(scaffolded):
    repo, _, _ = scaffolded
    # Reuse the repository's compiled dependencies (the copy's own crates are rebuilt).
    env = {"CARGO_TARGET_DIR": str(WORK / "target")}
    p = run(["cargo", "test", "--offline", "-p", f"r2p-app-{NAME}", "-p", "r2p-boardgen",
             "-p", "r2p-world", "--test", "manifest", "--lib"], cwd=repo / "firmware", env=env)
    assert p.returncode == 0, p.stdout[-3000:]
    assert p.stdout.count("test result: ok") >= 3, p.stdout[-3000:]
    cache = ROOT / "firmware" / "targets" / "f103" / "target" / "reproducible"
    if cache.is_dir():
        (repo / "firmware" / "targets" / "f103" / "target").mkdir(parents=True)
        subprocess.run(["cp", "-a", "--reflink=auto", str(cache), str(repo / "firmware" / "targets" / "f103" / "target")],
                       check=True)
    p = run([str(repo / "scripts" / "firmware"), "build", NAME], cwd=repo)
    assert p.returncode == 0, p.stdout[-3000:]
    assert re.search(rf"^{NAME} .* ok$", p.stdout, re.M), p.stdout[-2000:]
    assert (repo / "firmware" / "images" / f"{NAME}.bin").stat().st_size > 30_000


def test_its_case_generates_and_fits(scaffolded):
    # `case = true`: make's enclosure stage makes it from the board.
    repo, _, _ = scaffolded
    p = run([str(repo / "scripts" / "enclosures"), "generate", NAME], cwd=repo)
    assert p.returncode == 0, p.stdout[-2000:]
    assert (repo / "enclosures" / NAME / f"{NAME}-assembly.step").is_file()
    p = run([str(repo / "scripts" / "enclosures"), "check", NAME], cwd=repo)
    assert p.returncode == 0, p.stdout[-2000:]


@pytest.mark.parametrize("name, says", [
    ("psu", "module 'psu' exists (modules.toml)"),
    ("template", "module 'template' exists"),
    ("Servo", "is not a module name"),
    ("2nd", "is not a module name"),
    ("core", "taken by shared code"),
])
def test_an_existing_or_invalid_name_is_refused_and_nothing_written(tmp_path, name, says):
    repo = tmp_path
    for f in ("modules.toml",):
        shutil.copy2(ROOT / f, repo / f)
    for d in ("hardware", "firmware"):
        (repo / d).symlink_to(ROOT / d)
    before = snapshot(repo)
    p = run([str(ROOT / "scripts" / "new-module"), name, "--root", str(repo)])
    assert p.returncode == 1 and f"new-module: " in p.stdout and says in p.stdout, p.stdout
    assert snapshot(repo) == before
