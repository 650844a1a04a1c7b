"""KiCad's 3D models for the renders, only the ones our boards use, from Debian's package.

    scripts/py -m r2ptools.kicad.models3d      (extracts what hardware/*/*.kicad_pcb reference)

Debian's kicad-packages3d 9.0.8 (bookworm-backports) is a 332 MB download that installs 4.7 GB;
our boards reference ~25 models (2.7 MB). scripts/setup downloads the .deb once (apt checks it
against the archive's signed index) into .tools/kicad-packages3d-<version>/ with a listing of
its contents; this module extracts the models the boards name into models/ there, on demand, so
a new board's models arrive on its first `scripts/fab` without a network. The renders point
KICAD9_3DMODEL_DIR at that folder. Models KiCad does not ship (our own connector footprints, a
few switch and package footprints) render as bare pads: `missing()` names them.
"""
from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

from .. import ROOT

KICAD_VERSION = "9.0.8"
CACHE = ROOT / ".tools" / f"kicad-packages3d-{KICAD_VERSION}"
MODELS = CACHE / "models"
PREFIX = "./usr/share/kicad/3dmodels/"
_MODEL = re.compile(r'\(model "\$\{KICAD9_3DMODEL_DIR\}/([^"]+)"')


def referenced(pcbs: list[Path]) -> list[str]:
    """Model paths (relative to KiCad's 3D model folder) that the boards' footprints name."""
    return sorted({m for pcb in pcbs for m in _MODEL.findall(pcb.read_text())})


def _deb() -> Path | None:
    debs = sorted(CACHE.glob(f"kicad-packages3d_{KICAD_VERSION}*.deb"))
    return debs[-1] if debs else None


def shipped() -> set[str]:
    listing = CACHE / "contents.txt"
    if not listing.exists():
        return set()
    return {line[len(PREFIX):] for line in listing.read_text().splitlines() if line.startswith(PREFIX)}


def missing(models: list[str]) -> list[str]:
    """Models the boards name that KiCad's package does not have."""
    have = shipped()
    return [m for m in models if m not in have]


def ensure(pcbs: list[Path]) -> Path:
    """The model folder with every shipped model the boards reference, extracting what is
    missing from the cached .deb. Raises with what to do if the cache is not there."""
    want = referenced(pcbs)
    deb = _deb()
    if deb is None or not (CACHE / "contents.txt").exists():
        raise RuntimeError(f"no KiCad 3D model package in {CACHE}: run scripts/setup (its "
                           "models3d step downloads kicad-packages3d once, 332 MB)")
    todo = [m for m in want if m in shipped() and not (MODELS / m).exists()]
    if todo:
        MODELS.mkdir(parents=True, exist_ok=True)
        members = "\n".join(PREFIX + m for m in todo) + "\n"
        with subprocess.Popen(["dpkg-deb", "--fsys-tarfile", str(deb)], stdout=subprocess.PIPE) as src:
            list_file = CACHE / "extract.list"
            list_file.write_text(members)
            p = subprocess.run(["tar", "-x", "-C", str(MODELS), "--strip-components=5",
                                "-T", str(list_file)], stdin=src.stdout, capture_output=True, text=True)
            src.stdout.close()
        if p.returncode != 0:
            raise RuntimeError(f"extracting 3D models from {deb.name} failed:\n{p.stderr}")
        print(f"models3d: extracted {len(todo)} models into {MODELS}")
    return MODELS


def main() -> int:
    pcbs = sorted((ROOT / "hardware").glob("*/*.kicad_pcb"))
    folder = ensure(pcbs)
    want = referenced(pcbs)
    lost = missing(want)
    print(f"models3d: {len(want) - len(lost)} of {len(want)} models the boards use are in {folder}"
          + (f"; KiCad ships none for: {', '.join(Path(m).stem for m in lost)}" if lost else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main())
