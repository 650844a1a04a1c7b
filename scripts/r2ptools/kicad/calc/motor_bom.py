"""The motor module's power-stage parts draft (hardware/motor/power-stage-bom.csv): its totals,
its agreement with the design calculation, and what JLCPCB would charge to assemble it.

Run `scripts/py -m r2ptools.kicad.calc.motor_bom`. The draft exists before the schematic, so it
is not a `bom/<module>.csv` (those are generated from schematics by `scripts/bom generate`): its
columns are a module BOM's plus the solder joints per part (no `.kicad_pcb` to count them from
yet) and where each figure comes from. `TBD` marks an LCSC number or MPN still to be looked up;
such parts are costed as JLC *extended* parts (the estimate errs high, as assembly_cost.py does).
"""
from __future__ import annotations

import csv
from dataclasses import dataclass
from decimal import Decimal
from pathlib import Path

from r2ptools.assembly_cost import load_fees

from . import motor

ROOT = Path(__file__).resolve().parents[4]
DRAFT = ROOT / "hardware/motor/power-stage-bom.csv"
FEES = ROOT / "bom/jlcpcb-fees.toml"
COLUMNS = ["references", "quantity", "value", "footprint", "mpn", "manufacturer", "lcsc",
           "unit_price_usd_qty10", "line_cost_usd", "smd_joints", "tht_joints", "source"]
OFF_BOARD = "-"               # footprint of a part that is bought but not assembled (heatsink)


@dataclass(frozen=True)
class Line:
    refs: tuple[str, ...]
    qty: int
    mpn: str
    lcsc: str
    unit: Decimal
    cost: Decimal
    smd: int
    tht: int
    footprint: str


def load(path: Path = DRAFT) -> tuple[list[Line], int, Decimal]:
    """The lines and the TOTAL line's quantity and cost; a malformed line names itself."""
    with path.open(newline="") as f:
        reader = csv.DictReader(f)
        if reader.fieldnames != COLUMNS:
            raise ValueError(f"{path}: columns {reader.fieldnames}, expected {COLUMNS}")
        lines, total = [], None
        for n, r in enumerate(reader, start=2):
            if r["references"] == "TOTAL":
                total = (int(r["quantity"]), Decimal(r["line_cost_usd"]))
                continue
            try:
                lines.append(Line(tuple(r["references"].split(",")), int(r["quantity"]), r["mpn"],
                                  r["lcsc"], Decimal(r["unit_price_usd_qty10"]),
                                  Decimal(r["line_cost_usd"]), int(r["smd_joints"]),
                                  int(r["tht_joints"]), r["footprint"]))
            except (ValueError, ArithmeticError) as e:
                raise ValueError(f"{path}:{n}: {e}: quantity, prices and joints must be numbers") from None
    if total is None:
        raise ValueError(f"{path}: no TOTAL line")
    return lines, total[0], total[1]


def problems(path: Path = DRAFT) -> list[str]:
    """Arithmetic and agreement with calc/motor.py; empty when the draft is consistent."""
    lines, qty, cost = load(path)
    out = []
    for ln in lines:
        if len(ln.refs) != ln.qty:
            out.append(f"{','.join(ln.refs)}: {len(ln.refs)} references, quantity {ln.qty}")
        if ln.unit * ln.qty != ln.cost:
            out.append(f"{','.join(ln.refs)}: {ln.qty} × {ln.unit} ≠ line cost {ln.cost}")
    refs = [r for ln in lines for r in ln.refs]
    if len(refs) != len(set(refs)):
        out.append(f"a reference appears twice: {sorted(r for r in set(refs) if refs.count(r) > 1)}")
    if qty != sum(ln.qty for ln in lines) or cost != sum(ln.cost for ln in lines):
        out.append(f"TOTAL {qty} parts {cost} USD; the lines add up to "
                   f"{sum(ln.qty for ln in lines)} parts {sum(ln.cost for ln in lines)} USD")
    by_mpn: dict[str, int] = {}
    for ln in lines:
        by_mpn[ln.mpn] = by_mpn.get(ln.mpn, 0) + ln.qty
    v = motor.DESIGN_VALUES
    for mpn, want in ((motor.FET, 4), (motor.DRV, 1), (motor.HALL, 1), (motor.TVS_MPN, 1),
                      (motor.CER, v["N_CER"])):
        if by_mpn.get(mpn, 0) != want:
            out.append(f"calc/motor.py designs with {want} × {mpn}; the draft has {by_mpn.get(mpn, 0)}")
    bulk = sum(ln.qty for ln in lines if ln.footprint.startswith("Capacitor_THT:CP_Radial"))
    if bulk != v["N_BULK"]:
        out.append(f"calc/motor.py designs with {v['N_BULK']} bulk electrolytics; the draft has {bulk}")
    return out


def assembled_cost(boards: int = 10) -> dict[str, Decimal]:
    """Per board, for an order of `boards`: parts, and JLC economic PCBA fees for the assembled
    ones (setup and stencil shared, every TBD or non-basic part paying the loading fee)."""
    lines, _, parts = load()
    fees = load_fees(FEES, str(FEES))
    on_board = [ln for ln in lines if ln.footprint != OFF_BOARD]
    smd = sum(ln.smd * ln.qty for ln in on_board)
    tht = sum(ln.tht * ln.qty for ln in on_board)
    extended = {ln.lcsc if ln.lcsc != "TBD" else ln.mpn if ln.mpn != "TBD" else ln.refs[0]
                for ln in on_board if ln.lcsc not in fees.basic}
    per_order = (fees.economic["setup"] + fees.economic["stencil"]
                 + fees.any["extended_part_loading"] * len(extended)
                 + (fees.any["hand_soldering_labour"] if tht else 0))
    per_board = smd * fees.economic["smt_joint"] + tht * fees.any["tht_joint"]
    return {"parts": parts, "assembly": per_board + per_order / boards,
            "extended parts": Decimal(len(extended)), "smd joints": Decimal(smd),
            "tht joints": Decimal(tht)}


def main() -> int:
    bad = problems()
    for p in bad:
        print(f"FAIL  {p}")
    for boards in (10, 100):
        c = assembled_cost(boards)
        print(f"power stage, {boards} boards: parts {c['parts']:.2f} USD + assembly "
              f"{c['assembly']:.2f} USD per board ({int(c['smd joints'])} SMD and {int(c['tht joints'])} "
              f"THT joints, {int(c['extended parts'])} extended parts' loading fees per order)")
    print("estimates: prices and LCSC numbers marked TBD/estimate in the draft's source column")
    return 1 if bad else 0


if __name__ == "__main__":
    raise SystemExit(main())
