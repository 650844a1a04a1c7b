"""The board descriptions: the common core sheet and one module per file.

`MODULES` lists every generated board folder under hardware/ in a fixed order; the core sheet
file is shared by all of them and records each one's references (so it is always written with
the full list, whichever board is being regenerated).
"""
from __future__ import annotations

from ..design import Module
from . import core, proximity, psu, template

MODULES = {
    "proximity": proximity.build,
    "psu": psu.build,
    "template": template.build,
}


def build(name: str) -> Module:
    if name not in MODULES:
        raise KeyError(f"no module {name!r}; known: {', '.join(MODULES)}")
    return MODULES[name](core.build())


def build_all() -> list[Module]:
    c = core.build()
    return [f(c) for f in MODULES.values()]
