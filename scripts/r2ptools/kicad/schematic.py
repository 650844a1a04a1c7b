"""Writes a module's schematic (KiCad 9 `.kicad_sch`) from its description: label-per-pin.

Every symbol is placed on a grid and every connected pin gets a label right on its connection
point: a global label for the board-wide nets (GND, +3V3, +5V), a hierarchical label for a net
that leaves the sheet, a local label otherwise; unconnected pins get a no-connect flag. There are
no wires to get wrong, the netlist is exactly the description, and ERC checks every pin type.
Identifiers (UUIDs) are derived from names, so the same description gives the same bytes.

A shared sheet (the common core) is one file used by several projects: KiCad keeps each project's
reference designators inside that file (`instances`), so it is written once with every project
that uses it.
"""
from __future__ import annotations

import uuid
from dataclasses import dataclass
from pathlib import Path

from . import catalog, libsym, sexpr
from .design import GLOBAL_NETS, Part, Sheet
from .sexpr import Q

NS = uuid.UUID("6f1d3c52-6d0c-4c1e-9a0e-1c2b2f0a5e11")
GRID = 2.54
FONT = ["effects", ["font", ["size", "1.27", "1.27"]]]
SCH_VERSION = "20250114"


def uid(*parts: str) -> str:
    return str(uuid.uuid5(NS, "/".join(parts)))


def snap(v: float) -> float:
    return round(v / GRID) * GRID


@dataclass
class Instance:
    """One use of a sheet file by a project: the project name and the sheet path of the use."""
    project: str
    path: str        # "/<root uuid>" or "/<root uuid>/<sheet uuid>"


def _prop(key: str, value: str, x: float, y: float, hide: bool, justify: str | None = None) -> list:
    eff = ["effects", ["font", ["size", "1.27", "1.27"]]]
    if justify:
        eff.append(["justify", justify])
    if hide:
        eff.append(["hide", "yes"])
    return ["property", Q(key), Q(value), ["at", sexpr.num(x), sexpr.num(y), "0"], eff]


def part_fields(part: Part) -> tuple[dict[str, str], bool]:
    """A part's symbol fields (from bom/parts.csv) and whether it is on the BOM: a test pad is on
    the board, off the BOM, with no part fields."""
    it = part.item
    if not it.on_bom:
        return {"Footprint": it.footprint, "Datasheet": "~",
                "Description": "bare copper test pad (no part)"}, False
    row = it.row
    return {"Footprint": it.footprint, "Datasheet": row["Datasheet"] or "~",
            "Description": row["Description"], "MPN": it.mpn,
            "Manufacturer": row["Manufacturer"], "LCSC": row["LCSC"]}, True


def _extent(lib_id: str) -> tuple[float, float, float, float]:
    """Pin extent in schematic coordinates relative to the symbol origin: x0, y0, x1, y1."""
    ps = libsym.pins(lib_id)
    xs = [p.x for p in ps] or [0.0]
    ys = [-p.y for p in ps] or [0.0]
    return min(xs), min(ys), max(xs), max(ys)


def _label_len(net: str) -> float:
    return 1.0 * len(net) + 4


