"""scripts/check-pins: board file vs KiCad schematic vs the MCU's pin capabilities.

Each case builds a small repository in tmp_path: the fixture board files of tests/fixtures/pins/
boards and a real KiCad schematic written by tests/fixtures/pins/mksch.py, which check-pins
exports through kicad-cli like a real board."""
from __future__ import annotations

import shutil
import sys
from pathlib import Path

import pytest

from conftest import ROOT, run

sys.path.insert(0, str(ROOT / "tests" / "fixtures" / "pins"))
from mksch import NC, WIRE, Part, write_schematic  # noqa: E402

FIXTURES = ROOT / "tests" / "fixtures" / "pins" / "boards"
CHECK = str(ROOT / "scripts" / "check-pins")
SCH = "hardware/demo/demo.kicad_sch"
BOARD = "firmware/boards/demo.toml"
BASE = "firmware/boards/core.toml"
R1 = Part("R1", "Device:R", "10k", "Resistor_SMD:R_0402_1005Metric", {"1": "BOOT1", "2": "GND"})
# The nets of a schematic that agrees with tests/fixtures/pins/boards/demo.toml. PB5 carries a
# no-connect flag, PB10 is tied to GND (a net with the MCU's VSS pins), PB12 to +5V (power by its
# name alone): none is a signal the firmware must list.
GOOD_NETS = {"PA0": "VIN_SENSE", "PA1": "IIN_SENSE", "PA8": "PWM_A", "PB0": "BUS_EN",
             "PB1": "BUS_FAULT", "PA11": "CAN_RX", "PA12": "CAN_TX", "PA13": "SWDIO",
             "PA14": "SWCLK", "PD0": "OSC_IN", "PD1": "OSC_OUT", "PB2": "BOOT1",
             "PC13": "LED_STATUS", "PB5": NC, "PB10": "GND", "PB12": "+5V"}

def make_repo(tmp: Path, nets: dict[str, str] = GOOD_NETS, demo_edit=None, parts=(R1,), **sch) -> Path:
    """tmp as a repository: fixture board files (demo.toml through `demo_edit`) and a schematic."""
    boards = tmp / "firmware" / "boards"
    boards.mkdir(parents=True)
    shutil.copy(FIXTURES / "core.toml", boards)
    text = (FIXTURES / "demo.toml").read_text()
    (boards / "demo.toml").write_text(demo_edit(text) if demo_edit else text)
    write_schematic(tmp / SCH, nets, list(parts), **sch)
    return tmp


def check(repo: Path, *args: str, env: dict[str, str] | None = None):
    result = run([CHECK, "--root", str(repo), *args], env=env)
    lines = [line for line in result.stdout.splitlines() if line.startswith("demo: ")]
    return result.returncode, lines, result.stdout


def test_agreeing_board_file_and_schematic_pass(tmp_path):
    rc, problems, out = check(make_repo(tmp_path))
    assert rc == 0, out
    assert problems == []
    assert "check-pins: demo: ok (13 pins agree)" in out


def test_a_net_that_reaches_nothing_but_the_mcu_is_not_wired(tmp_path):
    # A label on an unused pin connects nothing: fine. A used pin whose net reaches nothing
    # else is as good as unconnected.
    nets = {**GOOD_NETS, "PB7": "SPARE_LABEL"}
    rc, problems, out = check(make_repo(tmp_path, nets, lone=("SPARE_LABEL", "BUS_EN")))
    assert rc == 1, out
    assert problems == [
        f"demo: PB0 is on net BUS_EN in {SCH}, which reaches nothing else, but {BOARD} says signal "
        "BUS_EN (output): wire the net to its circuit",
    ]


def test_swapped_pins_are_reported_on_both_pins_with_the_net_and_both_files(tmp_path):
    nets = {**GOOD_NETS, "PA0": "IIN_SENSE", "PA1": "VIN_SENSE"}
    rc, problems, out = check(make_repo(tmp_path, nets))
    assert rc == 1, out
    assert problems == [
        f"demo: PA0 is on net IIN_SENSE in {SCH} but {BOARD} says signal VIN_SENSE (analog ADC1_IN0);"
        " net VIN_SENSE is on PA1",
        f"demo: PA1 is on net VIN_SENSE in {SCH} but {BOARD} says signal IIN_SENSE (analog ADC1_IN1);"
        " net IIN_SENSE is on PA0",
    ]


