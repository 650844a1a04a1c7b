"""Reads a `.kicad_pcb` with pcbnew into the facts a case is made from.

Coordinates are millimetres in the board frame the form factor is specified in: origin at the
top-left corner of the board outline's bounding box, x right, y down (as KiCad shows the board),
whatever the board's position on the KiCad page. A part's extent is the bounding box of its body
as KiCad's libraries draw it on the fabrication layer (F.Fab/B.Fab) and of its pads (a QFP's
leads, a connector's tabs); the courtyard (body + placement margin) only when there is no
fabrication drawing.

What a footprint is for the case:
- mounting hole: library `MountingHole*`, or reference `H<n>`/`MH<n>` with one drilled pad;
- connector: library `Connector*` or `TerminalBlock*`, or reference `J`, `P`, `CN`, `X`; it faces
  the board edge its courtyard is nearest to when that is within `edge_near` (else it is inside the
  case and gets no cut-out); a field `R2P_EDGE` = top|bottom|left|right|none overrides;
- control: a slide, toggle or DIP switch (library `Button_Switch*` or reference `SW`): at an edge
  (a bus termination switch) it faces it like a connector, so the wall is open in front of it;
- button: any other switch, pressed from above (reset, boot): a pin hole in the lid over it;
- LED: library `LED_*`, or a `D`/`LED` reference whose value says LED: gets a light-pipe hole;
- warm: a field `R2P_WARM` (any value but 0/no/false), power inductors (library `Inductor*`
  beyond chip sizes), DPAK/D2PAK, SMA/SMB/SMC and PowerDI diodes, and every part on a power
  inductor's switch node (a net of at most SWITCH_NODE_MAX footprints: the converter IC): vented.
"""
from __future__ import annotations

import re
from dataclasses import asdict, dataclass, replace
from pathlib import Path

from .heights import HeightError, height_of

EDGES = ("top", "bottom", "left", "right")
_CONNECTOR_LIB = re.compile(r"^(Connector|TerminalBlock)")
_CONNECTOR_REF = re.compile(r"^(J|P|CN|X)\d")
_HOLE_REF = re.compile(r"^(H|MH)\d")
_SWITCH_REF = re.compile(r"^SW\d")
_SIDEWAYS = re.compile(r":SW_(SPDT|DPDT|SP3T|Slide|DIP|Toggle)|:SW_.*_Slide", re.I)
SWITCH_NODE_MAX = 4      # footprints on a net for it to count as a converter's switch node
_LED_REF = re.compile(r"^(D|LED)\d")
_WARM = re.compile(
    r"^Inductor_(SMD|THT)[^:]*:(?!L_(0201|0402|0603|0805|1008|1206|1210)_)"
    r"|^Package_TO_SOT_SMD:(TO-252|TO-263|TO-268|DPAK|D2PAK)"
    r"|^Diode_SMD:D_(SMA|SMB|SMC|PowerDI)")
# Power packages whose tab is soldered onto thermal vias: their heat leaves through the board's
# bottom copper (a B.Cu island the size of the tab under it), into a gap pad and a heatsink.
HEAT_DOWN = re.compile(r"^Package_TO_SOT_SMD:(TO-263|TO-268|D2PAK)")


class BoardError(ValueError):
    """The board cannot be made into a case; the message says where and what to do."""


@dataclass(frozen=True)
class Hole:
    ref: str
    x: float
    y: float
    d: float


@dataclass(frozen=True)
class Part:
    ref: str
    fpid: str
    value: str
    side: str                  # "top" or "bottom"
    x0: float                  # body and pads bounding box, board frame
    y0: float
    x1: float
    y1: float
    h: float                   # body height away from the board surface on its side
    h_src: str
    kind: str                  # "connector", "control", "button", "led", "warm" or "part"
    edge: str | None           # for connectors and controls: the board edge it faces
    leads: tuple[float, float, float, float] | None  # drilled pads' box (x0, y0, x1, y1)


@dataclass(frozen=True)
class Tab:
    """A heat-down package's tab (its largest pad), board frame: where its thermal vias land on
    the B.Cu island the gap pad presses on (hardware/motor/motor.py draws the island the tab's
    size)."""
    ref: str
    x0: float
    y0: float
    x1: float
    y1: float


