"""Whether two builds of a module image run the same slot path, instruction for instruction.

The slot path (docs/rtcan.md, "The slot lead") is the code from the slot timer's interrupt to
the HRT frame's mailbox request: the bus task (module-core's `bus`, `Node::slot_tick` inlined
into its poll) and the rtcan, rtcan-bxcan, r2p-node, middleware, executor and time functions it
calls. `MODULE_SLOT_LEAD_US` is measured on that code, so a change elsewhere in an image (a diet,
a new feature) must leave it alone. Addresses are normalised (branch targets by symbol or offset
in the function, literal addresses, `movw`/`movt` immediates), so moving code is no change.

    scripts/py -m r2ptools.slotpath OLD.elf NEW.elf     # exit 1 if a slot-path function changed
"""
from __future__ import annotations

import re
import subprocess
import sys

SLOT_PATH = ("rtcan", "r2p_node", "r2p_middleware", "r2p_msgs", "embassy_executor", "embassy_time",
             "_embassy_time", "embassy_stm32::time_driver", "module_core", "TIM2", "TIM4",
             "USB_LP_CAN1_RX0", "CAN1_RX1")
"""Demangled name prefixes (with or without a leading `<`) of the functions on the slot path."""
NOT_ON_IT = ("as r2p_module::endpoints::TopicNode>", "embassy_executor::arch::thread",
             "embassy_executor::raw::util::UninitCell")
"""Of those, what runs at boot or in thread mode: registering topics, the thread executor, spawning."""
BUS_TASK_CALLS = "rtcan::cycle::SlotClock"
"""The bus task is the executor task whose poll calls the node's slot clock."""


def functions(elf: str) -> dict[str, list[list[str]]]:
    """Every function's normalised instructions, by demangled name (a name may repeat)."""
    out = subprocess.run(["arm-none-eabi-objdump", "-d", "--no-show-raw-insn", "-C", elf],
                         capture_output=True, text=True, check=True).stdout
    funcs: dict[str, list[list[str]]] = {}
    name, start, body = None, 0, []
    for line in out.splitlines() + ["00000000 <end>:"]:
        m = re.match(r"^([0-9a-f]+) <(.*)>:$", line)
        if m:
            if name:
                funcs.setdefault(name, []).append(body)
            name, start, body = m.group(2), int(m.group(1), 16), []
            continue
        m = re.match(r"^\s+[0-9a-f]+:\s+(.*)$", line)
        if not (m and name):
            continue
        ins = m.group(1).split(";")[0].split("@")[0].strip()

        def target(t: re.Match, name: str = name, start: int = start) -> str:
            sym = t.group(2).split("+")[0]
            return f"<.+{int(t.group(1), 16) - start:#x}>" if sym == name else f"<{sym}>"
        ins = re.sub(r"\b([0-9a-f]{7,8}) <(.*)>$", target, ins)
        ins = re.sub(r"0x(08|20)[0-9a-f]{6}|\b(08|20)[0-9a-f]{6}\b", "ADDR", ins)
        if ins.startswith(("movw", "movt")):
            ins = re.sub(r"#.*", "#IMM", ins)
        body.append(ins)
    return funcs


def trimmed(body: list[str]) -> list[str]:
    """Without the padding after the last return or call that never returns (objdump shows the
    alignment half-word as an instruction)."""
    for i in range(len(body) - 1, -1, -1):
        if body[i].startswith(("bx\tlr", "pop", "b.", "b\t", "bl\t<core::", "udf", "ldmia.w\tsp!")):
            return body[:i + 1]
    return body


def on_path(name: str, bodies: list[list[str]]) -> list[list[str]]:
    if "TaskStorage" in name:
        return [b for b in bodies if any(BUS_TASK_CALLS in i for i in b)]
    if name.lstrip("<").startswith(SLOT_PATH) and not any(n in name for n in NOT_ON_IT):
        return bodies
    return []


def compare(old: str, new: str) -> tuple[int, int, list[str]]:
    """(slot-path functions identical, their instructions, what changed)."""
    a, b = functions(old), functions(new)
    same, insns, changed = 0, 0, []
    for name, bodies in sorted(a.items()):
        for body in on_path(name, bodies):
            if trimmed(body) in [trimmed(x) for x in b.get(name, [])]:
                same, insns = same + 1, insns + len(trimmed(body))
            else:
                changed.append(f"{name}: {len(body)} instructions, now "
                               f"{[len(x) for x in b.get(name, [])] or 'gone'}")
    return same, insns, changed


def main(argv: list[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else argv
    if len(args) != 2:
        print(__doc__.strip().splitlines()[-1].strip(), file=sys.stderr)
        return 2
    same, insns, changed = compare(*args)
    for c in changed:
        print("changed:", c)
    print(f"slot path: {same} functions identical ({insns} instructions), {len(changed)} changed")
    return 1 if changed else 0


if __name__ == "__main__":
    sys.exit(main())
