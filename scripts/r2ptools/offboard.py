"""A module's off-board parts: what is bought for it but not placed by the board assembler.

A heatsink, its gap pad, the screws and insulating washers that clamp them are part of what a
module costs and of a robot's order, but they are not on the schematic (bom/<module>.csv is the
board's BOM, generated from it) and JLCPCB does not place them. Each module that needs such parts
keeps them, by hand, in `hardware/<module>/off-board.csv`, one row per part with where every
figure came from; `scripts/bom generate` (bom.py) folds them into `bom/<module>-off-board.csv`,
the module's cost with them, and the robots' orders.

Columns (`COLUMNS`), every field filled in:

| column | content |
|---|---|
| `item` | a short name for the part in the module's assembly, unique in the file (e.g. `HS101`) |
| `quantity` | how many one module needs, a whole number |
| `description` | what it is and what it is for |
| `mpn`, `manufacturer` | the manufacturer's part number and name (for a standard fastener, its standard designation and `any`) |
| `distributor`, `distributor_pn` | where to order it and its number there (`-`: order by the MPN) |
| `unit_price_usd_qty10` | unit price in USD at 10, as bom/parts.csv's (an upper bound where only a single-unit price was seen) |
| `source` | where the MPN, the figures and the price come from; `NOT VERIFIED` where a datasheet was not read |
"""
from __future__ import annotations

import csv
import re
from dataclasses import dataclass
from decimal import Decimal, InvalidOperation
from pathlib import Path

COLUMNS = ("item", "quantity", "description", "mpn", "manufacturer", "distributor", "distributor_pn",
           "unit_price_usd_qty10", "source")
FILE = "off-board.csv"
PACKAGE = "off-board"         # the robot BOM's package column for these parts
NOT_AT_LCSC = "-"


@dataclass(frozen=True)
class Part:
    """One row of a module's off-board table."""
    line: int
    item: str
    quantity: int
    description: str
    mpn: str
    manufacturer: str
    distributor: str
    distributor_pn: str
    price: Decimal
    source: str

    @property
    def cost(self) -> Decimal:
        return self.price * self.quantity


def path(root: Path, module: str) -> Path:
    return root / "hardware" / module / FILE


def _problems(row: dict[str, str]) -> list[str]:
    out = [f"no {c}: fill it in (hardware/<module>/{FILE} columns: bom/README.md)"
           for c in COLUMNS if not (row.get(c) or "").strip()]
    qty = (row.get("quantity") or "").strip()
    if qty and not re.fullmatch(r"[1-9]\d*", qty):
        out.append(f"quantity {qty!r} is not a positive whole number: give how many one module needs")
    price = (row.get("unit_price_usd_qty10") or "").strip()
    if price:
        try:
            if not Decimal(price) > 0:
                raise InvalidOperation
        except InvalidOperation:
            out.append(f"unit_price_usd_qty10 {price!r} is not a positive price in USD (e.g. 11.85)")
    return out


def load(file: Path, where: str, board_mpns: set[str] = frozenset()) -> tuple[list[Part], list[str]]:
    """The parts of one off-board table and its errors, each as `file:line: item: what, what to
    do`. An MPN that is also a board part (`board_mpns`, bom/parts.csv) is refused: it would merge
    with the board's line in a robot's order."""
    try:
        text = file.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as e:
        return [], [f"{where}: cannot read: {e}"]
    reader = csv.DictReader(text.splitlines())
    if tuple(reader.fieldnames or ()) != COLUMNS:
        return [], [f"{where}: the header must be exactly {','.join(COLUMNS)} "
                    f"(found {','.join(reader.fieldnames or []) or 'nothing'})"]
    parts: list[Part] = []
    errors: list[str] = []
    seen: dict[str, int] = {}
    mpns: dict[str, int] = {}
    for row in reader:
        line = reader.line_num
        if None in row:
            errors.append(f"{where}:{line}: more fields than the header's {len(COLUMNS)}: quote a "
                          "field that holds a comma")
            continue
        item = (row.get("item") or "").strip()
        name = item or "(row without item)"
        problems = _problems(row)
        mpn = (row.get("mpn") or "").strip()
        if item and item in seen:
            problems.append(f"is already on line {seen[item]}: one row per item")
        if mpn and mpn in mpns:
            problems.append(f"MPN {mpn} is already on line {mpns[mpn]}: one row per part, with its "
                            "total quantity")
        if mpn in board_mpns:
            problems.append(f"MPN {mpn} is a board part (bom/parts.csv): put it on the schematic, "
                            "not here")
        errors += [f"{where}:{line}: {name}: {p}" for p in problems]
        seen.setdefault(item, line)
        mpns.setdefault(mpn, line)
        if problems:
            continue
        f = {k: (v or "").strip() for k, v in row.items()}
        parts.append(Part(line, item, int(f["quantity"]), f["description"], f["mpn"],
                          f["manufacturer"], f["distributor"], f["distributor_pn"],
                          Decimal(f["unit_price_usd_qty10"]), f["source"]))
    if not parts and not errors:
        errors.append(f"{where}: no parts: delete the file if the module needs none")
    return parts, errors
