"""The project footprint library `R2P` (hardware/core/R2P.pretty): KiCad footprints, silk trimmed.

Some KiCad library outlines cannot sit cleanly on our boards: the RJ45 (the bus jacks and the
gateway's Ethernet jack), XT30 and JST PH bodies overhang the edge they face out of (their outline
crosses the board edge), and the PSU's eFuse (HTSSOP-20) outline runs along J2's pin-1 arrow. A fab clips silk at the edge anyway, but DRC
rightly warns, so these parts use a **variant**: the KiCad footprint with identical pads, fab,
courtyard and fields, whose silkscreen lines are cut where they would come within 0.3 mm of the
board edge, 0.15 mm of another part's pad or silk, on any board that places it (every placement
in every module description, so one variant serves them all). Pin-1 marks (small separate
figures) and non-line graphics are kept as drawn; DRC checks the result.

The library also holds footprints KiCad does not have at all (`DRAWN`: the motor's NANO2 456
fuse), drawn from the maker's recommended land pattern; the generator routes them as they are and
never rewrites them.

The catalogue names a variant as `R2P:<KiCad footprint name>`, so the schematic's Footprint
field and the board agree (schematic parity) and DRC compares the board's footprint with the
variant in R2P.pretty (no lib_footprint_mismatch). Routing uses the **source** footprint
(`source()`): the silk outline and the library id are part of the Specctra DSN, so the route key
stays that of the KiCad footprint and a trim never forces a reroute; the variant's silk replaces
the source's on the routed board (`apply`). The variant files are written by the generator
(`write`) from the descriptions and KiCad's library; same inputs, same bytes (UUIDs derive from
the name).
"""
from __future__ import annotations

import re
import subprocess
import sys
import uuid
from pathlib import Path

import pcbnew

from .. import ROOT
from . import board as board_mod
from . import libtables, silk
from .board import mm

LIB = libtables.PROJECT_FP_LIB
VARIANTS = {
    # variant name (= the KiCad footprint it is cut from) -> KiCad library
    "RJ45_Amphenol_54602-x08_Horizontal": "Connector_RJ",
    "RJ45_Hanrun_HR911105A_Horizontal": "Connector_RJ",
    "AMASS_XT30PW-M_1x02_P2.50mm_Horizontal": "Connector_AMASS",
    "AMASS_XT60PW-M_1x02_P7.20mm_Horizontal": "Connector_AMASS",
    "AMASS_XT60PW-F_1x02_P7.20mm_Horizontal": "Connector_AMASS",
    "JST_PH_S3B-PH-K_1x03_P2.00mm_Horizontal": "Connector_JST",
    "HTSSOP-20-1EP_4.4x6.5mm_P0.65mm_EP3.4x6.5mm": "Package_SO",
}
DRAWN = (
    # Footprints KiCad's library does not have, drawn for the project from the maker's land
    # pattern (its description cites the drawing) and edited in KiCad: kept as drawn, routed as
    # themselves, never cut or rewritten by the generator.
    "Fuse_Littelfuse-NANO2-456",
)
STEP = 0.05
"""Resolution of a cut along a silk line, mm."""
MIN_PIECE = 0.2
"""A cut piece shorter than this (mm) is dropped rather than left as a speck."""
MARK_SIZE = 1.5
"""Silk lines joined into a figure no larger than this (mm) are a mark (pin-1 arrow): kept whole."""
_UUID_NS = uuid.UUID("6f1d1b2e-2c53-4f7e-9a51-52325046504c")


class TrimError(ValueError):
    """A variant that cannot be cut (placed on the back, unknown name); the message says which."""


def source(lib_id: str) -> str:
    """The KiCad footprint a lib id is routed with: a variant's source, anything else itself."""
    lib, _, name = lib_id.partition(":")
    if lib != LIB or name in DRAWN:
        return lib_id
    if name not in VARIANTS:
        raise TrimError(f"{lib_id}: no such variant or drawn footprint; known: "
                        f"{', '.join(sorted(VARIANTS) + list(DRAWN))} (r2ptools/kicad/fplib.py "
                        "VARIANTS, DRAWN)")
    return f"{VARIANTS[name]}:{name}"


