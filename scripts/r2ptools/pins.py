"""`scripts/check-pins`: the firmware's pins and the hardware's nets must agree.

For each module it reads the HAL board file (`firmware/boards/<module>.toml`, merged with its
base) and the module's KiCad schematic (through `kicad-cli sch export netlist`), finds the MCU
symbol and the net on each of its GPIO pins, and reports every disagreement:

- a pin the firmware uses that the schematic leaves unconnected or puts on another net;
- a GPIO on a signal net (not a power net, not unconnected) that the board file does not list;
- a `function` the pin cannot carry on this MCU, or only with an AFIO remap the file does not set
  (pin capabilities from stm32-metapac, see `stm32db`); an `oscillator` pin that is none.

The board files are checked against the chip even where no schematic exists yet; such modules
are reported as skipped, with the reason. Exit status 1 on any disagreement.

    scripts/check-pins                 every module (board files and hardware/ folders)
    scripts/check-pins psu proximity   the named ones
"""
from __future__ import annotations

import argparse
import re
import shutil
import subprocess
import sys
import tempfile
import tomllib
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

from . import ROOT, is_shared_sheet
from .boardfile import Board, BoardFileError, display, load_board
from .stm32db import Chip, ChipDbError, load_chip

GPIO = re.compile(r"^(P[A-K](?:1[0-5]|[0-9]))(?![0-9])")
"""A GPIO's name at the start of a symbol pin name: `PB2/BOOT1` and `PD0-OSC_IN` are PB2, PD0."""
UNNAMED = ("unconnected-(", "Net-(")
POWER_NAME = re.compile(r"^([+-]?\d+(\.\d+)?V\d*|[+-]?(VCC|VDD|VDDA|VSS|VSSA|VEE|VBAT|VBUS)|"
                        r"GND|[ADP]GND|GND[ADP]|EARTH)$")
"""Power-net names (`+5V`, `+3V3`, `GND`, `VDDA`...), for nets whose only node is the MCU pin; a net
with a power_in/power_out pin on it (the MCU's own VDD/VSS, a regulator) is power whatever its
name. Sense nets such as VIN_SENSE or VBAT_SENSE are signals."""
POWER_PINS = {"power_in", "power_out"}
OSCILLATOR = "RCC_OSC"
"""Functions of crystal pins in stm32-metapac: RCC_OSC_IN/OUT (HSE), RCC_OSC32_IN/OUT (LSE)."""


class CheckError(Exception):
    """The check itself cannot run (no kicad-cli, unreadable schematic, no MCU symbol)."""


# -------------------------------------------------------------------------------- netlist

@dataclass
class Net:
    """A net of the netlist: its name without sheet path, whether it is unnamed or power."""
    name: str
    unnamed: bool
    power: bool
    lone: bool = False
    """Only the MCU pin is on it: a label that reaches nothing else connects nothing."""


@dataclass
class McuNets:
    """The MCU symbol of a schematic and the net on each of its GPIOs (by GPIO name)."""
    ref: str
    gpio: dict[str, Net] = field(default_factory=dict)

    def pins_on(self, net: str) -> list[str]:
        return [p for p, n in self.gpio.items() if n.name == net and not n.unnamed]


