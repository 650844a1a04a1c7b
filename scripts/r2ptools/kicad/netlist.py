"""The schematic's netlist as KiCad itself computes it (`kicad-cli sch export netlist`).

The board is built from this netlist rather than from the description, exactly as KiCad's
"Update PCB from schematic" does: net names (sheet paths included), symbol paths and fields come
from KiCad, so the board is in parity with the schematic by construction and the DRC's parity
check tests the generator instead of trusting it.
"""
from __future__ import annotations

import subprocess
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

from . import sexpr


@dataclass
class Component:
    ref: str
    value: str
    footprint: str
    path: str                     # KiCad footprint path: /<sheet uuids>/<symbol uuid>
    sheetname: str
    sheetfile: str
    fields: dict[str, str] = field(default_factory=dict)


@dataclass
class Netlist:
    components: dict[str, Component]
    nets: dict[str, list[tuple[str, str]]]   # net name -> [(ref, pin)]

    def resolve(self, name: str) -> str:
        """The KiCad name of a description net: `GND` stays, a sheet-local `SW` is `/SW`."""
        if name in self.nets:
            return name
        hits = [n for n in self.nets if n.endswith("/" + name)]
        if len(hits) != 1:
            raise KeyError(f"net {name!r}: {'not in the netlist' if not hits else 'ambiguous: ' + ', '.join(hits)}")
        return hits[0]

    def pin_nets(self) -> dict[tuple[str, str], str]:
        return {node: name for name, nodes in self.nets.items() for node in nodes}


def export(sch: Path) -> Netlist:
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "net.net"
        p = subprocess.run(["kicad-cli", "sch", "export", "netlist", "--format", "kicadsexpr",
                            "-o", str(out), sch.name], cwd=sch.parent, capture_output=True,
                           text=True)      # run beside it: sheet file names come out relative
        if p.returncode != 0 or not out.exists():
            raise RuntimeError(f"kicad-cli could not export the netlist of {sch}:\n{p.stdout}{p.stderr}")
        return parse(out.read_text())


def parse(text: str) -> Netlist:
    tree = sexpr.parse(text)
    comps = {}
    for c in sexpr.find_all(sexpr.find(tree, "components"), "comp"):
        ref = str(sexpr.find(c, "ref")[1])
        sp = sexpr.find(c, "sheetpath")
        tstamps = str(sexpr.find(sp, "tstamps")[1])
        fields = {}
        fl = sexpr.find(c, "fields")
        for f in sexpr.find_all(fl or [], "field"):
            name = str(sexpr.find(f, "name")[1])
            fields[name] = str(f[2]) if len(f) > 2 else ""
        fp = sexpr.find(c, "footprint")
        sheetfile = ""
        for prop in sexpr.find_all(c, "property"):
            if str(sexpr.find(prop, "name")[1]) == "Sheetfile":
                sheetfile = str(sexpr.find(prop, "value")[1])
        comps[ref] = Component(
            ref=ref, value=str(sexpr.find(c, "value")[1]), footprint=str(fp[1]) if fp else "",
            path=tstamps + str(sexpr.find(c, "tstamps")[1]),
            sheetname=str(sexpr.find(sp, "names")[1]), sheetfile=sheetfile, fields=fields)
    nets = {}
    for n in sexpr.find_all(sexpr.find(tree, "nets"), "net"):
        name = str(sexpr.find(n, "name")[1])
        nets[name] = [(str(sexpr.find(node, "ref")[1]), str(sexpr.find(node, "pin")[1]))
                      for node in sexpr.find_all(n, "node")]
    return Netlist(comps, nets)
