"""Each MCU's slot lead matches its slot path measured under QEMU (scripts/r2ptools/slotlead.py):
a lead longer than the shortest path puts HRT frames in their mailbox before their boundary, a
shorter one sends them late; the emulator's path is the longest."""
import functools
import json
import re

import pytest

from r2ptools import qemu, slotlead


@pytest.fixture(scope="module")
def measured(monkeypatch_module):
    """Measures each core's path once for the module's tests."""
    m = functools.cache(slotlead.measure)
    monkeypatch_module.setattr(slotlead, "measure", m)
    return m


@pytest.fixture(scope="module")
def monkeypatch_module():
    with pytest.MonkeyPatch.context() as mp:
        yield mp


def test_the_constants_give_the_measured_leads(measured, capsys):
    assert slotlead.main() == 0, capsys.readouterr().out
    out = capsys.readouterr().out
    assert "STM32F103 (modules)  slot" in out and " 72 MHz  25 µs     27 µs" in out
    assert "STM32F407 (gateway)  slot" in out and "168 MHz  10 µs     12 µs" in out
    # The master's sync, loaded first in its tick: 9 µs at 72 MHz, 4 µs at 168 MHz.
    assert " 72 MHz   9 µs     10 µs" in out and "168 MHz   4 µs      5 µs" in out, out


def test_the_f407_path_is_measured_on_its_own_core(measured):
    m3, m4 = measured("cortex-m3")["slot"], measured("cortex-m4")["slot"]
    # The same source built for another core: not the same image, a few instructions apart
    # (equal counts happen: the paths differ by a handful of instructions either way).
    image = lambda cpu: (qemu.WORKSPACE / "target" / qemu.CORES[cpu] / "release" / "slot-path").read_bytes()
    assert image("cortex-m3") != image("cortex-m4")
    assert abs(m3.min_instructions - m4.min_instructions) < 50


def test_the_grid_master_requests_its_sync_first(measured):
    """A slot-grid master loads its sync before it takes its received frames and runs its
    timers (r2p-node's `send_sync` at step 2): its path is short and steady, so every cycle
    starts where the master times it. Loaded after them, the sync was requested 704–3 038
    instructions after the call, from 12 µs early to 20 µs late at 72 MHz, by a different amount
    each cycle (docs/rtcan.md, "The sync lead")."""
    for cpu in ("cortex-m3", "cortex-m4"):
        sync, slot = measured(cpu)["sync"], measured(cpu)["slot"]
        assert sync.max_instructions - sync.min_instructions < 50, (cpu, sync)
        assert sync.max_instructions < slot.min_instructions - 1_000, (cpu, sync, slot)


def test_a_stale_constant_is_caught_with_what_to_do(measured, tmp_path, monkeypatch, capsys):
    src = slotlead.CONFIG_RS.read_text()
    # The M4 path's shortest as 4 600 instructions: 27 µs at 168 MHz, the F103's old lead.
    stale, n = re.subn(r"(pub const CORTEX_M4_SLOT_PATH: SlotPath =\s*SlotPath \{ min_instructions: )[\d_]+",
                       r"\g<1>4_600", src)
    assert n == 1
    (tmp_path / "config.rs").write_text(stale)
    monkeypatch.setattr(slotlead, "CONFIG_RS", tmp_path / "config.rs")
    assert slotlead.main() == 1
    assert "CORTEX_M4_SLOT_PATH gives 27/12 µs: measure it again" in capsys.readouterr().out


def test_a_missing_constant_is_named():
    with pytest.raises(RuntimeError, match="no `pub const CORTEX_M7_SLOT_PATH: SlotPath"):
        slotlead.constant("CORTEX_M7_SLOT_PATH")


def framed_slot_path(feature: str) -> dict:
    """The slot-path bench's frame-sized row, built with the QEMU workspace's `feature`
    (`framed`, `staged`); the grid's image is built again after."""
    out = qemu.build(profile="release", cpu="cortex-m3", image="slot-path", features=(feature,))
    try:
        rc, text = qemu.run_image(out / "slot-path", "cortex-m3")
    finally:
        qemu.build(profile="release", cpu="cortex-m3", image="slot-path")  # the grid's again
    rows = [json.loads(l) for l in text.splitlines() if l.startswith("{")]
    assert rc == 0 and rows and rows[-1]["bench"] == "framed_slot_path", text
    return rows[-1]