def test_a_pin_the_firmware_uses_but_hardware_leaves_unconnected(tmp_path):
    nets = {k: v for k, v in GOOD_NETS.items() if k != "PB0"}
    rc, problems, out = check(make_repo(tmp_path, nets))
    assert rc == 1, out
    assert problems == [f"demo: PB0 is unconnected in {SCH} but {BOARD} says signal BUS_EN (output)"]


def test_a_base_pin_on_another_net_names_the_base_file(tmp_path):
    rc, problems, _ = check(make_repo(tmp_path, {**GOOD_NETS, "PA12": "CANTX"}))
    assert rc == 1
    assert problems == [f"demo: PA12 is on net CANTX in {SCH} but {BASE} says signal CAN_TX "
                        f"(alternate CAN_TX)"]


def test_wired_pins_the_firmware_does_not_list(tmp_path):
    """A labelled net and an unlabelled wire to a resistor both count; NC and GND do not."""
    r2 = Part("R2", "Device:R", "1k", "Resistor_SMD:R_0402_1005Metric", {"1": "SPARE", "2": "GND"})
    rc, problems, out = check(make_repo(tmp_path, {**GOOD_NETS, "PB6": "EXTRA", "PB7": "SPARE",
                                                   "PB8": "VBAT_SENSE"}, parts=(R1, r2)))
    assert rc == 1, out
    assert problems == [
        f"demo: PB6 is on net EXTRA in {SCH} but {BOARD} does not list PB6: add it, or leave the "
        "pin unconnected",
        f"demo: PB7 is on net SPARE in {SCH} but {BOARD} does not list PB7: add it, or leave the "
        "pin unconnected",
        f"demo: PB8 is on net VBAT_SENSE in {SCH} but {BOARD} does not list PB8: add it, or leave the "
        "pin unconnected",
    ]


def test_an_unlabelled_wire_is_an_unnamed_net(tmp_path):
    r2 = Part("R2", "Device:R", "1k", "Resistor_SMD:R_0402_1005Metric", {"1": WIRE, "2": "GND"})
    rc, problems, out = check(make_repo(tmp_path, {**GOOD_NETS, "PB7": WIRE}, parts=(R1, r2)))
    assert rc == 1, out
    assert problems == [f"demo: PB7 is on an unnamed net Net-(U1-PB7) in {SCH} but {BOARD} does not "
                        "list PB7: add it, or leave the pin unconnected"]


def test_a_listed_signal_wired_to_the_wrong_pin_points_at_the_board_file_pin(tmp_path):
    nets = {k: v for k, v in GOOD_NETS.items() if k != "PB1"} | {"PB11": "BUS_FAULT"}
    rc, problems, _ = check(make_repo(tmp_path, nets))
    assert rc == 1
    assert problems == [
        f"demo: PB1 is unconnected in {SCH} but {BOARD} says signal BUS_FAULT (input)",
        f"demo: PB11 is on net BUS_FAULT in {SCH} but {BOARD} does not list PB11; {BOARD} puts "
        "BUS_FAULT on PB1: add it, or leave the pin unconnected",
    ]


def test_an_impossible_alternate_function(tmp_path):
    edit = lambda t: t.replace('PA0 = { signal = "VIN_SENSE", mode = "analog", function = "ADC1_IN0" }',
                               'PA0 = { signal = "VIN_SENSE", mode = "alternate", function = "TIM1_CH1" }')
    rc, problems, out = check(make_repo(tmp_path, demo_edit=edit))
    assert rc == 1, out
    assert problems == [
        f"demo: {BOARD}: PA0 (signal VIN_SENSE) cannot carry TIM1_CH1 on STM32F103CB: TIM1_CH1 is "
        "on PA8; PA0 can carry ADC1_IN0, ADC2_IN0, TIM2_CH1, TIM2_ETR, USART2_CTS"]


