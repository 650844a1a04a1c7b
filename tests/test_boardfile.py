"""The HAL board file reader (scripts/r2ptools/boardfile.py, format in docs/board-files.md)."""
from __future__ import annotations

from pathlib import Path

import pytest

from conftest import ROOT
from r2ptools.boardfile import BoardFileError, load_board

BASE = """
[board]
mcu = "STM32F103CBT6"
package = "LQFP48"

[afio]
CAN1_REMAP = 0

[pins]
PA11 = { signal = "CAN_RX", mode = "alternate", function = "CAN_RX" }
PC13 = { signal = "LED_STATUS", mode = "output", init = "high", active = "low" }
"""
MODULE = """
[board]
module = "psu"
revision = "A"
extends = "base.toml"
schematic = "hardware/psu/psu.kicad_sch"

[pins]
PA0 = { signal = "VIN_SENSE", mode = "analog", function = "ADC1_IN0" }
"""


def write(tmp: Path, **files: str) -> Path:
    for name, text in files.items():
        (tmp / f"{name}.toml").write_text(text)
    return tmp


def errors(tmp: Path, name: str = "psu") -> list[str]:
    with pytest.raises(BoardFileError) as e:
        load_board(tmp / f"{name}.toml", root=tmp)
    return e.value.messages


def test_extends_merges_base_first_and_records_each_pins_file(tmp_path):
    write(tmp_path, base=BASE, psu=MODULE)
    board = load_board(tmp_path / "psu.toml", root=tmp_path)
    assert list(board.pins) == ["PA11", "PC13", "PA0"]
    assert board.pins["PA11"].source == tmp_path / "base.toml"
    assert board.pins["PA0"].source == tmp_path / "psu.toml"
    assert board.pins["PC13"].init == "high" and board.pins["PC13"].active == "low"
    assert board.pins["PA0"].describe() == "VIN_SENSE (analog ADC1_IN0)"
    assert (board.module, board.mcu, board.schematic) == ("psu", "STM32F103CBT6",
                                                          "hardware/psu/psu.kicad_sch")
    assert board.afio == {"CAN1_REMAP": 0}
    assert board.files == [tmp_path / "base.toml", tmp_path / "psu.toml"]
    assert "extends" not in board.settings


def test_extends_chains_over_several_files(tmp_path):
    mid = MODULE.replace('module = "psu"\nrevision = "A"\n', "").replace(
        'schematic = "hardware/psu/psu.kicad_sch"\n', "")
    top = '[board]\nmodule = "psu"\nrevision = "A"\nextends = "mid.toml"\n' \
          'schematic = "x.kicad_sch"\n[pins]\nPB0 = { signal = "BUS_EN", mode = "output" }\n'
    write(tmp_path, base=BASE, mid=mid, psu=top)
    board = load_board(tmp_path / "psu.toml", root=tmp_path)
    assert list(board.pins) == ["PA11", "PC13", "PA0", "PB0"]


def test_a_pin_defined_in_base_and_module_names_both_files(tmp_path):
    write(tmp_path, base=BASE, psu=MODULE + 'PA11 = { signal = "OTHER", mode = "input" }\n')
    assert errors(tmp_path) == ["psu.toml: pin PA11 is already defined in base.toml (as CAN_RX): "
                                "a pin may be defined once"]


def test_a_signal_on_two_pins_names_both_pins_and_files(tmp_path):
    write(tmp_path, base=BASE, psu=MODULE + 'PB8 = { signal = "CAN_RX", mode = "input" }\n')
    assert errors(tmp_path) == ["psu.toml: signal CAN_RX of PB8 is already on PA11 in base.toml: "
                                "a signal names one net, one pin"]


def test_a_signal_twice_in_one_file(tmp_path):
    write(tmp_path, base=BASE, psu=MODULE + 'PA1 = { signal = "VIN_SENSE", mode = "input" }\n')
    assert errors(tmp_path) == ["psu.toml: signal VIN_SENSE of PA1 is already on PA0 in psu.toml: "
                                "a signal names one net, one pin"]


def test_a_pin_twice_in_one_file_is_a_toml_error_with_the_file_name(tmp_path):
    write(tmp_path, base=BASE, psu=MODULE + 'PA0 = { signal = "X", mode = "input" }\n')
    (message,) = errors(tmp_path)
    assert message.startswith("psu.toml: invalid TOML: ") and "line 10" in message


def test_a_module_may_not_change_its_base_board_keys(tmp_path):
    write(tmp_path, base=BASE, psu=MODULE.replace('revision = "A"', 'revision = "A"\nmcu = "STM32F103C8T6"'))
    assert errors(tmp_path) == ["psu.toml: [board] mcu = 'STM32F103C8T6' changes 'STM32F103CBT6' of "
                                "base.toml: a file may add [board] keys to its base, not change them"]