def test_the_frame_sized_path_requests_the_hrt_frame_first():
    """On frame-sized reservations the HRT frame and the master's sync are requested before
    the node takes its received frames and runs its timers (r2p-node's `send_sync` and
    `framed_first`): their
    paths are short and nearly constant, where a heartbeat handled first would start an HRT
    frame 5 µs late every fifth cycle, more than a reservation's guard bits, and the sync up to
    33 µs late (docs/rtcan.md, "The slot path in them"). Each has its own lead, which r2p-node's
    constants give."""
    r = framed_slot_path("framed")
    assert r["hrt_requests"] >= 390
    # 1 179–1 189 measured, the sync 524–534; the grid's path is 1 639–1 739 in the same harness.
    assert r["to_request_max_insn"] - r["to_request_min_insn"] < 50, r
    assert r["sync_requests"] >= 390 and r["sync_max_insn"] - r["sync_min_insn"] < 50, r
    assert r["to_request_max_insn"] < slotlead.constant("CORTEX_M3_SLOT_PATH").min_instructions - slotlead.IRQ_INSTRUCTIONS, r
    # r2p-node's constants for both (the leads `MODULE_FRAMED_LEADS`, the emulator's latencies)
    # are the bench's, from the interrupt (~190 more): the same leads and emulated paths at
    # 72 MHz, and never a lead longer than the path.
    for name, key in (("CORTEX_M3_FRAMED_SLOT_PATH", "to_request"), ("CORTEX_M3_FRAMED_SYNC_PATH", "sync")):
        c = slotlead.constant(name)
        irq = slotlead.IRQ_INSTRUCTIONS
        m = slotlead.Path(r[f"{key}_min_insn"] + irq, r[f"{key}_max_insn"] + irq)
        assert c.min_instructions <= m.min_instructions, (name, c, m)
        assert (c.lead_us(72_000_000), c.longest_us(72_000_000)) == \
            (m.lead_us(72_000_000), m.longest_us(72_000_000)), (name, c, m)
    # The short path (`Node::top_up`) after a transmit-complete or a publish: shorter than a
    # whole slot tick's path to a window's frame, which also takes frames and runs timers.
    assert r["queued_requests"] > 100 and r["top_up_transmit_requests"] > 100, r
    assert r["top_up_transmit_min_insn"] < r["queued_min_insn"] - 500, r
    # r2p-node's constant for it (the emulator's latency) is the bench's, from the interrupt
    # (~190 more).
    path = slotlead.constant("CORTEX_M3_TOP_UP_PATH")
    assert abs(path.min_instructions - (r["top_up_transmit_min_insn"] + slotlead.IRQ_INSTRUCTIONS)) < 50, r
    assert abs(path.max_instructions - (r["top_up_transmit_max_insn"] + slotlead.IRQ_INSTRUCTIONS)) < 300, r
    # The load bench's what-if waits this long from a wake to a node's next SRT/NRT frame: not
    # less than the shortest such path measured here, from the interrupt, at 72 MHz.
    src = (slotlead.ROOT / "firmware/host/loadbench/src/rtcan_node.rs").read_text()
    for name, key in (("TRANSMIT", "top_up_transmit"), ("RELEASE", "top_up_publish")):
        reaction_us = int(re.search(rf"pub const {name}_REACTION_US: Micros = (\d+);", src).group(1))
        shortest = (r[f"{key}_min_insn"] + slotlead.IRQ_INSTRUCTIONS) / 72
        assert shortest <= reaction_us < shortest + 1, (name, r)


def test_staged_reloads_have_their_own_measured_paths_and_leads():
    """With staged reloads (r2p-node's `staged-reloads`) the node stages what it cannot load,
    hands it to the transmit interrupt, and takes that interrupt's loads first in each call: a
    few instructions more on every frame-sized path, which move the master's sync lead at
    72 MHz from 9 to 10 µs. r2p-node's `CORTEX_M3_STAGED_*` constants (the leads and the
    emulator's paths of a build with the feature, `CORTEX_M3_FRAMED_PATHS`) are the bench's."""
    r = framed_slot_path("staged")
    irq = slotlead.IRQ_INSTRUCTIONS
    for name, key in (("CORTEX_M3_STAGED_SLOT_PATH", "to_request"),
                      ("CORTEX_M3_STAGED_SYNC_PATH", "sync"),
                      ("CORTEX_M3_STAGED_TOP_UP_PATH", "top_up_transmit")):
        c = slotlead.constant(name)
        m = slotlead.Path(r[f"{key}_min_insn"] + irq, r[f"{key}_max_insn"] + irq)
        assert c == m, (name, c, m, "set the constant in firmware/crates/r2p-node/src/node/config.rs")
    staged = slotlead.constant("CORTEX_M3_STAGED_SYNC_PATH")
    framed = slotlead.constant("CORTEX_M3_FRAMED_SYNC_PATH")
    assert (framed.lead_us(72_000_000), staged.lead_us(72_000_000)) == (9, 10)
    assert slotlead.constant("CORTEX_M3_STAGED_SLOT_PATH").lead_us(72_000_000) == 19