def test_board_files_are_checked_against_the_chip_without_a_schematic(tmp_path):
    edit = lambda t: t.replace('function = "ADC1_IN1"', 'function = "ADC1_IN9"')
    repo = make_repo(tmp_path, demo_edit=edit)
    (repo / SCH).unlink()
    rc, problems, out = check(repo)
    assert rc == 1, out
    assert problems == [f"demo: {BOARD}: PA1 (signal IIN_SENSE) cannot carry ADC1_IN9 on STM32F103CB: "
                        "ADC1_IN9 is on PB1; PA1 can carry ADC1_IN1, ADC2_IN1, TIM2_CH2, USART2_RTS"]
    assert f"check-pins: demo: 1 problem(s)" in out


def test_a_module_without_a_schematic_is_skipped_with_the_reason(tmp_path):
    repo = make_repo(tmp_path)
    (repo / SCH).unlink()
    (repo / "hardware" / "gateway").mkdir()
    rc, problems, out = check(repo)
    assert rc == 0, out
    assert problems == []
    assert (f"check-pins: demo: skipped: {SCH} does not exist yet (board file checked against "
            "STM32F103CB only)") in out
    assert "check-pins: gateway: skipped: no HAL board file firmware/boards/gateway.toml" in out


REMAPPED = ('PA6 = { signal = "DRV_FAULT", mode = "alternate", function = "TIM1_BKIN" }\n')


def test_a_function_that_needs_an_afio_remap_the_file_does_not_set(tmp_path):
    rc, problems, out = check(make_repo(tmp_path, {**GOOD_NETS, "PA6": "DRV_FAULT"},
                                        demo_edit=lambda t: t + REMAPPED))
    assert rc == 1, out
    assert problems == [f"demo: {BOARD}: PA6 (signal DRV_FAULT) carries TIM1_BKIN only with "
                        f"TIM1_REMAP = 1, but {BOARD} leaves TIM1_REMAP = 0: set it under [afio]"]


def test_the_same_function_passes_with_the_remap_set(tmp_path):
    edit = lambda t: t.replace("[pins]", "[afio]\nTIM1_REMAP = 1\n\n[pins]") + REMAPPED
    rc, problems, out = check(make_repo(tmp_path, {**GOOD_NETS, "PA6": "DRV_FAULT"}, demo_edit=edit))
    assert rc == 0, out


def test_afio_fields_and_values_come_from_the_chip(tmp_path):
    edit = lambda t: t.replace("[pins]", "[afio]\nTIM3_REMAP = 1\nTIM9_REMAP = 0\n\n[pins]")
    rc, problems, _ = check(make_repo(tmp_path, demo_edit=edit))
    assert rc == 1
    assert problems == [
        f"demo: {BOARD}: [afio] TIM3_REMAP = 1 is not a remap of STM32F103CB (values: 0, 2, 3)",
        f"demo: {BOARD}: [afio] TIM9_REMAP is not an AFIO remap field of STM32F103CB (CAN1_REMAP, "
        "I2C1_REMAP, SPI1_REMAP, TIM1_REMAP, TIM2_REMAP, TIM3_REMAP, TIM4_REMAP, USART1_REMAP, "
        "USART2_REMAP, USART3_REMAP)"]


@pytest.mark.parametrize("line, message", [
    ('PA2 = { signal = "X", mode = "analog", function = "TIM2_CH3" }',
     "PA2 (signal X) has mode analog, which needs an ADC input such as ADC1_IN0, not TIM2_CH3"),
    ('PA4 = { signal = "X", mode = "alternate", function = "ADC1_IN4" }',
     "PA4 (signal X): ADC1_IN4 needs mode analog, not alternate"),
    ('PB3 = { signal = "X", mode = "oscillator" }',
     "PB3 (signal X) has mode oscillator but is no oscillator pin of STM32F103CB (those are: "
     "PC14, PC15, PD0, PD1)"),
    ('PE7 = { signal = "X", mode = "output" }', "PE7 (signal X) is not a pin of STM32F103CB"),
])
def test_modes_and_pins_the_chip_cannot_provide(tmp_path, line, message):
    repo = make_repo(tmp_path, demo_edit=lambda t: t + line + "\n")
    (repo / SCH).unlink()
    rc, problems, _ = check(repo)
    assert rc == 1
    assert problems == [f"demo: {BOARD}: {message}"]


