"""The readable description a board is generated from: sheets of parts, their nets and places.

A module is written as Python (hardware/<module>/design.py… see `r2ptools.kicad.modules`): each
part names a catalogue entry (symbol, footprint, value, MPN, from `catalog`) and says which net
each pin is on. Pins are named by their symbol pin name when it is unique (`VIN`, `PA0`) or by
number (`"24"`). A pin left out is an error unless listed in `nc=` (a deliberate no-connect), so a
forgotten pin never slips into a board silently. Placement (mm from the board's top-left corner,
rotation in degrees, side) lives beside the part.
"""
from __future__ import annotations

from dataclasses import dataclass, field

from . import catalog, libsym

GLOBAL_NETS = ("GND", "+3V3", "+5V")
"""Nets shared by every sheet of a board (global labels): the bus supply, its ground, the 3.3 V."""


class DesignError(ValueError):
    """A description that cannot become a board; the message names the part and pin."""


@dataclass
class Place:
    x: float
    y: float
    rot: float = 0.0
    back: bool = False


@dataclass(frozen=True)
class At:
    """A symbol's place on the sheet: grid units (2.54 mm) from the page's top-left corner."""
    x: float
    y: float
    rot: int = 0


@dataclass
class Block:
    """A functional block: a dashed frame with a title and design notes, in grid units."""
    title: str
    x0: float
    y0: float
    x1: float
    y1: float
    notes: list[tuple[float, float, str]] = field(default_factory=list)   # (x, y, text)

    def contains(self, p: tuple[int, int]) -> bool:
        """`p` in 0.01 mm (drawing.py's unit)."""
        return self.x0 * 254 <= p[0] <= self.x1 * 254 and self.y0 * 254 <= p[1] <= self.y1 * 254



@dataclass
class Part:
    ref: str
    key: str                          # catalogue entry
    nets: dict[str, str]              # pin number -> net name
    place: Place | None
    value: str
    note: str = ""

    @property
    def item(self) -> catalog.Item:
        return catalog.item(self.key)


@dataclass
class Port:
    """A net that crosses a sheet boundary (a hierarchical label in the child sheet)."""
    name: str
    shape: str = "bidirectional"


@dataclass
class Sheet:
    name: str
    title: str
    parts: list[Part] = field(default_factory=list)
    ports: list[Port] = field(default_factory=list)
    flags: list[str] = field(default_factory=list)   # nets given a PWR_FLAG (driven from outside)
    children: list["SheetUse"] = field(default_factory=list)
    revision: str = "A"                                    # of a shared sheet (the core)
    drawing: dict[str, At] = field(default_factory=dict)   # ref (or "flag:NET") -> place
    blocks: list[Block] = field(default_factory=list)      # functional blocks of the drawing

    def part(self, ref: str, key: str, pins: dict[str, str], at: Place | tuple | None = None,
             nc: tuple[str, ...] = (), value: str | None = None, note: str = "") -> Part:
        """Adds a part; `pins` maps pin name or number to net, `nc` lists unconnected pins."""
        it = catalog.item(key)
        symbol_pins = libsym.pins(it.symbol)
        by_number = {p.number: p for p in symbol_pins}
        names: dict[str, list[str]] = {}
        for p in symbol_pins:
            names.setdefault(p.name, []).append(p.number)
        nets: dict[str, str] = {}

        def resolve(pin: str) -> list[str]:
            if pin in by_number:
                return [pin]
            if pin in names:
                return names[pin]          # a name shared by several pins (VSS) means all of them
            raise DesignError(f"{self.name}/{ref}: symbol {it.symbol} has no pin {pin!r} "
                              f"(pins: {', '.join(sorted(by_number))})")

        for pin, net in pins.items():
            for num in resolve(pin):
                if num in nets and nets[num] != net:
                    raise DesignError(f"{self.name}/{ref} pin {num}: on both {nets[num]} and {net}")
                nets[num] = net
        for pin in nc:
            for num in resolve(pin):
                nets[num] = ""
        missing = [p.number for p in symbol_pins if p.number not in nets and p.etype != "no_connect"]
        if missing:
            raise DesignError(f"{self.name}/{ref} ({it.symbol}): pins {', '.join(missing)} not "
                              "connected: give each a net or list it in nc=")
        for p in symbol_pins:
            nets.setdefault(p.number, "")
        if any(p.ref == ref for p in self.parts):
            raise DesignError(f"{self.name}: reference {ref} used twice")
        place = at if isinstance(at, Place) or at is None else Place(*at)
        part = Part(ref, key, nets, place, value or it.value, note)
        self.parts.append(part)
        return part

    def port(self, name: str, shape: str = "bidirectional") -> str:
        self.ports.append(Port(name, shape))
        return name

    def use(self, child: "Sheet", nets: dict[str, str], at: tuple[float, float] = (30, 30)) -> None:
        """Instantiates `child` here; `nets` maps each child port to a net of this sheet ('' = NC)."""
        missing = [p.name for p in child.ports if p.name not in nets]
        extra = [k for k in nets if k not in {p.name for p in child.ports}]
        if missing or extra:
            raise DesignError(f"{self.name}: sheet {child.name}: ports not mapped {missing}, "
                              f"unknown ports {extra}")
        self.children.append(SheetUse(child, nets, at))


