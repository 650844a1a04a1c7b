"""Board descriptions `scripts/hwgen` scaffolds new boards from: the common core (`core.py`, shared
by every board, so it stays here with the generator) and one description per module.

A module's description is its board's generator input, so it lives in the module's folder:
`hardware/<module>/<module>.py`, its drawing in `<module>_sheet.py` beside it, found through the
module manifest (modules.toml). A board's KiCad files are its source once scaffolded, and its
description is then deleted (git keeps it): proximity's and psu's are gone; `template` stays as
the example a new module copies (tests/test_hardware.py scaffolds it into a scratch folder).
`MODULES` lists the descriptions.
"""
from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType

from ... import ROOT, manifest
from ..design import Module
from . import core


def _load(path: Path) -> ModuleType:
    """A description file as a Python module (named after its path, so two never collide)."""
    name = "r2p_hardware." + path.parent.name.replace("-", "_") + "." + path.stem
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name, path)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[name] = mod
    spec.loader.exec_module(mod)
    return mod


def drawing_of(description: str) -> ModuleType:
    """The drawing (`<module>_sheet.py`) beside a description file (`<module>.py`)."""
    p = Path(description)
    return _load(p.with_name(f"{p.stem}_sheet.py"))


def description_file(name: str) -> Path | None:
    """Where module `name`'s description is, if it has one."""
    for m in manifest.load(check_tree=False):
        if m.name == name and (f := ROOT / m.hardware / f"{name}.py").is_file():
            return f
    return None


def _descriptions() -> dict:
    found = {}
    for m in manifest.load(check_tree=False):
        if (f := description_file(m.name)) is not None:
            found[m.name] = _load(f).build
    return found


MODULES = _descriptions()


def build(name: str) -> Module:
    if name not in MODULES:
        raise KeyError(f"no module {name!r}; known: {', '.join(MODULES)}")
    return MODULES[name](core.build())


def build_all() -> list[Module]:
    c = core.build()
    return [f(c) for f in MODULES.values()]
