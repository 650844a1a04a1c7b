"""`make bench`: speed and size of the firmware core, as numbers and ratios against a baseline
measured in the same run (never pass/fail on timing: that is what tests are not for).

1. Cortex-M3 instructions per publish → deliver → release round trip, 1–8 subscribers, R2P
   middleware vs embassy-sync's PubSubChannel, under QEMU with -icount (deterministic: the same
   binary gives the same counts). Plotted to docs/img/bench-pubsub-cortex-m3.png.
2. The same round trip on the host, messages per second (varies with the machine).
3. Footprint of the core images (flash and static RAM) against their budgets.
"""
from __future__ import annotations

import json
import subprocess
import sys

from . import ROOT, firmware, qemu

PLOT = ROOT / "docs" / "img" / "bench-pubsub-cortex-m3.png"
# The paper's figure for the original middleware on a 72 MHz Cortex-M3, one subscriber:
# 86 600 msg/s ≈ 830 cycles per message.
PAPER_CYCLES_1_SUB = 72_000_000 / 86_600
TARGET_INSN_1_SUB = 400
FOOTPRINT_GOAL = (24 * 1024, 6 * 1024)  # RTCAN + middleware + executor on the STM32F103


def json_lines(text: str) -> list[dict]:
    return [json.loads(l) for l in text.splitlines() if l.startswith("{")]


def cortex_m3() -> list[dict]:
    outdir = qemu.build(profile="release")
    rc, out = qemu.run_image(outdir / "bench")
    if rc != 0:
        raise RuntimeError(f"QEMU bench image failed (exit {rc}):\n{out}")
    return [r for r in json_lines(out) if r["bench"] == "cortex_m3_pubsub"]


def host() -> list[dict]:
    p = subprocess.run(["cargo", "run", "-q", "--release", "--locked", "-p", "r2p-bench-host"],
                       cwd=ROOT / "firmware", capture_output=True, text=True, check=True)
    return json_lines(p.stdout)


def plot(rows: list[dict]) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    plt.rcParams["svg.hashsalt"] = "r2p"
    n = [r["subscribers"] for r in rows]
    fig, ax = plt.subplots(figsize=(6.4, 3.6), dpi=100)
    ax.plot(n, [r["r2p_insn_per_msg"] for r in rows], "o-", label="R2P middleware (zero copy)")
    ax.plot(n, [r["embassy_sync_insn_per_msg"] for r in rows], "s-", label="embassy-sync PubSubChannel")
    ax.axhline(PAPER_CYCLES_1_SUB, color="grey", ls=":", label="original R2P, 1 subscriber (cycles)")
    ax.axhline(TARGET_INSN_1_SUB, color="red", ls="--", lw=0.8, label="target, 1 subscriber")
    ax.set_xlabel("subscribers")
    ax.set_ylabel("instructions per message")
    ax.set_title("publish → deliver → release on a Cortex-M3 (QEMU -icount)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    PLOT.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(PLOT, metadata={"Software": None})
    plt.close(fig)


def main() -> int:
    try:
        m3 = cortex_m3()
        hs = host()
    except (RuntimeError, subprocess.CalledProcessError) as e:
        print(f"bench: {e}", file=sys.stderr)
        return 1

    print("\n=== Cortex-M3 (QEMU, -icount): instructions per message, lower is better")
    print(f"{'subscribers':>11} {'R2P':>7} {'embassy-sync':>13} {'ratio':>6}")
    for r in m3:
        a, b = r["r2p_insn_per_msg"], r["embassy_sync_insn_per_msg"]
        print(f"{r['subscribers']:>11} {a:>7} {b:>13} {a / b:>6.2f}")
    slope = (m3[-1]["r2p_insn_per_msg"] - m3[0]["r2p_insn_per_msg"]) / (len(m3) - 1)
    one = m3[0]["r2p_insn_per_msg"]
    print(f"one subscriber: {one} instructions (target ≤ {TARGET_INSN_1_SUB}; the original R2P: "
          f"≈{PAPER_CYCLES_1_SUB:.0f} cycles); each extra subscriber: +{slope:.0f} (linear)")
    print(f"at 72 MHz and one instruction per cycle (an upper bound) that is "
          f"{72e6 / one:,.0f} msg/s vs the paper's 86,600")

    print("\n=== host: messages per second, higher is better (this machine, median of 7)")
    print(f"{'subscribers':>11} {'R2P':>12} {'embassy-sync':>13} {'ratio':>6}")
    for r in hs:
        a, b = r["r2p_msgs_per_s"], r["embassy_sync_msgs_per_s"]
        print(f"{r['subscribers']:>11} {a:>12,} {b:>13,} {a / b:>6.2f}")

    print("\n=== footprint of the core images (firmware/images, built by make firmware)")
    rows = []
    for img in firmware.manifest():
        if img.name.startswith("footprint"):
            elf = ROOT / firmware.IMAGES_DIR / f"{img.name}.elf"
            rows.append((img, firmware.size_of(elf) if elf.exists() else None))
    print(firmware.table(rows))
    print(f"goal for the F103 core: ≤ {FOOTPRINT_GOAL[0] // 1024} KiB flash, ≤ {FOOTPRINT_GOAL[1] // 1024} KiB static RAM")

    plot(m3)
    print(f"\nplot: {PLOT.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