@dataclass
class SheetUse:
    sheet: Sheet
    nets: dict[str, str]
    at: tuple[float, float]


@dataclass
class Text:
    text: str
    x: float
    y: float
    size: float = 1.0
    layer: str = "F.SilkS"
    rot: float = 0.0


@dataclass
class Track:
    """A hand-placed copper path (power): points in mm, width in mm."""
    net: str
    points: list[tuple[float, float]]
    width: float
    layer: str = "F.Cu"


@dataclass
class Via:
    net: str
    x: float
    y: float
    size: float = 0.6
    drill: float = 0.3


@dataclass
class Zone:
    """A copper pour: polygon in mm; priority decides which of overlapping zones wins."""
    net: str
    layer: str
    polygon: list[tuple[float, float]]
    priority: int = 0
    min_width: float = 0.2
    thermal_gap: float = 0.3
    spoke: float = 0.5
    solid: bool = False               # pads joined solid (power) rather than by thermal spokes


@dataclass
class Keepout:
    """A rule area other nets' tracks may not cross (e.g. to keep a power band in one piece)."""
    polygon: list[tuple[float, float]]
    layers: tuple[str, ...] = ("F.Cu", "B.Cu")
    tracks: bool = True
    vias: bool = False


@dataclass
class Module:
    """One board: its root sheet, board text, hand-routed power copper, identity."""
    name: str
    title: str
    revision: str
    root: Sheet
    texts: list[Text] = field(default_factory=list)
    tracks: list[Track] = field(default_factory=list)
    vias: list[Via] = field(default_factory=list)
    zones: list[Zone] = field(default_factory=list)
    keepouts: list[Keepout] = field(default_factory=list)
    places: dict[str, Place] = field(default_factory=dict)   # per-board moves of core parts
    netclasses: dict[str, list[str]] = field(default_factory=dict)
    fiducials: list[tuple[float, float]] = field(default_factory=list)   # 3, board-only
    seed: int = 1
    solid_pads: tuple[str, ...] = ()    # parts whose pads join the pours solid, THT ones too
    netclass_defs: dict[str, tuple[float, float, float, float]] = field(default_factory=dict)
    # extra net classes (clearance, track, via, drill in mm) for `netclasses` beyond Power
    dru_rules: str = ""                 # board-specific KiCad custom rules, after the fab's
    # the outline and stack-up: the bus form factor unless a module states its reason to differ
    # (docs/bus.md); holes in mm from the top-left corner, None = the four of the 60 x 50 mm grid
    size: tuple[float, float] = (60.0, 50.0)
    holes: list[tuple[float, float]] | None = None
    copper_layers: int = 2

    def sheets(self) -> list[Sheet]:
        out, todo = [], [self.root]
        while todo:
            s = todo.pop(0)
            if s not in out:
                out.append(s)
            todo.extend(u.sheet for u in s.children)
        return out

    def all_parts(self) -> list[tuple[Sheet, Part]]:
        return [(s, p) for s in self.sheets() for p in s.parts]