class SheetWriter:
    """Lays out and writes one sheet."""

    def __init__(self, sheet: Sheet, key: str, instances: list[Instance], paper_title: str,
                 revision: str, ports: set[str]):
        self.sheet = sheet
        self.key = key                 # uuid namespace of this sheet file
        self.instances = instances
        self.title = paper_title
        self.revision = revision
        self.ports = ports
        self.items: list[list] = []
        self.lib_ids: list[str] = []
        self.width = 0.0
        self.height = 0.0
        self.y_offset = 0.0            # mm, on the grid: packs the sheet below a drawing

    # --- layout -------------------------------------------------------------------------------
    def _layout(self) -> list[tuple[Part | str, float, float]]:
        """Row packing: each part's box is its pin extent plus room for the longest label."""
        boxes = []
        for p in self.sheet.parts:
            x0, y0, x1, y1 = _extent(p.item.symbol)
            lab = max((_label_len(n) for n in p.nets.values() if n), default=4)
            boxes.append((p, x1 - x0 + 2 * lab + 6, y1 - y0 + 14, x0 - lab - 3, y0 - 7))
        for net in self.sheet.flags:
            boxes.append((net, 2 * _label_len(net) + 6, 14, -_label_len(net) - 3, -7))
        row_w = 380.0 if len(boxes) > 12 else 260.0
        x = y = 0.0
        row_h = 0.0
        placed = []
        for obj, w, h, ox, oy in boxes:
            if x + w > row_w and x > 0:
                x = 0.0
                y += row_h
                row_h = 0.0
            placed.append((obj, snap(20 + x - ox), snap(30 + y - oy) + self.y_offset))
            x += w
            row_h = max(row_h, h)
        self.width = row_w + 40
        self.height = y + row_h + 50
        return placed

    # --- items --------------------------------------------------------------------------------
    def _label(self, net: str, x: float, y: float, angle: int, tag: str) -> None:
        just = "left" if angle in (0, 90) else "right"
        at = ["at", sexpr.num(x), sexpr.num(y), str(angle)]
        eff = ["effects", ["font", ["size", "1.27", "1.27"]], ["justify", just]]
        u = ["uuid", Q(uid(self.key, "label", tag))]
        if net in GLOBAL_NETS:
            self.items.append(["global_label", Q(net), ["shape", "passive"], at,
                               ["fields_autoplaced", "yes"], eff, u,
                               ["property", Q("Intersheetrefs"), Q("${INTERSHEET_REFS}"),
                                ["at", sexpr.num(x), sexpr.num(y), "0"],
                                ["effects", ["font", ["size", "1.27", "1.27"]], ["hide", "yes"]]]])
        elif net in self.ports:
            self.items.append(["hierarchical_label", Q(net), ["shape", "bidirectional"], at, eff, u])
        else:
            eff = ["effects", ["font", ["size", "1.27", "1.27"]], ["justify", just, "bottom"]]
            self.items.append(["label", Q(net), at, ["fields_autoplaced", "yes"], eff, u])

    def _nc(self, x: float, y: float, tag: str) -> None:
        self.items.append(["no_connect", ["at", sexpr.num(x), sexpr.num(y)],
                           ["uuid", Q(uid(self.key, "nc", tag))]])

    def _symbol(self, lib_id: str, ref: str, value: str, x: float, y: float, fields: dict[str, str],
                pins_nets: dict[str, str], in_bom: bool = True, tag: str | None = None,
                on_board: bool | None = None) -> None:
        if lib_id not in self.lib_ids:
            self.lib_ids.append(lib_id)
        tag = tag or ref
        x0, y0, x1, y1 = _extent(lib_id)
        props = [_prop("Reference", ref, x + x1 + 1.27, y + y0 - 2.54, hide=ref.startswith("#"),
                       justify="left"),
                 _prop("Value", value, x + x1 + 1.27, y + y0 - 0.0, hide=ref.startswith("#"),
                       justify="left")]
        for k, v in fields.items():
            props.append(_prop(k, v, x, y, hide=True))
        pins = [["pin", Q(p.number), ["uuid", Q(uid(self.key, tag, "pin", p.number))]]
                for p in libsym.pins(lib_id)]
        inst = ["instances"]
        for i in self.instances:
            inst.append(["project", Q(i.project),
                         ["path", Q(i.path), ["reference", Q(ref)], ["unit", "1"]]])
        self.items.append(["symbol", ["lib_id", Q(lib_id)],
                           ["at", sexpr.num(x), sexpr.num(y), "0"], ["unit", "1"],
                           ["exclude_from_sim", "no"], ["in_bom", "yes" if in_bom else "no"],
                           ["on_board", "yes" if (in_bom if on_board is None else on_board) else "no"],
                           ["dnp", "no"], ["uuid", Q(uid(self.key, tag))], *props, *pins, inst])
        for p in libsym.pins(lib_id):
            px, py = x + p.x, y - p.y
            net = pins_nets.get(p.number, "")
            if net:
                self._label(net, px, py, (p.angle + 180) % 360, f"{tag}/{p.number}")
            elif p.etype != "no_connect":
                self._nc(px, py, f"{tag}/{p.number}")

    def build(self) -> list:
        flag_n = 0
        for obj, x, y in self._layout():
            if isinstance(obj, str):
                flag_n += 1
                self._symbol("power:PWR_FLAG", f"#FLG{self.key[:3].upper()}{flag_n:02d}", "PWR_FLAG",
                             x, y, {"Footprint": "", "Datasheet": "~", "Description": ""},
                             {"1": obj}, in_bom=False, tag=f"flag/{obj}")
                continue
            fields, on_bom = part_fields(obj)
            self._symbol(obj.item.symbol, obj.ref, obj.value, x, y, fields, obj.nets,
                         in_bom=on_bom, on_board=True)
        return self.items

    def document(self, sheet_uses: list[list] | None = None, root: bool = False) -> list:
        items = self.items if self.items else self.build()
        if sheet_uses:
            items = items + sheet_uses
        w = self.width + (60 if sheet_uses else 0)
        paper = "A3" if w <= 420 and self.height <= 297 else "A2"
        if paper == "A2" and (w > 594 or self.height > 420):
            paper = "A1"
        doc = ["kicad_sch", ["version", SCH_VERSION], ["generator", Q("r2p-hwgen")],
               ["generator_version", Q("9.0")], ["uuid", Q(uid(self.key, "sheet"))],
               ["paper", Q(paper)],
               ["title_block", ["title", Q(self.title)], ["rev", Q(self.revision)],
                ["company", Q("R2P - Rapid Robot Prototyping")],
                ["comment", "1", Q(f"Generated by scripts/hwgen: circuit in {description_path(self.key)}, "
                                   f"drawing in {self.key}_sheet.py")]],
               ["lib_symbols", *[libsym.embedded(l) for l in self.lib_ids]],
               *items]
        if root:
            doc.append(["sheet_instances", ["path", Q("/"), ["page", Q("1")]]])
        doc.append(["embedded_fonts", "no"])
        return doc