@dataclass(frozen=True)
class Board:
    module: str
    source: str
    width: float
    height: float
    thickness: float
    corner_r: float
    outline: tuple[tuple[float, float], ...]   # closed polygon, arcs flattened by KiCad
    holes: tuple[Hole, ...]
    parts: tuple[Part, ...]
    tabs: tuple[Tab, ...] = ()

    def as_dict(self) -> dict:
        d = asdict(self)
        if not d["tabs"]:
            del d["tabs"]           # boards without power packages: their files stay as they were
        return d

    @staticmethod
    def from_dict(d: dict) -> "Board":
        return Board(
            **{**d,
               "outline": tuple(tuple(p) for p in d["outline"]),
               "holes": tuple(Hole(**h) for h in d["holes"]),
               "parts": tuple(Part(**{**p, "leads": tuple(p["leads"]) if p["leads"] else None})
                              for p in d["parts"]),
               "tabs": tuple(Tab(**t) for t in d.get("tabs", ()))})


def _mm(v: int) -> float:
    return round(v / 1e6, 4)


def _field(fp, name: str) -> str | None:
    return fp.GetFieldText(name) if fp.HasFieldByName(name) else None


def _box(b) -> tuple[int, int, int, int]:
    return b.GetX(), b.GetY(), b.GetRight(), b.GetBottom()


def _body(fp, side: str, pcbnew) -> tuple[int, int, int, int] | None:
    """The part's footprint on the board: its body as drawn on the fabrication layer plus its
    pads (leads reach past a QFP's body); the courtyard (body + placement margin) if neither."""
    fab = pcbnew.B_Fab if side == "bottom" else pcbnew.F_Fab
    bb = None
    items = [g for g in fp.GraphicalItems() if isinstance(g, pcbnew.PCB_SHAPE) and g.GetLayer() == fab]
    for it in [*items, *fp.Pads()]:
        b = it.GetBoundingBox()
        if bb is None:
            bb = b
        else:
            bb.Merge(b)
    if bb is None or not items:
        cy = fp.GetCourtyard(pcbnew.B_CrtYd if side == "bottom" else pcbnew.F_CrtYd)
        if cy.OutlineCount() > 0:
            return _box(cy.BBox())
    return _box(bb) if bb is not None else None


def _kind(ref: str, lib: str, fpid: str, value: str, warm_field: str | None) -> str:
    if lib.startswith("LED_") or (_LED_REF.match(ref) and "LED" in value.upper()):
        return "led"
    if _CONNECTOR_LIB.match(lib) or _CONNECTOR_REF.match(ref):
        return "connector"
    if lib.startswith("Button_Switch") or _SWITCH_REF.match(ref):
        return "control" if _SIDEWAYS.search(fpid) else "button"
    if (warm_field is not None and warm_field.strip().lower() not in ("", "0", "no", "false")) \
            or _WARM.search(fpid):
        return "warm"
    return "part"


def _facing(ref: str, box: tuple[float, ...], w: float, h: float, near: float, where: str) -> str | None:
    x0, y0, x1, y1 = box
    dist = {"top": y0, "bottom": h - y1, "left": x0, "right": w - x1}
    ranked = sorted(dist.items(), key=lambda kv: kv[1])
    (e1, d1), (_, d2) = ranked[0], ranked[1]
    if d1 > near:
        return None
    if d2 - d1 < 0.5:
        raise BoardError(f"{where}: {ref} is as close to the {ranked[0][0]} edge as to the "
                         f"{ranked[1][0]} edge ({d1:.2f} vs {d2:.2f} mm): set its R2P_EDGE field to "
                         "the edge it faces (top, bottom, left, right or none)")
    return e1