def export_netlist(schematic: Path, out: Path) -> Path:
    """Runs `kicad-cli sch export netlist --format kicadxml`; raises CheckError with its output."""
    cli = shutil.which("kicad-cli")
    if cli is None:
        raise CheckError("kicad-cli not found: install KiCad 9 (scripts/setup does)")
    result = subprocess.run([cli, "sch", "export", "netlist", "--format", "kicadxml", "-o", str(out),
                             str(schematic)], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    if result.returncode != 0 or not out.is_file():
        raise CheckError(f"kicad-cli could not export the netlist of {schematic}:\n{result.stdout}")
    return out


def _matches_part(candidate: str, mcu: str) -> bool:
    """KiCad names STM32 symbols with `x` for the variable letters: STM32F103CBTx ~ STM32F103CBT6."""
    pattern = "".join("." if c == "x" else re.escape(c) for c in candidate)
    return bool(candidate) and re.fullmatch(pattern, mcu, re.IGNORECASE) is not None


def _net_name(name: str) -> tuple[str, bool]:
    if name.startswith(UNNAMED):
        return name, True
    return name.rsplit("/", 1)[-1], False


def mcu_nets(netlist: Path, mcu: str, where: str) -> McuNets:
    """The symbol whose value, library symbol or MPN field is `mcu`, and its GPIOs' nets."""
    root = ET.parse(netlist).getroot()
    found = []
    for comp in root.iter("comp"):
        lib = comp.find("libsource")
        fields = {f.get("name"): (f.text or "") for f in comp.iter("field")}
        names = [comp.findtext("value", ""), lib.get("part", "") if lib is not None else "",
                 fields.get("MPN", "")]
        if any(_matches_part(n, mcu) for n in names):
            found.append((comp.get("ref"), lib))
    if len(found) != 1:
        symbols = ", ".join(f"{c.get('ref')} {c.findtext('value', '')}" for c in root.iter("comp")
                            if c.get("ref", "").startswith("U"))
        what = "no symbol" if not found else f"{len(found)} symbols ({', '.join(r for r, _ in found)})"
        raise CheckError(f"{where}: {what} with value, library symbol or MPN {mcu} (the board file's "
                         f"mcu); U symbols: {symbols or 'none'}")
    ref, lib = found[0]

    # Pin names from the library part: a node's pinfunction is the *alternate* name when one is
    # selected in the schematic, the libpart keeps the base name.
    names: dict[str, str] = {}
    for part in root.iter("libpart"):
        if lib is not None and (part.get("lib"), part.get("part")) == (lib.get("lib"), lib.get("part")):
            names = {p.get("num"): p.get("name", "") for p in part.iter("pin")}
    result = McuNets(ref=ref)
    for net in root.iter("net"):
        nodes = list(net.iter("node"))
        name, unnamed = _net_name(net.get("name", ""))
        power = not unnamed and (any(n.get("pintype") in POWER_PINS for n in nodes)
                                 or POWER_NAME.match(name) is not None)
        for node in nodes:
            if node.get("ref") != ref:
                continue
            pin_name = names.get(node.get("pin")) or node.get("pinfunction", "")
            gpio = GPIO.match(pin_name)
            if gpio:
                result.gpio[gpio.group(1)] = Net(name, unnamed, power, lone=len(nodes) == 1)
    if not result.gpio:
        raise CheckError(f"{where}: {ref} has no pins named like PA0: is it the MCU?")
    return result


# -------------------------------------------------------------------------------- checks

def check_against_chip(board: Board, chip: Chip, root: Path) -> list[str]:
    """Board-file pins the MCU cannot provide: missing pins, impossible functions, AFIO remaps."""
    errors = []
    for field_name, value in board.afio.items():
        where = display(board.afio_source[field_name], root)
        remap = chip.remaps.get(field_name)
        if remap is None:
            errors.append(f"{where}: [afio] {field_name} is not an AFIO remap field of {chip.name} "
                          f"({', '.join(sorted(chip.remaps))})")
        elif value not in remap.values:
            errors.append(f"{where}: [afio] {field_name} = {value} is not a remap of {chip.name} "
                          f"(values: {', '.join(map(str, sorted(remap.values)))})")
    for pin in board.pins.values():
        where = display(pin.source, root)
        if pin.name not in chip.pins:
            errors.append(f"{where}: {pin.name} (signal {pin.signal}) is not a pin of {chip.name}")
            continue
        can = chip.functions.get(pin.name, frozenset())
        if pin.mode == "oscillator":
            if not any(f.startswith(OSCILLATOR) for f in can):
                oscillators = [p for p in chip.pins
                               if any(f.startswith(OSCILLATOR) for f in chip.functions.get(p, ()))]
                errors.append(f"{where}: {pin.name} (signal {pin.signal}) has mode oscillator but is "
                              f"no oscillator pin of {chip.name} (those are: {', '.join(oscillators)})")
            continue
        if pin.function is None:
            continue
        is_adc = pin.function.startswith("ADC") and "_IN" in pin.function
        if pin.mode == "analog" and not is_adc:
            errors.append(f"{where}: {pin.name} (signal {pin.signal}) has mode analog, which needs an "
                          f"ADC input such as ADC1_IN0, not {pin.function}")
        elif pin.mode == "alternate" and is_adc:
            errors.append(f"{where}: {pin.name} (signal {pin.signal}): {pin.function} needs mode "
                          f"analog, not alternate")
        if pin.function not in can:
            elsewhere = chip.pins_with(pin.function)
            hint = (f"{pin.function} is on {', '.join(elsewhere)}" if elsewhere
                    else f"{chip.name} has no {pin.function}")
            errors.append(f"{where}: {pin.name} (signal {pin.signal}) cannot carry {pin.function} on "
                          f"{chip.name}: {hint}; {pin.name} can carry "
                          f"{', '.join(sorted(can)) or 'no peripheral signal'}")
            continue
        remap = chip.remap_of(chip.peripheral_of(pin.function) or "")
        needed = remap.values_for(pin.name) if remap else set()
        current = board.afio.get(remap.field, 0) if remap else 0
        if needed and current not in needed:
            options = " or ".join(str(v) for v in sorted(needed))
            errors.append(f"{where}: {pin.name} (signal {pin.signal}) carries {pin.function} only with "
                          f"{remap.field} = {options}, but {display(board.path, root)} leaves "
                          f"{remap.field} = {current}: set it under [afio]")
    return errors


def check_against_schematic(board: Board, nets: McuNets, schematic: str, root: Path) -> list[str]:
    """Every disagreement between the board file's pins and the MCU's nets in the schematic."""
    errors = []
    for pin in board.pins.values():
        where = display(pin.source, root)
        net = nets.gpio.get(pin.name)
        if net is None:
            errors.append(f"{pin.name} is not a pin of {nets.ref} in {schematic} but {where} says "
                          f"signal {pin.describe()}")
        elif net.unnamed and net.name.startswith("unconnected-("):
            errors.append(f"{pin.name} is unconnected in {schematic} but {where} says signal "
                          f"{pin.describe()}")
        elif net.lone and not net.power:
            errors.append(f"{pin.name} is on net {net.name} in {schematic}, which reaches nothing else, "
                          f"but {where} says signal {pin.describe()}: wire the net to its circuit")
        elif net.name != pin.signal or net.unnamed:
            on = nets.pins_on(pin.signal)
            hint = f"; net {pin.signal} is on {', '.join(on)}" if on else ""
            kind = "an unnamed net " if net.unnamed else "net "
            errors.append(f"{pin.name} is on {kind}{net.name} in {schematic} but {where} says signal "
                          f"{pin.describe()}{hint}")
    for name, net in sorted(nets.gpio.items(), key=lambda kv: _pin_order(kv[0])):
        if name in board.pins or net.power or net.lone or net.name.startswith("unconnected-("):
            continue
        listed = [p for p in board.pins.values() if p.signal == net.name]
        hint = f"; {display(listed[0].source, root)} puts {net.name} on {listed[0].name}" if listed else ""
        kind = "an unnamed net " if net.unnamed else "net "
        errors.append(f"{name} is on {kind}{net.name} in {schematic} but {display(board.path, root)} "
                      f"does not list {name}{hint}: add it, or leave the pin unconnected")
    return errors


def _pin_order(name: str) -> tuple[str, int]:
    return name[:2], int(name[2:])


# -------------------------------------------------------------------------------- modules

@dataclass
class Result:
    """What checking one module found: `errors` (disagreements) or a `skipped` reason."""
    module: str
    errors: list[str] = field(default_factory=list)
    skipped: str | None = None
    pins: int = 0


def modules(root: Path) -> tuple[list[str], list[str]]:
    """(modules with a board file, hardware folders without one), each sorted."""
    with_file = []
    for path in sorted((root / "firmware" / "boards").glob("*.toml")):
        try:
            if "module" in tomllib.loads(path.read_text()).get("board", {}):
                with_file.append(path.stem)
        except (OSError, tomllib.TOMLDecodeError, AttributeError):
            with_file.append(path.stem)       # unreadable: load_board will report it
    hardware = root / "hardware"
    without = sorted(d.name for d in hardware.iterdir()
                     if d.is_dir() and d.name not in with_file) if hardware.is_dir() else []
    return with_file, without


def check_module(module: str, root: Path, netlist_dir: Path) -> Result:
    result = Result(module)
    path = root / "firmware" / "boards" / f"{module}.toml"
    if not path.is_file():
        if is_shared_sheet(root / "hardware" / module):
            result.skipped = ("a shared sheet, not a board: its pins are checked in every module "
                              "whose schematic uses it")
        else:
            result.skipped = (f"no HAL board file {display(path, root)} (a module's firmware "
                              f"starts there: docs/board-files.md)")
        return result
    try:
        board = load_board(path, root)
        chip = load_chip(board.mcu)
    except BoardFileError as e:
        result.errors = e.messages
        return result
    result.errors = check_against_chip(board, chip, root)
    schematic = root / board.schematic
    if not schematic.is_file():
        result.skipped = (f"{board.schematic} does not exist yet "
                          f"(board file checked against {chip.name} only)")
        return result
    where = display(schematic, root)
    netlist = export_netlist(schematic, netlist_dir / f"{module}.xml")
    nets = mcu_nets(netlist, board.mcu, where)
    result.pins = len(board.pins)
    result.errors += check_against_schematic(board, nets, where, root)
    return result


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="scripts/check-pins",
        description="Check that each module's HAL board file (firmware/boards/<module>.toml) and its "
                    "KiCad schematic agree pin by pin, and that every pin function exists on the MCU "
                    "(stm32-metapac). Exit status 1 on any disagreement.")
    parser.add_argument("modules", nargs="*", metavar="MODULE",
                        help="modules to check (default: every board file and hardware/ folder)")
    parser.add_argument("--root", type=Path, default=ROOT,
                        help="repository root holding firmware/boards and hardware (default: this one)")
    args = parser.parse_args(argv)
    root = args.root.resolve()
    with_file, without = modules(root)
    names = args.modules or with_file + without
    unknown = [m for m in args.modules if m not in with_file and not (root / "hardware" / m).is_dir()]
    if unknown:
        print(f"check-pins: unknown module(s) {', '.join(unknown)}; modules: "
              f"{', '.join(with_file + without)}", file=sys.stderr)
        return 2
    failed = False
    with tempfile.TemporaryDirectory(prefix="check-pins-") as tmp:
        for module in names:
            try:
                result = check_module(module, root, Path(tmp))
            except (CheckError, ChipDbError) as e:
                result = Result(module, errors=[str(e)])
            for error in result.errors:
                print(f"{module}: {error}")
            if result.errors:
                failed = True
                print(f"check-pins: {module}: {len(result.errors)} problem(s)")
            elif result.skipped:
                print(f"check-pins: {module}: skipped: {result.skipped}")
            else:
                print(f"check-pins: {module}: ok ({result.pins} pins agree)")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
