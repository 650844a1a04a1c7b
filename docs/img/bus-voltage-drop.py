"""Voltage along an R2P bus chain (docs/bus.md, "Power budget"): writes bus-voltage-drop.png
beside this file and prints the scenario table the document quotes.

    scripts/py docs/img/bus-voltage-drop.py

The model is DC and resistive: each hop between two neighbours is one patch cord (3 conductors
per rail in parallel), two mated RJ45 contacts per conductor (one at each end of the cord) and,
after the first hop, the pass-through copper of the module it crosses; both rails (+5V and GND)
drop. Every module draws its current at its jack. The PNG is byte-for-byte reproducible
(r2ptools.pictures: matplotlib's default style and own fonts, no timestamp or software tag);
tests/test_pictures.py draws it again and compares the bytes.
"""
from __future__ import annotations

from pathlib import Path

from r2ptools import pictures

PNG = Path(__file__).with_suffix(".png")

# Worst-case values (docs/bus.md, "Power budget").
CONDUCTOR_OHM_PER_M = 0.0938   # 24 AWG, TIA-568 maximum DC resistance 9.38 ohm / 100 m
CONTACT_OHM = 0.020            # one mated RJ45 contact (plug in jack), datasheet maximum
PASS_THROUGH_OHM = 0.005       # module copper from BUS IN to BUS OUT, per rail (spec maximum)
CONDUCTORS = 3                 # per rail: +5V on pins 4, 5, 7; GND on 3, 6, 8
V_PSU = 4.90                   # 5.00 V - 2 % regulation tolerance
V_MIN = 4.00                   # lowest bus voltage a module must accept
HOP_M = 0.10                   # 20 hops over 2 m
MODULE_A = 0.200


def hop_ohm(length_m: float, first: bool) -> float:
    """Resistance of one rail over one hop."""
    cable = CONDUCTOR_OHM_PER_M * length_m / CONDUCTORS
    contacts = 2 * CONTACT_OHM / CONDUCTORS
    return cable + contacts + (0.0 if first else PASS_THROUGH_OHM)


def branch(n: int, amps: float = MODULE_A, hop_m: float = HOP_M) -> list[float]:
    """Voltages at the PSU and then at each of `n` modules fed in a line from it."""
    volts = [V_PSU]
    for k in range(1, n + 1):
        through = (n - k + 1) * amps      # hop k carries the current of every module beyond it
        volts.append(volts[-1] - 2 * hop_ohm(hop_m, k == 1) * through)
    return volts


def scenarios() -> list[tuple[str, list[float], list[float], float]]:
    """(label, positions in m, voltages, largest current per conductor in A)."""
    out = []
    for n in (20, 14):
        v = branch(n)
        out.append((f"PSU at one end, {n} modules × 200 mA", [i * HOP_M for i in range(n + 1)], v,
                    n * MODULE_A / CONDUCTORS))
    half = branch(10)
    xs = [1.0 - i * HOP_M for i in range(11)][::-1] + [1.0 + i * HOP_M for i in range(1, 11)]
    out.append(("PSU in the middle, 20 modules × 200 mA", xs, half[::-1] + half[1:],
                10 * MODULE_A / CONDUCTORS))
    lumped = V_PSU - 2 * (CONDUCTOR_OHM_PER_M * 2.0 / CONDUCTORS + 2 * CONTACT_OHM / CONDUCTORS) * 4.0
    out.append(("4 A at the far end of one 2 m cord", [0.0, 2.0], [V_PSU, lumped], 4.0 / CONDUCTORS))
    return out


def main(out: Path = PNG) -> Path:
    """Prints the scenario table and draws the plot to `out`."""
    with pictures.style(**{"font.family": "DejaVu Sans", "font.size": 9}) as plt:
        fig, ax = plt.subplots(figsize=(7.0, 3.6), dpi=120)
        styles = ["-o", "-s", "-^", "--"]
        print("| configuration | lowest module voltage | drop | largest current per conductor |")
        print("|---|---:|---:|---:|")
        for (label, xs, vs, amps), style in zip(scenarios(), styles):
            ax.plot(xs, vs, style, markersize=3, linewidth=1.2, label=label)
            low = min(vs)
            print(f"| {label} | {low:.2f} V | {V_PSU - low:.2f} V | {amps:.2f} A |")
        ax.axhline(V_MIN, color="black", linewidth=0.8, linestyle=":")
        ax.text(1.55, V_MIN + 0.03, "module minimum: 4.00 V", fontsize=8)
        ax.set_xlabel("position along the chain (m of patch cord, 0.1 m between neighbours)")
        ax.set_ylabel("+5V − GND at the module (V)")
        ax.set_title("R2P bus voltage, worst case (PSU 4.90 V, 24 AWG, 20 mΩ contacts)")
        ax.set_xlim(0, 2.0)
        ax.set_ylim(2.9, 5.0)
        ax.grid(True, linewidth=0.3)
        ax.legend(loc="lower left", fontsize=8)
        fig.tight_layout()
        return pictures.save(fig, out)


if __name__ == "__main__":
    main()