def read(path: Path, design) -> Board:
    """Reads `path` (a .kicad_pcb); module name = file stem."""
    import pcbnew

    where = str(path)
    if not path.exists():
        raise BoardError(f"{where}: no such board file")
    board = pcbnew.LoadBoard(str(path))
    polys = pcbnew.SHAPE_POLY_SET()
    if not board.GetBoardPolygonOutlines(polys) or polys.OutlineCount() != 1:
        raise BoardError(f"{where}: Edge.Cuts must form exactly one closed outline "
                         f"(found {polys.OutlineCount()}); fix it in KiCad (DRC reports gaps)")
    edges = polys.BBox()           # the outline's centre line, not widened by its stroke
    ox, oy = edges.GetX(), edges.GetY()

    def pt(x: int, y: int) -> tuple[float, float]:
        return _mm(x - ox), _mm(y - oy)

    chain = polys.Outline(0)
    outline = tuple(pt(chain.CPoint(i).x, chain.CPoint(i).y) for i in range(chain.PointCount()))
    radii = [_mm(s.GetRadius()) for s in board.GetDrawings()
             if s.GetLayer() == pcbnew.Edge_Cuts and isinstance(s, pcbnew.PCB_SHAPE)
             and s.GetShape() == pcbnew.SHAPE_T_ARC]
    width, height = _mm(edges.GetWidth()), _mm(edges.GetHeight())

    holes: list[Hole] = []
    parts: list[Part] = []
    tabs: list[Tab] = []
    nets: dict[str, set[str]] = {}       # net -> references of the footprints on it
    inductors: list[str] = []
    for fp in board.GetFootprints():
        ref = fp.GetReference()
        fpid = f"{fp.GetFPID().GetLibNickname()}:{fp.GetFPID().GetLibItemName()}"
        lib = str(fp.GetFPID().GetLibNickname())
        pads = list(fp.Pads())
        drilled = [p for p in pads if p.GetDrillSize().x > 0]
        if lib.startswith("MountingHole") or (_HOLE_REF.match(ref) and len(pads) == 1 and drilled):
            if len(drilled) != 1:
                raise BoardError(f"{where}: mounting hole {ref} ({fpid}) has {len(drilled)} drilled pads, expected 1")
            c = drilled[0].GetPosition()
            holes.append(Hole(ref, *pt(c.x, c.y), _mm(drilled[0].GetDrillSize().x)))
            continue
        try:
            h, h_src = height_of(fpid, ref, _field(fp, "Height"), where)
        except HeightError as e:
            raise BoardError(str(e)) from None
        if h <= 0:
            continue
        side = "bottom" if fp.IsFlipped() else "top"
        bx = _body(fp, side, pcbnew)
        if bx is None:
            raise BoardError(f"{where}: {ref} ({fpid}) has no fabrication outline, pads or courtyard to size "
                             "it by; draw its body on F.Fab")
        box = (*pt(bx[0], bx[1]), *pt(bx[2], bx[3]))
        # Leads and plastic pegs (NPTH) both come through the board.
        tht = [p for p in pads if p.GetDrillSize().x > 0]
        leads = None
        if tht:
            bb = tht[0].GetBoundingBox()
            for p in tht[1:]:
                bb.Merge(p.GetBoundingBox())
            lb = _box(bb)
            leads = (*pt(lb[0], lb[1]), *pt(lb[2], lb[3]))
        value = fp.GetValue()
        kind = _kind(ref, lib, fpid, value, _field(fp, "R2P_WARM"))
        for p in pads:
            if p.GetNetname():
                nets.setdefault(p.GetNetname(), set()).add(ref)
        if kind == "warm" and lib.startswith("Inductor"):
            inductors.append(ref)
        edge = None
        if kind in ("connector", "control"):
            forced = _field(fp, "R2P_EDGE")
            if forced is not None and forced.strip():
                f = forced.strip().lower()
                if f not in (*EDGES, "none"):
                    raise BoardError(f"{where}: {ref}: R2P_EDGE is {forced!r}; use top, bottom, left, right or none")
                edge = None if f == "none" else f
            else:
                edge = _facing(ref, box, width, height, design.edge_near, where)
        parts.append(Part(ref, fpid, value, side, *box, h, h_src, kind, edge, leads))
        if side == "top" and HEAT_DOWN.match(fpid) and pads:
            big = max(pads, key=lambda p: p.GetSize().x * p.GetSize().y)
            tb = _box(big.GetBoundingBox())
            tabs.append(Tab(ref, *pt(tb[0], tb[1]), *pt(tb[2], tb[3])))

    # A power inductor's small nets are its converter's switch node and bootstrap: the IC and
    # diodes on them are the warm region too (the output rail is a big net and does not count).
    hot = {r for n, refs in nets.items() if any(i in refs for i in inductors) and len(refs) <= SWITCH_NODE_MAX
           for r in refs}
    parts = [replace(p, kind="warm") if p.ref in hot and p.kind == "part" else p for p in parts]
    if not holes:
        raise BoardError(f"{where}: no mounting holes (MountingHole footprints or H<n> references); "
                         "the case holds the board by them")
    holes.sort(key=lambda o: (o.y, o.x, o.ref))
    parts.sort(key=lambda p: _refkey(p.ref))
    return Board(module=path.stem, source=path.name, width=width, height=height,
                 thickness=_mm(board.GetDesignSettings().GetBoardThickness()),
                 corner_r=max(radii) if radii else 0.0, outline=outline,
                 holes=tuple(holes), parts=tuple(parts),
                 tabs=tuple(sorted(tabs, key=lambda t: _refkey(t.ref))))


def _refkey(ref: str) -> tuple:
    m = re.match(r"^([A-Za-z_]*)(\d*)(.*)$", ref)
    assert m
    return m.group(1), int(m.group(2) or 0), m.group(3)
