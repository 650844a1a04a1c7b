"""The slot lead of each MCU, from its slot path measured under QEMU.

A node's slot timer fires `slot_lead_us` before each slot boundary, so that the HRT frame's
mailbox request lands at the boundary (docs/rtcan.md, "The slot lead"); a master's fires
`sync_lead_us` before each cycle's start, where its sync, loaded first in the tick, reaches its
mailbox. A lead is the shortest path at one cycle per instruction on the MCU's clock (no core
runs faster; flash wait states only add), rounded down: a frame never reaches its mailbox early. The emulator takes the
longest path, rounded up, from a board's tick to its frame's request. Both come from
r2p-node's `SlotPath` constants (firmware/crates/r2p-node/src/node/config.rs); this measures
the path again, built for each core, and says whether the constants still give the same leads.

    scripts/py -m r2ptools.slotlead      # exit 1 if a constant no longer matches the measurement
"""
from __future__ import annotations

import json
import math
import re
import sys
from dataclasses import dataclass

from . import ROOT, qemu

CONFIG_RS = ROOT / "firmware" / "crates" / "r2p-node" / "src" / "node" / "config.rs"

MCUS = {"STM32F103 (modules)": ("cortex-m3", "CORTEX_M3", 72_000_000),
        "STM32F407 (gateway)": ("cortex-m4", "CORTEX_M4", 168_000_000)}
"""Each MCU: its core, the prefix of r2p-node's constants of the paths built for that core
(`…_SLOT_PATH`, `…_SYNC_PATH`), its core clock (the board files' sysclk_hz)."""

PATHS = {"slot": "SLOT_PATH", "sync": "SYNC_PATH"}
"""Each path and its constant's suffix. The slot path runs from the compare interrupt to a
slot's HRT frame; the sync's, a slot-grid master's, from its call to its sync's request (the
sync goes first in its tick), to which the interrupt's ~190 instructions are added."""

IRQ_INSTRUCTIONS = 190
"""From the compare interrupt to the slot tick's call (the grid's slot path measures both)."""


@dataclass(frozen=True)
class Path:
    min_instructions: int
    max_instructions: int

    def lead_us(self, sysclk_hz: int) -> int:
        return self.min_instructions * 1_000_000 // sysclk_hz

    def longest_us(self, sysclk_hz: int) -> int:
        return math.ceil(self.max_instructions * 1_000_000 / sysclk_hz)


def constant(name: str) -> Path:
    """r2p-node's `SlotPath` constant `name`."""
    m = re.search(rf"pub const {name}: SlotPath =\s*SlotPath \{{\s*min_instructions: ([\d_]+),"
                  rf"\s*max_instructions: ([\d_]+)", CONFIG_RS.read_text())
    if not m:
        raise RuntimeError(f"no `pub const {name}: SlotPath = SlotPath {{ … }}` in {CONFIG_RS}")
    return Path(int(m.group(1).replace("_", "")), int(m.group(2).replace("_", "")))


def measure(cpu: str) -> dict[str, Path]:
    """The slot path from the compare interrupt to the HRT mailbox request and the master's path
    to its sync's, on `cpu` (400 slots, 400 cycles)."""
    outdir = qemu.build(profile="release", cpu=cpu, image="slot-path")
    rc, out = qemu.run_image(outdir / "slot-path", cpu)
    rows = [json.loads(l) for l in out.splitlines() if l.startswith("{")]
    if rc != 0 or not rows:
        raise RuntimeError(f"QEMU slot-path image on {cpu} failed (exit {rc}):\n{out}")
    r = rows[-1]
    return {"slot": Path(r["irq_to_request_min_insn"], r["irq_to_request_max_insn"]),
            "sync": Path(r["sync_min_insn"] + IRQ_INSTRUCTIONS, r["sync_max_insn"] + IRQ_INSTRUCTIONS)}


def main() -> int:
    ok = True
    print(f"{'MCU':<20} {'path':<5} {'(insn)':>12} {'measured':>12} {'clock':>8} {'lead':>6} {'emulated':>9}")
    for mcu, (cpu, prefix, hz) in MCUS.items():
        measured = measure(cpu)
        for path, suffix in PATHS.items():
            name = f"{prefix}_{suffix}"
            c, m = constant(name), measured[path]
            same = c.lead_us(hz) == m.lead_us(hz) and c.longest_us(hz) == m.longest_us(hz) \
                and c.min_instructions <= m.min_instructions
            ok &= same
            print(f"{mcu:<20} {path:<5} {c.min_instructions:>5}–{c.max_instructions:<6} {m.min_instructions:>5}–"
                  f"{m.max_instructions:<6} {hz // 1_000_000:>4} MHz {m.lead_us(hz):>3} µs {m.longest_us(hz):>6} µs"
                  f"{'' if same else f'  ← {name} gives {c.lead_us(hz)}/{c.longest_us(hz)} µs: measure it again'}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
