"""Project library tables naming KiCad's installed libraries (${KICAD9_*_DIR}).

With them the projects open, pass ERC and DRC and match footprints against their libraries on a
machine whose global library tables were never configured (a fresh install, CI, kicad-cli). The
project footprint library R2P (fplib.py) is named relative to the project folder."""
from __future__ import annotations

from pathlib import Path

PROJECT_FP_LIB = "R2P"
"""The project's own footprints (hardware/core/R2P.pretty, fplib.py) and symbols
(hardware/core/R2P.kicad_sym, parts KiCad has no symbol for), shared like the core sheet."""


def write(folder: Path, symbol_libs: list[str], footprint_libs: list[str]) -> None:
    sym = ["(sym_lib_table", "\t(version 7)"]
    for lib in sorted(set(symbol_libs)):
        uri = (f"${{KIPRJMOD}}/../core/{lib}.kicad_sym" if lib == PROJECT_FP_LIB
               else f"${{KICAD9_SYMBOL_DIR}}/{lib}.kicad_sym")
        sym.append(f'\t(lib (name "{lib}")(type "KiCad")(uri "{uri}")(options "")(descr ""))')
    sym.append(")")
    (folder / "sym-lib-table").write_text("\n".join(sym) + "\n")
    fp = ["(fp_lib_table", "\t(version 7)"]
    for lib in sorted(set(footprint_libs)):
        uri = f"${{KIPRJMOD}}/../core/{lib}.pretty" if lib == PROJECT_FP_LIB else f"${{KICAD9_FOOTPRINT_DIR}}/{lib}.pretty"
        fp.append(f'\t(lib (name "{lib}")(type "KiCad")(uri "{uri}")(options "")(descr ""))')
    fp.append(")")
    (folder / "fp-lib-table").write_text("\n".join(fp) + "\n")
