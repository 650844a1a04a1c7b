"""Pin capabilities of an STM32, read from the chip database embassy-stm32 is built from.

`stm32-metapac` carries, per chip, every peripheral's pins (`PeripheralPin { pin, signal }`) and,
on the F1, the AFIO remap values that route a peripheral to a set of pins. We parse that Rust
source straight from the cargo registry, at the version the firmware's Cargo.lock pins, so the
pin check and the firmware's compile-time pin traits agree by construction: nothing here is
typed by hand.
"""
from __future__ import annotations

import os
import re
import tomllib
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

from . import ROOT

CRATE = "stm32-metapac"


class ChipDbError(Exception):
    """The chip database cannot be found or read; the message says what to do."""


@dataclass(frozen=True)
class Remap:
    """One AFIO remap field (e.g. TIM1_REMAP): which pins each value routes the peripheral to."""
    field: str
    peripheral: str
    values: dict[int, frozenset[str]]

    def values_for(self, pin: str) -> set[int]:
        """Remap values under which the peripheral uses `pin`; empty if no value lists it."""
        return {v for v, pins in self.values.items() if pin in pins}


@dataclass(frozen=True)
class Chip:
    """One chip's pins and what each can carry (`ADC1_IN0`, `TIM1_CH1N`, `RCC_OSC_IN`, ...)."""
    name: str
    source: Path
    pins: tuple[str, ...]
    functions: dict[str, frozenset[str]]          # pin -> functions
    remaps: dict[str, Remap]                      # AFIO field -> remap
    peripherals: frozenset[str]

    def pins_with(self, function: str) -> list[str]:
        """Pins that can carry `function`, in the chip's pin order."""
        return [p for p in self.pins if function in self.functions.get(p, ())]

    def peripheral_of(self, function: str) -> str | None:
        """`TIM1` for `TIM1_CH1N`: the longest peripheral name that prefixes the function."""
        names = [p for p in self.peripherals if function.startswith(p + "_")]
        return max(names, key=len) if names else None

    def remap_of(self, peripheral: str) -> Remap | None:
        return next((r for r in self.remaps.values() if r.peripheral == peripheral), None)


def _registry_roots() -> list[Path]:
    home = Path(os.environ.get("CARGO_HOME", Path.home() / ".cargo"))
    return sorted((home / "registry" / "src").glob("*"))


def metapac_version(mcu: str, root: Path = ROOT) -> tuple[str, Path]:
    """The stm32-metapac version locked by the firmware target for `mcu`, and that Cargo.lock.

    The target is the folder of firmware/targets whose name the part number contains
    (STM32F103CBT6 -> f103)."""
    targets = root / "firmware" / "targets"
    locks = sorted(p for p in targets.glob("*/Cargo.lock") if p.parent.name in mcu.lower())
    if not locks:
        raise ChipDbError(f"no firmware target for {mcu}: expected firmware/targets/<family>/Cargo.lock "
                          f"with <family> (e.g. f103) in the part number")
    lock = locks[-1]
    with open(lock, "rb") as f:
        packages = tomllib.load(f).get("package", [])
    versions = [p["version"] for p in packages if p.get("name") == CRATE]
    if len(versions) != 1:
        raise ChipDbError(f"{lock.relative_to(root)} locks {len(versions)} versions of {CRATE} "
                          f"({', '.join(versions) or 'none'}); expected one")
    return versions[0], lock


def chip_dir(mcu: str, root: Path = ROOT) -> Path:
    """The crate's src/chips/<chip> folder for `mcu`: the longest chip name prefixing the part."""
    version, lock = metapac_version(mcu, root)
    crates = [r / f"{CRATE}-{version}" for r in _registry_roots()]
    crate = next((c for c in crates if (c / "src" / "chips").is_dir()), None)
    if crate is None:
        target = lock.parent.relative_to(root)
        raise ChipDbError(f"{CRATE} {version} (locked by {target}/Cargo.lock) is not in the cargo "
                          f"registry ({os.environ.get('CARGO_HOME', '~/.cargo')}/registry/src/*/): "
                          f"run `cargo fetch` in {target}")
    part = mcu.lower()
    chips = [d for d in (crate / "src" / "chips").iterdir() if part.startswith(d.name)]
    if not chips:
        raise ChipDbError(f"{CRATE} {version} has no chip matching {mcu} (looked in {crate}/src/chips)")
    return max(chips, key=lambda d: len(d.name))


def _block(text: str, start: str, where: Path) -> str:
    """The text of the array literal that begins at `start` (up to its closing `];`)."""
    i = text.find(start)
    if i < 0:
        raise ChipDbError(f"{where}: no `{start}`: the {CRATE} format changed; update stm32db.py")
    depth = 0
    for j in range(text.index("= &[", i) + 3, len(text)):
        depth += {"[": 1, "]": -1}.get(text[j], 0)
        if depth == 0:
            return text[i:j + 1]
    raise ChipDbError(f"{where}: unterminated `{start}`")


def _parse(text: str, name: str, source: Path) -> Chip:
    peripherals = _block(text, "static PERIPHERALS", source)
    chunks = re.split(r"\n    Peripheral \{", peripherals)[1:]
    functions: dict[str, set[str]] = {}
    remaps: dict[str, Remap] = {}
    names = set()
    for chunk in chunks:
        periph = re.search(r'^\s*name: "(\w+)"', chunk).group(1)
        names.add(periph)
        pins = re.findall(r'PeripheralPin \{\s*pin: "(\w+)",\s*signal: "(\w+)"', chunk)
        if len(pins) != chunk.count("PeripheralPin {"):
            raise ChipDbError(f"{source}: cannot read the pins of {periph}; update stm32db.py")
        for pin, signal in pins:
            functions.setdefault(pin, set()).add(f"{periph}_{signal}")
        afio = re.search(r'afio: Some\(PeripheralAfio \{\s*register: "(\w+)",\s*field: "(\w+)",'
                         r'\s*values: &\[(.*?)\],\s*\}\)', chunk, re.S)
        if afio:
            values = {int(v): frozenset(re.findall(r'"(\w+)"', pins))
                      for v, pins in re.findall(r'value: (\d+),\s*pins: &\[([^\]]*)\]', afio.group(3))}
            remaps[afio.group(2)] = Remap(afio.group(2), periph, values)
        elif "afio: Some" in chunk:
            raise ChipDbError(f"{source}: cannot read the AFIO remap of {periph}; update stm32db.py")
    pin_names = tuple(re.findall(r'Pin \{ name: "(\w+)" \}', _block(text, "static PINS", source)))
    if not chunks or not pin_names:
        raise ChipDbError(f"{source}: no peripherals or pins found; update stm32db.py")
    return Chip(name=name, source=source, pins=pin_names,
                functions={p: frozenset(f) for p, f in functions.items()},
                remaps=remaps, peripherals=frozenset(names))


@lru_cache(maxsize=None)
def _load(directory: Path) -> Chip:
    metadata = directory / "metadata.rs"
    text = metadata.read_text()
    # metadata.rs include!s the file that many chips share (peripherals, pins).
    for inc in re.findall(r'include!\("([^"]+)"\);', text):
        text += "\n" + (directory / inc).read_text()
    chip_name = re.search(r'name: "(\w+)"', text[text.find("static METADATA"):])
    return _parse(text, chip_name.group(1) if chip_name else directory.name.upper(), metadata)


def load_chip(mcu: str, root: Path = ROOT) -> Chip:
    """The pin capabilities of `mcu` (e.g. STM32F103CBT6) from the locked stm32-metapac."""
    return _load(chip_dir(mcu, root))
