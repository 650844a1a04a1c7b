"""Reader of the HAL board files (`firmware/boards/<module>.toml`, format in docs/board-files.md).

A board file names every MCU pin a module's firmware uses: its signal (the KiCad net name), mode
and peripheral function. `load_board` merges a file with the base it `extends` and checks the
format; it knows nothing about the chip (that is `stm32db`) or the schematic (that is `pins`).
Every error names the file it is in, and all errors of a file are reported at once.
"""
from __future__ import annotations

import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

from . import ROOT

MODES = ("input", "output", "analog", "alternate", "debug", "oscillator", "reserved")
BOARD_KEYS = {"module": str, "revision": str, "extends": str, "schematic": str, "mcu": str,
              "package": str, "hse_hz": int, "sysclk_hz": int}
MODULE_REQUIRED = ("module", "revision", "schematic", "mcu")
"""[board] keys a module file (one with `module`) must have once merged with its base."""
PIN_KEYS = ("signal", "mode", "function", "init", "pull", "active")
# Which modes a key may appear on (`signal` and `mode` always; `function` is required on these).
KEY_MODES = {"function": ("analog", "alternate"), "init": ("output",),
             "pull": ("input", "alternate"), "active": ("input", "output", "alternate")}
KEY_VALUES = {"init": ("high", "low"), "pull": ("up", "down", "none"), "active": ("high", "low")}
PIN_NAME = re.compile(r"^P[A-K](1[0-5]|[0-9])$")
SIGNAL_NAME = re.compile(r"^[A-Z][A-Z0-9_]*$")
FUNCTION_NAME = re.compile(r"^[A-Z][A-Z0-9]*_[A-Z0-9_]+$")
MODULE_NAME = re.compile(r"^[a-z][a-z0-9-]*$")


class BoardFileError(Exception):
    """One or more problems in a board file (or its base); `messages` lists them all."""

    def __init__(self, messages: list[str]):
        super().__init__("\n".join(messages))
        self.messages = messages


@dataclass(frozen=True)
class Pin:
    """One `[pins]` entry, with the file that defines it."""
    name: str
    signal: str
    mode: str
    source: Path
    function: str | None = None
    init: str | None = None
    pull: str | None = None
    active: str | None = None

    def describe(self) -> str:
        """`IIN_SENSE (analog ADC1_IN1)`: the signal and how the firmware uses the pin."""
        how = f"{self.mode} {self.function}" if self.function else self.mode
        return f"{self.signal} ({how})"


@dataclass
class Board:
    """A board file merged with its bases: `files` base first, `path` (the module's file) last."""
    path: Path
    files: list[Path]
    settings: dict[str, object] = field(default_factory=dict)     # merged [board], minus extends
    afio: dict[str, int] = field(default_factory=dict)
    afio_source: dict[str, Path] = field(default_factory=dict)
    pins: dict[str, Pin] = field(default_factory=dict)

    @property
    def module(self) -> str | None:
        return self.settings.get("module")

    @property
    def mcu(self) -> str | None:
        return self.settings.get("mcu")

    @property
    def schematic(self) -> str | None:
        return self.settings.get("schematic")


def display(path: Path, root: Path = ROOT) -> str:
    """A path as messages show it: relative to the repository root when inside it."""
    path = Path(path).resolve()
    root = Path(root).resolve()
    return str(path.relative_to(root)) if path.is_relative_to(root) else str(path)


def _read(path: Path, root: Path) -> dict:
    where = display(path, root)
    try:
        with open(path, "rb") as f:
            return tomllib.load(f)
    except FileNotFoundError:
        raise BoardFileError([f"{where}: no such board file"]) from None
    except tomllib.TOMLDecodeError as e:
        raise BoardFileError([f"{where}: invalid TOML: {e} (a key defined twice is an error)"]) from None


def _check_pin(name: str, spec: object, where: str) -> list[str]:
    """Format errors of one [pins] entry."""
    if not PIN_NAME.match(name):
        return [f"{where}: [pins] key {name!r} is not a pin name (PA0 … PK15)"]
    if not isinstance(spec, dict):
        return [f"{where}: {name} must be a table such as "
                f'{{ signal = "NAME", mode = "input" }}, not {spec!r}']
    errors = [f"{where}: {name}: unknown key {k!r} (keys: {', '.join(PIN_KEYS)})"
              for k in spec if k not in PIN_KEYS]
    signal, mode = spec.get("signal"), spec.get("mode")
    if not isinstance(signal, str) or not SIGNAL_NAME.match(signal):
        errors.append(f"{where}: {name}: signal must be an upper-case net name "
                      f"(A-Z, 0-9, _), got {signal!r}")
    if mode not in MODES:
        errors.append(f"{where}: {name}: mode must be one of {', '.join(MODES)}, got {mode!r}")
        return errors
    for key, modes in KEY_MODES.items():
        value = spec.get(key)
        if value is None:
            if key == "function" and mode in modes:
                errors.append(f"{where}: {name}: mode {mode} needs a function "
                              f"(e.g. ADC1_IN0, TIM1_CH1, CAN_RX)")
            continue
        if mode not in modes:
            errors.append(f"{where}: {name}: {key} is only for mode {' or '.join(modes)}, "
                          f"not {mode}")
        elif key == "function" and not (isinstance(value, str) and FUNCTION_NAME.match(value)):
            errors.append(f"{where}: {name}: function must be <PERIPHERAL>_<SIGNAL> "
                          f"(e.g. TIM1_CH1), got {value!r}")
        elif key in KEY_VALUES and value not in KEY_VALUES[key]:
            errors.append(f"{where}: {name}: {key} must be one of {', '.join(KEY_VALUES[key])}, "
                          f"got {value!r}")
    return errors


