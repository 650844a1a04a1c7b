"""Schematic stage of the generator: a module description → its `.kicad_sch` files.

Output layout (relative to the hardware/ folder, or a scratch copy of it):
    <module>/<module>.kicad_sch     root sheet: the module's own parts and the core sheet box
    core/core.kicad_sch             the shared core sheet, with every module's references
"""
from __future__ import annotations

from pathlib import Path

from .design import Module, Sheet
from .drawing import DrawnSheetWriter
from . import sexpr
from .schematic import Instance, SheetWriter, sheet_symbol, uid, write
from .sexpr import Q

CORE_FILE = "../core/core.kicad_sch"


def root_path(module: str) -> str:
    return "/" + uid(module, "sheet")


def child_path(module: str, child: str) -> str:
    return root_path(module) + "/" + uid(module, "sheet", child)


def write_module(m: Module, out: Path, writer: type[SheetWriter] = DrawnSheetWriter) -> Path:
    """The module's root sheet, drawn (`DrawnSheetWriter`) or label-per-pin (`SheetWriter`: the
    same circuit with no wires, the reference the drawing is checked against)."""
    root = m.root
    ports = set()
    w = writer(root, m.name, [Instance(m.name, root_path(m.name))], m.title, m.revision, ports)
    w.build()
    uses = []
    x = w.width + 20
    # a drawn sheet may place a child's box ("sheet:<name>" in Sheet.drawing): inside the drawing,
    # where its pins' labels face the blocks they join; else the boxes go right of the drawing
    drawn = root.drawing if isinstance(w, DrawnSheetWriter) else {}
    placed = bool(root.children) and all(f"sheet:{u.sheet.name}" in drawn for u in root.children)
    for page, use in enumerate(root.children, start=2):
        a = drawn.get(f"sheet:{use.sheet.name}")
        use.at = (round(x / 2.54) * 2.54, 38.1) if a is None else (a.x * 2.54, a.y * 2.54)
        uses += sheet_symbol(m.name, use, m.name, root_path(m.name), page, CORE_FILE)
    folder = out / m.name
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{m.name}.kicad_sch"
    if placed:                      # the drawing's extent holds the boxes: no margin added
        w.items += uses
        uses = []
    write(path, w.document(uses, root=True))
    return path


def write_core(core: Sheet, modules: list[Module], out: Path,
               writer: type[SheetWriter] = DrawnSheetWriter, projects: list[str] = ()) -> Path:
    """The shared sheet, instantiated once by each module (and by each of `projects`: boards
    that use the core but are no longer generated from a description)."""
    names = sorted({m.name for m in modules if any(u.sheet.name == core.name for u in m.root.children)}
                   | set(projects))
    inst = [Instance(n, child_path(n, core.name)) for n in names]
    w = writer(core, core.name, inst, core.title, core.revision, {p.name for p in core.ports})
    folder = out / core.name
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{core.name}.kicad_sch"
    write(path, w.document())
    return path


def core_projects(core_sch: Path) -> list[str]:
    """The projects whose references the shared sheet records."""
    tree = sexpr.parse(core_sch.read_text())
    return sorted({str(proj[1]) for sym in sexpr.find_all(tree, "symbol")
                   for inst in sexpr.find_all(sym, "instances")
                   for proj in sexpr.find_all(inst, "project")})


def add_project(core_sch: Path, project: str, core_name: str = "core") -> bool:
    """Records a new board's use of the shared sheet (KiCad keeps each project's references in
    the sheet file): every symbol gets the references it has in the other projects. The sheet
    itself (a person's edits included) is left as it is. True if the file changed."""
    tree = sexpr.parse(core_sch.read_text())
    changed = False
    for sym in sexpr.find_all(tree, "symbol"):
        inst = sexpr.find(sym, "instances")
        if inst is None or any(str(p[1]) == project for p in sexpr.find_all(inst, "project")):
            continue
        first = sexpr.find(sexpr.find(inst, "project"), "path")
        inst.append(["project", Q(project),
                     ["path", Q(child_path(project, core_name)), *first[2:]]])
        changed = True
    if changed:
        write(core_sch, tree)
    return changed