def test_symbol_pin_names_with_alternate_suffixes_are_matched_by_gpio(tmp_path):
    repo = make_repo(tmp_path, pin_names={"PB2": "PB2/BOOT1", "PD0": "PD0-OSC_IN",
                                          "PA13": "PA13/JTMS/SWDIO"})
    rc, problems, out = check(repo)
    assert rc == 0, out
    repo2 = make_repo(tmp_path / "b", {**GOOD_NETS, "PB2": "BOOT"}, pin_names={"PB2": "PB2/BOOT1"})
    rc, problems, _ = check(repo2)
    assert problems == [f"demo: PB2 is on net BOOT in {SCH} but {BASE} says signal BOOT1 (reserved)"]


def test_a_gpio_on_a_supply_net_is_power_by_the_pins_on_it_whatever_its_name(tmp_path):
    """MCU_3V3 carries the MCU's VDD pins (power_in): PB13 tied to it is not a signal."""
    repo = make_repo(tmp_path, {**GOOD_NETS, "PB13": "MCU_3V3"}, supply={"VDD": "MCU_3V3"})
    rc, problems, out = check(repo)
    assert rc == 0, out


def test_the_mcu_is_found_by_its_kicad_symbol_name_with_x_wildcards(tmp_path):
    repo = make_repo(tmp_path, mcu_fields={})     # STM32F103CBTx, no MPN field
    rc, _, out = check(repo)
    assert rc == 0, out


def test_the_mcu_is_found_by_mpn_when_value_and_symbol_differ(tmp_path):
    repo = make_repo(tmp_path, mcu_symbol="STM32F103C8Tx", mcu_value="MCU")  # MPN STM32F103CBT6
    rc, _, out = check(repo)
    assert rc == 0, out


def test_no_mcu_symbol_is_a_clear_error(tmp_path):
    repo = make_repo(tmp_path, mcu_symbol="STM32F103C8Tx", mcu_fields={"MPN": "STM32F103C8T6"})
    rc, problems, out = check(repo)
    assert rc == 1, out
    assert problems == [f"demo: {SCH}: no symbol with value, library symbol or MPN STM32F103CBT6 (the "
                        "board file's mcu); U symbols: U1 STM32F103C8Tx"]


def test_missing_chip_database_says_to_run_cargo_fetch(tmp_path):
    rc, problems, _ = check(make_repo(tmp_path), env={"CARGO_HOME": str(tmp_path / "cargo")})
    assert rc == 1
    assert len(problems) == 1
    assert problems[0].startswith("demo: stm32-metapac 21.0.0 (locked by firmware/targets/f103/"
                                  "Cargo.lock) is not in the cargo registry")
    assert problems[0].endswith("run `cargo fetch` in firmware/targets/f103")


def test_board_file_format_errors_are_reported(tmp_path):
    rc, problems, _ = check(make_repo(tmp_path, demo_edit=lambda t: t + 'PB6 = { signal = "CAN_RX", '
                                                                     'mode = "input" }\n'))
    assert rc == 1
    assert problems == [f"demo: {BOARD}: signal CAN_RX of PB6 is already on PA11 in {BASE}: a signal "
                        "names one net, one pin"]


def test_named_modules_only_and_unknown_names(tmp_path):
    repo = make_repo(tmp_path)
    (repo / "hardware" / "imu").mkdir()
    result = run([CHECK, "--root", str(repo), "demo"])
    assert result.returncode == 0, result.stdout
    assert "imu" not in result.stdout
    result = run([CHECK, "--root", str(repo), "nosuch"])
    assert result.returncode == 2
    assert "unknown module(s) nosuch; modules: demo, imu" in result.stdout


def test_help():
    result = run([CHECK, "--help"])
    assert result.returncode == 0
    assert "HAL board file" in result.stdout and "MODULE" in result.stdout


def test_every_real_module_agrees_or_is_skipped():
    """The repository's own boards: every module with a schematic must agree with its board file;
    modules without one are skipped with the reason, their board files still checked."""
    result = run([CHECK])
    assert result.returncode == 0, result.stdout
    modules = sorted(p.stem for p in (ROOT / "firmware" / "boards").glob("*.toml")
                     if 'module = "' in p.read_text())
    modules += [d.name for d in (ROOT / "hardware").iterdir() if d.is_dir() and d.name not in modules]
    for module in modules:
        assert (f"check-pins: {module}: ok" in result.stdout
                or f"check-pins: {module}: skipped: " in result.stdout), (module, result.stdout)
