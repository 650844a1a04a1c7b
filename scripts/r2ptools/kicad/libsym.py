"""Symbols from KiCad's installed libraries (/usr/share/kicad/symbols), ready to embed.

A schematic carries a copy of every library symbol it uses (`lib_symbols`). KiCad 9 libraries
define many parts as `extends` of a base symbol; an embedded copy must be flat, so the base's
drawing and pins are merged under the derived symbol's name and properties. Pins are read from
the same copy, so the schematic writer puts its labels exactly on the pins KiCad will see.
"""
from __future__ import annotations

import copy
import functools
from dataclasses import dataclass
from pathlib import Path

from . import sexpr
from .sexpr import Q

SYMBOL_DIR = Path("/usr/share/kicad/symbols")
PROJECT_LIB = "R2P"
"""The project's own symbols (hardware/core/R2P.kicad_sym) for parts KiCad's libraries lack."""


def library_path(lib: str) -> Path:
    if lib == PROJECT_LIB:
        from .. import ROOT
        return ROOT / "hardware" / "core" / f"{PROJECT_LIB}.kicad_sym"
    return SYMBOL_DIR / f"{lib}.kicad_sym"


@dataclass(frozen=True)
class Pin:
    number: str
    name: str
    etype: str          # KiCad electrical type: input, output, power_in, passive, no_connect…
    x: float            # connection point, library coordinates (y up)
    y: float
    angle: int          # direction from the connection point into the body
    hidden: bool


@functools.cache
def _library(lib: str) -> dict[str, list]:
    path = library_path(lib)
    if not path.exists():
        raise FileNotFoundError(f"symbol library {lib!r}: no {path} (is kicad-symbols installed?)")
    tree = sexpr.parse(path.read_text())
    return {str(s[1]): s for s in sexpr.find_all(tree, "symbol")}


def _flat(lib: str, name: str) -> list:
    symbols = _library(lib)
    if name not in symbols:
        raise KeyError(f"symbol {lib}:{name} not found in {library_path(lib)}")
    sym = copy.deepcopy(symbols[name])
    ext = sexpr.find(sym, "extends")
    if ext is None:
        return sym
    base = _flat(lib, str(ext[1]))
    base_name = str(base[1])
    props = {str(p[1]): p for p in sexpr.find_all(sym, "property")}
    out: list = ["symbol", Q(name)]
    for c in base[2:]:
        if isinstance(c, list) and c[0] == "property":
            out.append(props.pop(str(c[1]), c))
        elif isinstance(c, list) and c[0] == "symbol":
            sub = copy.deepcopy(c)
            sub[1] = Q(str(sub[1]).replace(base_name, name, 1))
            out.append(sub)
        else:
            out.append(c)
    # properties only the derived symbol has go after the base's ones
    idx = max(i for i, c in enumerate(out) if isinstance(c, list) and c[0] == "property")
    for p in props.values():
        idx += 1
        out.insert(idx, p)
    return out


@functools.cache
def embedded(lib_id: str) -> list:
    """The flat copy of `Lib:Name` as a schematic's `lib_symbols` holds it."""
    lib, name = lib_id.split(":", 1)
    sym = _flat(lib, name)
    sym[1] = Q(lib_id)
    return sym


@functools.cache
def pins(lib_id: str) -> tuple[Pin, ...]:
    """Every pin of unit 1 (and of the common unit 0), in library order."""
    out = []
    for sub in sexpr.find_all(embedded(lib_id), "symbol"):
        unit = int(str(sub[1]).rsplit("_", 2)[-2])
        if unit not in (0, 1):
            continue
        for p in sexpr.find_all(sub, "pin"):
            at = sexpr.find(p, "at")
            hide = "hide" in p or (sexpr.find(p, "hide") or [None, "no"])[1] == "yes"
            out.append(Pin(number=str(sexpr.find(p, "number")[1]), name=str(sexpr.find(p, "name")[1]),
                           etype=str(p[1]), x=float(at[1]), y=float(at[2]), angle=int(float(at[3])),
                           hidden=bool(hide)))
    return tuple(out)


def property_value(lib_id: str, key: str) -> str | None:
    for p in sexpr.find_all(embedded(lib_id), "property"):
        if str(p[1]) == key:
            return str(p[2])
    return None


def is_power(lib_id: str) -> bool:
    return sexpr.find(embedded(lib_id), "power") is not None