def _check_file(data: dict, where: str) -> list[str]:
    """Format errors of one file, before merging."""
    errors = [f"{where}: unknown table [{k}] (tables: board, afio, pins)"
              for k in data if k not in ("board", "afio", "pins")]
    for key, value in data.get("board", {}).items():
        kind = BOARD_KEYS.get(key)
        if kind is None:
            errors.append(f"{where}: [board] unknown key {key!r} (keys: {', '.join(BOARD_KEYS)})")
        elif not isinstance(value, kind) or isinstance(value, bool) or (kind is int and value <= 0):
            errors.append(f"{where}: [board] {key} must be a "
                          f"{'positive integer' if kind is int else 'string'}, got {value!r}")
    module = data.get("board", {}).get("module")
    if isinstance(module, str) and not MODULE_NAME.match(module):
        errors.append(f"{where}: [board] module {module!r} must be a lower-case folder name "
                      f"under hardware/")
    for key, value in data.get("afio", {}).items():
        if not isinstance(value, int) or isinstance(value, bool) or value < 0:
            errors.append(f"{where}: [afio] {key} must be a remap value (0, 1, 2, 3), got {value!r}")
    pins = data.get("pins", {})
    if not isinstance(pins, dict):
        errors.append(f"{where}: [pins] must be a table")
        pins = {}
    for name, spec in pins.items():
        errors += _check_pin(name, spec, where)
    return errors


def _chain(path: Path, root: Path) -> list[tuple[Path, dict]]:
    """The file and its bases, base first; follows `extends` relative to each file."""
    chain: list[tuple[Path, dict]] = []
    seen: list[Path] = []
    current = Path(path).resolve()
    while True:
        if current in seen:
            cycle = " -> ".join(display(p, root) for p in [*seen, current])
            raise BoardFileError([f"{display(path, root)}: extends forms a cycle: {cycle}"])
        seen.append(current)
        data = _read(current, root)
        chain.append((current, data))
        base = data.get("board", {}).get("extends")
        if base is None:
            return chain[::-1]
        if not isinstance(base, str):
            raise BoardFileError([f"{display(current, root)}: [board] extends must be a file name"])
        target = (current.parent / base).resolve()
        if not target.is_file():
            raise BoardFileError([f"{display(current, root)}: extends {base!r}: "
                                  f"no such file {display(target, root)}"])
        current = target


def load_board(path: Path, root: Path = ROOT) -> Board:
    """Reads a board file and its bases, merges them (base first) and checks the format.

    Raises BoardFileError listing every problem, each naming its file."""
    chain = _chain(path, root)
    errors: list[str] = []
    for file, data in chain:
        errors += _check_file(data, display(file, root))
    if errors:
        raise BoardFileError(errors)

    board = Board(path=Path(path).resolve(), files=[f for f, _ in chain])
    setting_source: dict[str, Path] = {}
    signal_pin: dict[str, Pin] = {}
    for file, data in chain:
        where = display(file, root)
        for key, value in data.get("board", {}).items():
            if key == "extends":
                continue
            if key in board.settings and board.settings[key] != value:
                errors.append(f"{where}: [board] {key} = {value!r} changes "
                              f"{board.settings[key]!r} of {display(setting_source[key], root)}: "
                              f"a file may add [board] keys to its base, not change them")
                continue
            board.settings[key], setting_source[key] = value, file
        for key, value in data.get("afio", {}).items():
            if key in board.afio and board.afio[key] != value:
                errors.append(f"{where}: [afio] {key} = {value} changes {board.afio[key]} of "
                              f"{display(board.afio_source[key], root)}")
                continue
            board.afio[key], board.afio_source[key] = value, file
        for name, spec in data.get("pins", {}).items():
            pin = Pin(name=name, source=file, **spec)
            if name in board.pins:
                errors.append(f"{where}: pin {name} is already defined in "
                              f"{display(board.pins[name].source, root)} (as {board.pins[name].signal}): "
                              f"a pin may be defined once")
                continue
            other = signal_pin.get(pin.signal)
            if other is not None:
                errors.append(f"{where}: signal {pin.signal} of {name} is already on {other.name} "
                              f"in {display(other.source, root)}: a signal names one net, one pin")
                continue
            board.pins[name] = pin
            signal_pin[pin.signal] = pin

    if board.module is not None:
        where = display(board.path, root)
        missing = [k for k in MODULE_REQUIRED if k not in board.settings]
        if missing:
            errors.append(f"{where}: [board] lacks {', '.join(missing)} (needed by a module file, "
                          f"here or in the base it extends)")
        if board.module != board.path.stem:
            errors.append(f"{where}: [board] module = {board.module!r} but the file is "
                          f"{board.path.name}: name the file <module>.toml")
    if errors:
        raise BoardFileError(errors)
    return board