def _silk(fp: pcbnew.FOOTPRINT) -> list[pcbnew.PCB_SHAPE]:
    return [g for g in fp.GraphicalItems() if isinstance(g, pcbnew.PCB_SHAPE)
            and g.GetLayer() in (pcbnew.F_SilkS, pcbnew.B_SilkS)]


def _key(g: pcbnew.PCB_SHAPE) -> tuple:
    return (g.GetLayer(), g.GetShape(), g.GetStart().x, g.GetStart().y, g.GetEnd().x, g.GetEnd().y)


def _lines(fp: pcbnew.FOOTPRINT) -> list[pcbnew.PCB_SHAPE]:
    """The footprint's silk lines that may be cut: segments not part of a small mark."""
    segs = [g for g in _silk(fp) if g.GetShape() == pcbnew.SHAPE_T_SEGMENT]
    parent = list(range(len(segs)))

    def find(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i
    ends: dict[tuple, int] = {}
    for i, g in enumerate(segs):
        for p in (g.GetStart(), g.GetEnd()):
            j = ends.setdefault((g.GetLayer(), p.x, p.y), i)
            parent[find(i)] = find(j)
    groups: dict[int, list[int]] = {}
    for i in range(len(segs)):
        groups.setdefault(find(i), []).append(i)
    out = []
    for members in groups.values():
        xs = [c for i in members for c in (segs[i].GetStart().x, segs[i].GetEnd().x)]
        ys = [c for i in members for c in (segs[i].GetStart().y, segs[i].GetEnd().y)]
        if max(xs) - min(xs) > mm(MARK_SIZE) or max(ys) - min(ys) > mm(MARK_SIZE):
            out += [segs[i] for i in members]
    return sorted(out, key=_key)


def _module_board(m) -> pcbnew.BOARD:
    """Every part of a module at its place, source footprints, no nets: the obstacles."""
    b = pcbnew.BOARD()
    board_mod._outline(b, m.size)
    places = {p.ref: (p, p.place) for _, p in m.all_parts()}
    for ref, (p, _) in list(places.items()):
        if ref in m.places:
            places[ref] = (p, m.places[ref])
    for ref in sorted(places):
        p, place = places[ref]
        fp = board_mod.load_footprint(source(p.item.footprint))
        fp.SetReference(ref)
        fp.SetPosition(board_mod.pt(place.x, place.y))
        fp.SetOrientationDegrees(place.rot)
        b.Add(fp)
        if place.back:
            fp.Flip(fp.GetPosition(), pcbnew.FLIP_DIRECTION_LEFT_RIGHT)
    for i, (x, y) in enumerate(board_mod.HOLES if m.holes is None else m.holes, start=1):
        fp = board_mod.load_footprint(":".join(board_mod.HOLE_FP))
        fp.SetReference(f"H{i}")
        fp.SetPosition(board_mod.pt(x, y))
        b.Add(fp)
    for i, (x, y) in enumerate(m.fiducials, start=1):
        fp = board_mod.load_footprint(":".join(board_mod.FIDUCIAL_FP))
        fp.SetReference(f"FID{i}")
        fp.SetPosition(board_mod.pt(x, y))
        b.Add(fp)
    return b


def _steps(g: pcbnew.PCB_SHAPE) -> int:
    a, e = g.GetStart(), g.GetEnd()
    return max(1, round(((e.x - a.x) ** 2 + (e.y - a.y) ** 2) ** 0.5 / mm(STEP)))


def _at(a, e, k: int, n: int) -> pcbnew.VECTOR2I:
    return pcbnew.VECTOR2I(a.x + (e.x - a.x) * k // n, a.y + (e.y - a.y) * k // n)


def _free(fp: pcbnew.FOOTPRINT, b: pcbnew.BOARD, g: pcbnew.PCB_SHAPE) -> list[bool]:
    """For each step of line `g` of placed footprint `fp`: clear of the edge, pads and silk."""
    layer = g.GetLayer()
    mask = pcbnew.F_Mask if layer == pcbnew.F_SilkS else pcbnew.B_Mask
    me = fp.GetReference()
    obstacles: list[tuple[silk.Obstacle, int]] = []
    for d in b.GetDrawings():
        if d.GetLayer() == pcbnew.Edge_Cuts:
            obstacles.append((silk.Obstacle(silk._box(d.GetBoundingBox()),
                                            d.GetEffectiveShape(pcbnew.Edge_Cuts), "edge"),
                              mm(silk.GAP_EDGE)))
    for f in b.GetFootprints():
        if f.GetReference() == me:
            continue
        for p in f.Pads():
            if p.IsOnLayer(mask):
                obstacles.append((silk.Obstacle(silk._box(p.GetBoundingBox()), p.GetEffectiveShape(mask),
                                                "pad"), mm(silk.GAP_MASK)))
        for s in _silk(f):
            if s.GetLayer() == layer:
                obstacles.append((silk.Obstacle(silk._box(s.GetBoundingBox()), s.GetEffectiveShape(layer),
                                                "silk"), mm(silk.GAP_SILK)))
    a, e, n = g.GetStart(), g.GetEnd(), _steps(g)
    out = []
    for k in range(n):
        seg = pcbnew.SHAPE_SEGMENT(_at(a, e, k, n), _at(a, e, k + 1, n), g.GetWidth())
        box = silk._box(seg.BBox())
        out.append(silk._inside(box, mm(silk.GAP_EDGE), board_mod.outline_size(b))
                   and not any(silk._near(box, o.box, gap) and seg.Collide(o.shape, gap)
                               for o, gap in obstacles))
    return out


def variants(modules) -> dict[str, pcbnew.FOOTPRINT]:
    """Every variant used by `modules`, in library coordinates, its lines cut for all placements."""
    stock = {n: board_mod.load_footprint(f"{lib}:{n}") for n, lib in sorted(VARIANTS.items())}
    keep = {n: {_key(g): [True] * _steps(g) for g in _lines(fp)} for n, fp in stock.items()}
    used = set()
    for m in modules:
        refs = sorted((p.ref, p.item.footprint.split(":", 1)[1]) for _, p in m.all_parts()
                      if p.item.footprint.startswith(LIB + ":")
                      and p.item.footprint.split(":", 1)[1] not in DRAWN)
        if not refs:
            continue
        b = _module_board(m)
        by_ref = {f.GetReference(): f for f in b.GetFootprints()}
        for ref, name in refs:
            source(f"{LIB}:{name}")
            fp = by_ref[ref]
            if fp.IsFlipped():
                raise TrimError(f"{m.name}: {ref} ({LIB}:{name}) is on the back: variants are cut "
                                "for the top side only (fplib.py)")
            used.add(name)
            # the placed lines in library order: unplace a copy to find each line's library key
            ref_fp = pcbnew.FOOTPRINT(fp)
            ref_fp.SetOrientationDegrees(0)
            ref_fp.SetPosition(pcbnew.VECTOR2I(0, 0))
            lib_keys = [_key(g) for g in _silk(ref_fp)]
            for g, k in zip(_silk(fp), lib_keys):
                if k in keep[name]:
                    keep[name][k] = [x and y for x, y in zip(keep[name][k], _free(fp, b, g))]
    out = {}
    for name in sorted(used):
        fp = pcbnew.FOOTPRINT(stock[name])
        fp.SetFPID(pcbnew.LIB_ID(LIB, name))
        for g in sorted(_lines(fp), key=_key):
            free = keep[name][_key(g)]
            if all(free):
                continue
            a, e, n = g.GetStart(), g.GetEnd(), len(free)
            k = 0
            while k < n:
                if not free[k]:
                    k += 1
                    continue
                j = k
                while j < n and free[j]:
                    j += 1
                if (j - k) * mm(STEP) >= mm(MIN_PIECE):
                    s = pcbnew.PCB_SHAPE(fp)
                    s.SetShape(pcbnew.SHAPE_T_SEGMENT)
                    s.SetLayer(g.GetLayer())
                    s.SetWidth(g.GetWidth())
                    s.SetStart(_round(_at(a, e, k, n)))
                    s.SetEnd(_round(_at(a, e, j, n)))
                    fp.Add(s)
                k = j
            fp.Remove(g)
        out[name] = fp
    return out


def _round(p: pcbnew.VECTOR2I) -> pcbnew.VECTOR2I:
    """To the micrometre, as the library file stores it."""
    return pcbnew.VECTOR2I(round(p.x / 1000) * 1000, round(p.y / 1000) * 1000)


def apply(board: pcbnew.BOARD, footprints: dict[str, str], lib: dict[str, pcbnew.FOOTPRINT]) -> None:
    """Gives each board footprint whose lib id (`footprints`: reference -> netlist lib id) is a
    variant the variant's silk and lib id; pads, nets and everything else stay as routed."""
    for fp in sorted(board.GetFootprints(), key=lambda f: f.GetReference()):
        lib_id = footprints.get(fp.GetReference(), "")
        if not lib_id.startswith(LIB + ":"):
            continue
        name = lib_id.split(":", 1)[1]
        if name in DRAWN:
            continue          # placed and routed as drawn: nothing to swap in
        placed = pcbnew.FOOTPRINT(lib[name])
        placed.SetPosition(fp.GetPosition())
        placed.SetOrientation(fp.GetOrientation())
        want = {_key(g): g for g in _silk(placed)}
        have = {_key(g): g for g in _silk(fp)}
        for k in sorted(set(have) - set(want)):
            fp.Remove(have[k])
        for k in sorted(set(want) - set(have)):
            g = want[k]
            if g.GetShape() != pcbnew.SHAPE_T_SEGMENT:
                raise TrimError(f"{fp.GetReference()}: variant {lib_id} changes a non-line silk item")
            s = pcbnew.PCB_SHAPE(fp)
            s.SetShape(pcbnew.SHAPE_T_SEGMENT)
            s.SetLayer(g.GetLayer())
            s.SetWidth(g.GetWidth())
            s.SetStart(g.GetStart())
            s.SetEnd(g.GetEnd())
            fp.Add(s)
        fp.SetFPID(pcbnew.LIB_ID(LIB, name))


def write(lib: dict[str, pcbnew.FOOTPRINT], folder: Path) -> None:
    """Writes the variants `folder` (…/R2P.pretty) does not have yet, UUIDs derived from each name."""
    folder.mkdir(parents=True, exist_ok=True)
    io = pcbnew.PCB_IO_MGR.PluginFind(pcbnew.PCB_IO_MGR.KICAD_SEXP)
    for name, fp in sorted(lib.items()):
        if (folder / f"{name}.kicad_mod").exists():
            continue      # the boards' own: edited in KiCad, or cut for placements no longer described
        io.FootprintSave(str(folder), fp)
        f = folder / f"{name}.kicad_mod"
        n = iter(range(1_000_000))
        f.write_text(re.sub(r'\(uuid "[0-9a-f-]+"\)',
                            lambda _: f'(uuid "{uuid.uuid5(_UUID_NS, f"{name}/{next(n)}")}")',
                            f.read_text()))


def folder(hardware: Path) -> Path:
    return hardware / "core" / f"{LIB}.pretty"      # shared by every module, like the core sheet


def build(hardware: Path) -> dict[str, pcbnew.FOOTPRINT]:
    """Writes the variants of every module under `hardware` and loads them.

    Cut in a process of its own: the scratch boards it places parts on would otherwise share
    pcbnew's project settings (the net classes the board is saved with) and its footprint cache
    (whose UUID draws order the routed board's footprints) with the board being generated."""
    out = folder(hardware)
    subprocess.run([sys.executable, "-m", "r2ptools.kicad.fplib", str(out)], check=True,
                   cwd=ROOT / "scripts")
    return {f.stem: pcbnew.FootprintLoad(str(out), f.stem) for f in sorted(out.glob("*.kicad_mod"))}


def main(argv: list[str] | None = None) -> int:
    from .modules import build_all
    args = argv if argv is not None else sys.argv[1:]
    # loaded items get UUIDs from this generator and KiCad orders some by UUID when saving
    pcbnew.KIID.SeedGenerator(0x52325046)
    write(variants(build_all()), Path(args[0]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
