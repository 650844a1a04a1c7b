"""What an assembled module costs at JLCPCB: parts plus the assembly fees, per board, at 10 and 100.

A parts total hides what decides an assembled board's price at small quantities: the per-order
setup and stencil, a loading fee for every distinct *extended* part, hand soldering for
through-hole parts, and a second (standard-PCBA) setup when SMD parts sit on the back. This
module counts those from the board itself and prices them with `bom/jlcpcb-fees.toml`:

- joints from the `.kicad_pcb`: every SMD pad of an SMD footprint (a thermal via drawn as a
  plated pad inside an exposed pad is copper, not a joint), every plated through-hole pad of a
  through-hole footprint; parts taken from the BOM lines (DNP and non-BOM footprints such as test
  pads and fiducials cost nothing);
- the side from the footprint's layer: any SMD joint on B.Cu makes the order a two-sided
  standard PCBA (setup and stencil per side), otherwise economic PCBA;
- parts at the quantity-10 unit price of `parts.csv` for both quantities (an upper bound at 100).

PCB fabrication and shipping are not included.
"""
from __future__ import annotations

import tomllib
from dataclasses import dataclass
from decimal import Decimal
from pathlib import Path

from .kicad import sexpr

QUANTITIES = (10, 100)
FEE_KEYS = {
    "economic": ("setup", "stencil", "smt_joint"),
    "standard": ("setup_per_side", "stencil_per_side", "smt_joint"),
    "any": ("extended_part_loading", "hand_soldering_labour", "tht_joint"),
}


class FeeError(ValueError):
    """bom/jlcpcb-fees.toml is malformed; the message names the key and the fix."""


@dataclass(frozen=True)
class Fees:
    economic: dict[str, Decimal]
    standard: dict[str, Decimal]
    any: dict[str, Decimal]
    basic: frozenset[str]
    checked: str


def load_fees(path: Path, where: str) -> Fees:
    try:
        data = tomllib.loads(path.read_text())
    except (OSError, tomllib.TOMLDecodeError) as e:
        raise FeeError(f"{where}: cannot read: {e}") from None
    fees = data.get("fees", {})
    tables = {}
    for table, keys in FEE_KEYS.items():
        t = fees.get(table)
        if not isinstance(t, dict):
            raise FeeError(f"{where}: missing table [fees.{table}] with {', '.join(keys)}")
        values = {}
        for k in keys:
            v = t.get(k)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or v < 0:
                raise FeeError(f"{where}: [fees.{table}] {k} = {v!r}: give a fee in USD, e.g. 8.00")
            values[k] = Decimal(str(v))
        tables[table] = values
    basic = data.get("basic", {}).get("lcsc", [])
    if not isinstance(basic, list) or not all(isinstance(x, str) and x[:1] == "C" for x in basic):
        raise FeeError(f"{where}: [basic] lcsc must be a list of LCSC numbers such as \"C25804\"")
    if not isinstance(fees.get("checked"), str):
        raise FeeError(f"{where}: [fees] checked = \"YYYY-MM\" (when the fees were last read) is missing")
    return Fees(tables["economic"], tables["standard"], tables["any"], frozenset(basic),
                fees["checked"])


@dataclass(frozen=True)
class Joints:
    """One footprint's solder joints and the side it sits on."""
    smd: int
    tht: int
    bottom: bool


def board_joints(pcb: Path) -> dict[str, Joints]:
    """Joints per reference designator, read from a `.kicad_pcb`."""
    out = {}
    for fp in sexpr.find_all(sexpr.parse(pcb.read_text()), "footprint"):
        ref = next((p[2] for p in sexpr.find_all(fp, "property") if p[1] == "Reference"), None)
        attr = sexpr.find(fp, "attr") or []
        layer = sexpr.find(fp, "layer")
        smd_fp = "smd" in attr
        smd = tht = 0
        for pad in sexpr.find_all(fp, "pad"):
            kind = pad[2]
            if kind == "smd":
                smd += 1
            elif kind == "thru_hole" and not smd_fp:
                tht += 1
        if ref is not None:
            out[str(ref)] = Joints(smd, tht, bool(layer) and layer[1] == "B.Cu")
    return out


@dataclass(frozen=True)
class Line:
    """A BOM line as costing needs it."""
    refs: tuple[str, ...]
    lcsc: str
    unit_price: Decimal


@dataclass(frozen=True)
class Estimate:
    boards: int
    kind: str                     # "economic" or "standard (two sides)"
    parts: Decimal
    setup: Decimal
    stencil: Decimal
    loading: Decimal
    smt: Decimal
    tht: Decimal
    extended: int
    smd_joints: int
    tht_joints: int

    @property
    def total(self) -> Decimal:
        return self.parts + self.setup + self.stencil + self.loading + self.smt + self.tht

    @property
    def per_board(self) -> Decimal:
        return self.total / self.boards


def estimate(lines: list[Line], joints: dict[str, Joints], fees: Fees, boards: int) -> Estimate:
    """The order of `boards` assembled boards. A BOM reference with no footprint on the board is
    an error the caller reports (schematic and board out of step)."""
    refs = [r for line in lines for r in line.refs]
    missing = [r for r in refs if r not in joints]
    if missing:
        raise KeyError(f"no footprint on the board for {', '.join(missing)}: update the PCB from "
                       f"the schematic")
    smd = sum(joints[r].smd for r in refs)
    tht = sum(joints[r].tht for r in refs)
    two_sided = any(joints[r].bottom and joints[r].smd for r in refs)
    extended = len({l.lcsc for l in lines if l.lcsc not in fees.basic})
    n = Decimal(boards)
    if two_sided:
        sides = Decimal(2)
        setup, stencil = fees.standard["setup_per_side"] * sides, fees.standard["stencil_per_side"] * sides
        smt, kind = fees.standard["smt_joint"] * smd * n, "standard (two sides)"
    else:
        setup, stencil = fees.economic["setup"], fees.economic["stencil"]
        smt, kind = fees.economic["smt_joint"] * smd * n, "economic"
    tht_cost = (fees.any["hand_soldering_labour"] + fees.any["tht_joint"] * tht * n) if tht else Decimal(0)
    parts = sum((l.unit_price * len(l.refs) for l in lines), Decimal(0)) * n
    return Estimate(boards, kind, parts, setup, stencil, fees.any["extended_part_loading"] * extended,
                    smt, tht_cost, extended, smd, tht)


if __name__ == "__main__":
    import sys
    print("r2ptools.assembly_cost is the library behind bom/README.md's assembled-cost table; "
          "regenerate the table with: scripts/bom generate  (check it with: scripts/bom check)",
          file=sys.stderr)
    sys.exit(2)