def sheet_symbol(parent_key: str, use, project: str, root_path: str, page: int, file: str) -> list:
    """The box in the parent sheet that instantiates `use.sheet`, plus its pin labels."""
    child = use.sheet
    x, y = use.at
    h = snap(len(child.ports) * GRID + 10)
    w = 40.64
    sid = uid(parent_key, "sheet", child.name)
    pins = []
    extra = []
    for i, port in enumerate(child.ports):
        py = y + 5.08 + i * GRID
        pins.append(["pin", Q(port.name), port.shape, ["at", sexpr.num(x), sexpr.num(py), "180"],
                     ["uuid", Q(uid(parent_key, "sheetpin", child.name, port.name))],
                     ["effects", ["font", ["size", "1.27", "1.27"]], ["justify", "left"]]])
        net = use.nets[port.name]
        tag = f"sheetpin/{child.name}/{port.name}"
        if net:
            just = "right"
            if net in GLOBAL_NETS:
                extra.append(["global_label", Q(net), ["shape", "passive"],
                              ["at", sexpr.num(x), sexpr.num(py), "180"],
                              ["fields_autoplaced", "yes"],
                              ["effects", ["font", ["size", "1.27", "1.27"]], ["justify", just]],
                              ["uuid", Q(uid(parent_key, "label", tag))],
                              ["property", Q("Intersheetrefs"), Q("${INTERSHEET_REFS}"),
                               ["at", sexpr.num(x), sexpr.num(py), "0"],
                               ["effects", ["font", ["size", "1.27", "1.27"]], ["hide", "yes"]]]])
            else:
                extra.append(["label", Q(net), ["at", sexpr.num(x), sexpr.num(py), "180"],
                              ["fields_autoplaced", "yes"],
                              ["effects", ["font", ["size", "1.27", "1.27"]], ["justify", just, "bottom"]],
                              ["uuid", Q(uid(parent_key, "label", tag))]])
        else:
            extra.append(["no_connect", ["at", sexpr.num(x), sexpr.num(py)],
                          ["uuid", Q(uid(parent_key, "nc", tag))]])
    box = ["sheet", ["at", sexpr.num(x), sexpr.num(y)], ["size", sexpr.num(w), sexpr.num(h)],
           ["exclude_from_sim", "no"], ["in_bom", "yes"], ["on_board", "yes"], ["dnp", "no"],
           ["fields_autoplaced", "yes"],
           ["stroke", ["width", "0.1524"], ["type", "solid"]],
           ["fill", ["color", "0", "0", "0", "0.0000"]],
           ["uuid", Q(sid)],
           ["property", Q("Sheetname"), Q(child.name), ["at", sexpr.num(x), sexpr.num(y - 0.7), "0"],
            ["effects", ["font", ["size", "1.27", "1.27"]], ["justify", "left", "bottom"]]],
           ["property", Q("Sheetfile"), Q(file), ["at", sexpr.num(x), sexpr.num(y + h + 0.6), "0"],
            ["effects", ["font", ["size", "1.27", "1.27"]], ["justify", "left", "top"]]],
           *pins,
           ["instances", ["project", Q(project), ["path", Q(root_path), ["page", Q(str(page))]]]]]
    return [box, *extra]


def write(path: Path, doc: list) -> None:
    path.write_text(sexpr.dump(doc) + "\n")


def description_path(key: str) -> str:
    """Where a board's description is, as the sheet's title block names it: in the module's
    hardware folder, or (a description not moved there yet) beside the generator."""
    from .. import ROOT
    if (ROOT / "hardware" / key / f"{key}.py").is_file():
        return f"hardware/{key}/{key}.py"
    return f"scripts/r2ptools/kicad/modules/{key}.py"