def test_extends_missing_file_and_cycle(tmp_path):
    write(tmp_path, psu=MODULE)
    assert errors(tmp_path) == [f"psu.toml: extends 'base.toml': no such file base.toml"]
    write(tmp_path, base=BASE.replace("[board]", '[board]\nextends = "psu.toml"'), psu=MODULE)
    assert errors(tmp_path) == ["psu.toml: extends forms a cycle: psu.toml -> base.toml -> psu.toml"]


def test_module_files_need_their_keys_and_matching_file_names(tmp_path):
    write(tmp_path, base=BASE, psu=MODULE.replace('revision = "A"\n', "").replace('"psu"', '"pdu"'))
    assert errors(tmp_path) == [
        "psu.toml: [board] lacks revision (needed by a module file, here or in the base it extends)",
        "psu.toml: [board] module = 'pdu' but the file is psu.toml: name the file <module>.toml"]


@pytest.mark.parametrize("pin, message", [
    ('PA1 = { signal = "X", mode = "analog" }',
     "PA1: mode analog needs a function (e.g. ADC1_IN0, TIM1_CH1, CAN_RX)"),
    ('PA1 = { signal = "X", mode = "input", init = "high" }', "PA1: init is only for mode output, not input"),
    ('PA1 = { signal = "X", mode = "output", function = "TIM2_CH2" }',
     "PA1: function is only for mode analog or alternate, not output"),
    ('PA1 = { signal = "X", mode = "output", init = "on" }', "PA1: init must be one of high, low, got 'on'"),
    ('PA1 = { signal = "X", mode = "input", pull = "strong" }',
     "PA1: pull must be one of up, down, none, got 'strong'"),
    ('PA1 = { signal = "x-1", mode = "input" }',
     "PA1: signal must be an upper-case net name (A-Z, 0-9, _), got 'x-1'"),
    ('PA1 = { signal = "X", mode = "gpio" }',
     "PA1: mode must be one of input, output, analog, alternate, debug, oscillator, reserved, got 'gpio'"),
    ('PA1 = { signal = "X", mode = "input", speed = "high" }',
     "PA1: unknown key 'speed' (keys: signal, mode, function, init, pull, active)"),
    ('PA1 = { signal = "X", mode = "alternate", function = "tim2-ch2" }',
     "PA1: function must be <PERIPHERAL>_<SIGNAL> (e.g. TIM1_CH1), got 'tim2-ch2'"),
    ('PZ1 = { signal = "X", mode = "input" }', "[pins] key 'PZ1' is not a pin name (PA0 … PK15)"),
    ('PA1 = "X"', "PA1 must be a table such as { signal = \"NAME\", mode = \"input\" }, not 'X'"),
])
def test_pin_format_errors_name_the_file_and_pin(tmp_path, pin, message):
    write(tmp_path, base=BASE, psu=MODULE + pin + "\n")
    assert errors(tmp_path) == [f"psu.toml: {message}"]


def test_format_errors_in_the_base_are_reported_with_the_base_file(tmp_path):
    write(tmp_path, base=BASE.replace('init = "high"', 'init = "hi"') + "[extra]\n", psu=MODULE)
    assert errors(tmp_path) == ["base.toml: unknown table [extra] (tables: board, afio, pins)",
                                "base.toml: PC13: init must be one of high, low, got 'hi'"]


def test_board_key_types(tmp_path):
    write(tmp_path, base=BASE.replace('package = "LQFP48"', 'package = "LQFP48"\nhse_hz = "8MHz"\ncolour = 1'),
          psu=MODULE)
    assert errors(tmp_path) == [
        "base.toml: [board] hse_hz must be a positive integer, got '8MHz'",
        "base.toml: [board] unknown key 'colour' (keys: module, revision, extends, schematic, mcu, "
        "package, hse_hz, sysclk_hz)"]


@pytest.mark.parametrize("path", sorted((ROOT / "firmware" / "boards").glob("*.toml")),
                         ids=lambda p: p.name)
def test_the_repositorys_board_files_load(path):
    board = load_board(path)
    # The modules' F103 (the core's CAN on PA11/PA12), or the gateway's F407 (CAN1 on PB8/PB9).
    assert board.mcu in ("STM32F103CBT6", "STM32F407VGT6")
    assert "PA11" in board.pins or board.module == "gateway"
    assert {"CAN_RX", "CAN_TX"} <= {p.signal for p in board.pins.values()}
    if board.module:
        assert board.schematic == f"hardware/{board.module}/{board.module}.kicad_sch"
