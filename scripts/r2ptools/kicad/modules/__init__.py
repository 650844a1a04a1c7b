"""Board descriptions `scripts/hwgen` scaffolds new boards from: the common core and one module
per file (`<module>.py`, its drawing in `<module>_sheet.py`).

A board's KiCad files are its source once scaffolded, and its description is then deleted (git
keeps it): proximity's and psu's are gone; `template` stays as the example a new module copies
(tests/test_hardware.py scaffolds it into a scratch folder). `MODULES` lists the descriptions.
"""
from __future__ import annotations

from ..design import Module
from . import core, template

MODULES = {
    "template": template.build,
}


def build(name: str) -> Module:
    if name not in MODULES:
        raise KeyError(f"no module {name!r}; known: {', '.join(MODULES)}")
    return MODULES[name](core.build())


def build_all() -> list[Module]:
    c = core.build()
    return [f(c) for f in MODULES.values()]
