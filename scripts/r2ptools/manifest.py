"""The module manifest (`modules.toml` at the repository root): the one list of R2P modules.

Every tool that needs the modules reads them here — `make`'s summary, `make fab`, the firmware
images, the layout test, the scaffold (`scripts/new-module`) — so adding a module is one entry,
not a hunt through hand-written lists. The Rust readers (r2p-boardgen's test, the emulator's kind
table) parse the same file and agree with this one's checks.

A malformed or inconsistent entry raises `ManifestError`, whose text names the file, the line
and what to write instead: `modules.toml:31: module "servo": board_file
firmware/boards/servo.toml does not exist; write the board file (docs/board-files.md) or remove
the key`.

    scripts/py -m r2ptools.manifest            # check the manifest, list the modules
"""
from __future__ import annotations

import re
import sys
import tomllib
from dataclasses import dataclass
from pathlib import Path

from . import ROOT

FILE = "modules.toml"
NAME = re.compile(r"^[a-z][a-z0-9-]*$")
"""A module's name: also a folder, a file stem, a cargo package and a robot-file kind."""

REQUIRED = {"name": str, "kind": str, "hardware": str, "fab": bool, "case": bool}
OPTIONAL = {"board_file": str, "app": str, "emulator": str, "image": dict}
IMAGE_KEYS = {"workspace": str, "package": str, "mcu": str, "budget_flash": int, "budget_ram": int}
IMAGE_OPTIONAL = {"slot": str}
"""`slot = "active"`: the image runs behind its MCU's bootloader, linked in the flash map's active
slot (firmware/images.toml); without it, alone from the flash base."""
SLOTS = ("active",)


class ManifestError(ValueError):
    """A manifest entry that cannot be used: the message says where and what to do."""


@dataclass(frozen=True)
class ModuleImage:
    workspace: str
    package: str
    mcu: str
    budget_flash: int
    budget_ram: int
    slot: str | None = None


@dataclass(frozen=True)
class Module:
    name: str
    kind: str
    hardware: str
    fab: bool
    case: bool
    board_file: str | None = None
    app: str | None = None
    emulator: str | None = None
    image: ModuleImage | None = None

    @property
    def pcb(self) -> str:
        """Where its board's layout is (or will be)."""
        return f"{self.hardware}/{self.name}.kicad_pcb"


def _entry_lines(text: str) -> list[tuple[int, dict[str, int]]]:
    """For each [[module]] table: the line of its header and of each key in it (1-based)."""
    out: list[tuple[int, dict[str, int]]] = []
    for n, line in enumerate(text.splitlines(), 1):
        s = line.strip()
        if s == "[[module]]":
            out.append((n, {}))
        elif out and (m := re.match(r"([A-Za-z0-9_-]+)\s*=", s)):
            out[-1][1].setdefault(m.group(1), n)
    return out


def _type_name(t: type) -> str:
    return {str: "a string", bool: "true or false", int: "an integer", dict: "an inline table"}[t]


def load(root: Path = ROOT, check_tree: bool = True) -> list[Module]:
    """The modules of `root/modules.toml`, in file order, every entry checked (and, with
    `check_tree`, checked against the files it names)."""
    path = root / FILE
    where = path.relative_to(root) if path.is_relative_to(root) else path
    try:
        text = path.read_text()
    except FileNotFoundError:
        raise ManifestError(f"{where}: missing; it lists the modules (docs/adding-a-module.md)") from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise ManifestError(f"{where}: not valid TOML: {e}; fix the line it names") from None
    lines = _entry_lines(text)
    extra = sorted(set(data) - {"module"})
    if extra:
        raise ManifestError(f"{where}: unknown top-level table `{extra[0]}`; only [[module]] "
                            "tables belong here (MCUs are in firmware/images.toml)")
    entries = data.get("module", [])
    if not isinstance(entries, list) or not entries:
        raise ManifestError(f"{where}: no [[module]] table; add one per module")
    mcus = _mcus(root) if check_tree else None
    out: list[Module] = []
    seen: dict[str, int] = {}
    for i, e in enumerate(entries):
        head, keys = lines[i] if i < len(lines) else (0, {})

        def fail(msg: str, key: str | None = None) -> ManifestError:
            line = keys.get(key, head) if key else head
            who = f'module "{e["name"]}"' if isinstance(e.get("name"), str) else f"module #{i + 1}"
            return ManifestError(f"{where}:{line}: {who}: {msg}")

        for key, t in REQUIRED.items():
            if key not in e:
                raise fail(f"`{key}` is missing; add `{key} = …` ({_type_name(t)})")
        for key, value in e.items():
            t = REQUIRED.get(key) or OPTIONAL.get(key)
            if t is None:
                known = ", ".join([*REQUIRED, *OPTIONAL])
                raise fail(f"unknown key `{key}`; the keys are {known}", key)
            if type(value) is not t:
                raise fail(f"`{key}` must be {_type_name(t)}, not {value!r}", key)
        name = e["name"]
        if not NAME.match(name):
            raise fail(f"name {name!r} is not lowercase letters, digits and `-` starting with a "
                       "letter (it names folders, files and a cargo package)", "name")
        if name in seen:
            raise fail(f"listed twice (also at line {seen[name]}); remove one entry", "name")
        seen[name] = head
        expected = {"hardware": f"hardware/{name}", "board_file": f"firmware/boards/{name}.toml",
                    "app": f"firmware/apps/{name}"}
        for key, want in expected.items():
            if key in e and e[key] != want:
                raise fail(f"`{key}` is {e[key]!r}; a module's {key} is {want!r} (tools find "
                           "it by the module's name)", key)
        image = None
        if "image" in e:
            img = e["image"]
            for key, t in IMAGE_KEYS.items():
                if key not in img:
                    raise fail(f"image: `{key}` is missing; add it ({_type_name(t)})", "image")
                if type(img[key]) is not t:
                    raise fail(f"image: `{key}` must be {_type_name(t)}, not {img[key]!r}", "image")
            unknown = sorted(set(img) - set(IMAGE_KEYS) - set(IMAGE_OPTIONAL))
            if unknown:
                raise fail(f"image: unknown key `{unknown[0]}`; the keys are "
                           f"{', '.join([*IMAGE_KEYS, *IMAGE_OPTIONAL])}", "image")
            if "slot" in img and img["slot"] not in SLOTS:
                raise fail(f"image: slot {img['slot']!r} is not one of {', '.join(SLOTS)} (or leave "
                           "it out for an image alone in flash)", "image")
            if "app" not in e or "board_file" not in e:
                raise fail("an image needs the module's `app` and `board_file`; add them or "
                           "remove the image", "image")
            image = ModuleImage(**img)
            if mcus is not None:
                if image.mcu not in mcus:
                    raise fail(f"image: mcu {image.mcu!r} is not a [mcu.*] of firmware/images.toml "
                               f"(one of {', '.join(sorted(mcus))})", "image")
                flash, ram = mcus[image.mcu]
                if not 0 < image.budget_flash <= flash or not 0 < image.budget_ram <= ram:
                    raise fail(f"image: the budget ({image.budget_flash} B flash, {image.budget_ram} B "
                               f"RAM) must be positive and within the {image.mcu}'s {flash} B and "
                               f"{ram} B", "image")
        m = Module(name, e["kind"], e["hardware"], e["fab"], e["case"], e.get("board_file"),
                   e.get("app"), e.get("emulator"), image)
        if check_tree:
            _check_tree(root, m, fail)
        out.append(m)
    if check_tree:
        _check_unlisted(root, where, {m.name for m in out})
    return out


def _check_unlisted(root: Path, where: Path, listed: set[str]) -> None:
    """A module's rooms without its entry: the tools that find boards by folder (check-pins,
    bom, enclosures, the board checks) would see a module the manifest's readers do not."""
    rooms = [(d.name, f"hardware/{d.name}/{d.name}.kicad_pro") for d in sorted((root / "hardware").glob("*/"))
             if (d / f"{d.name}.kicad_pro").is_file()]
    rooms += [(f.stem, f"firmware/boards/{f.name}") for f in sorted((root / "firmware" / "boards").glob("*.toml"))
              if not f.stem.startswith("core-")]
    rooms += [(d.name, f"firmware/apps/{d.name}/") for d in sorted((root / "firmware" / "apps").glob("*/"))
              if d.name != "base"]   # base: the robot-level nodes the emulated gateway runs
    for name, path in rooms:
        if name not in listed:
            raise ManifestError(f"{where}: {path} belongs to module {name!r}, which has no [[module]] "
                                f"entry; add one (docs/adding-a-module.md) or remove the files")


def _mcus(root: Path) -> dict[str, tuple[int, int]]:
    data = tomllib.loads((root / "firmware" / "images.toml").read_text())
    return {k: (v["flash"], v["ram"]) for k, v in data.get("mcu", {}).items()}


def _check_tree(root: Path, m: Module, fail) -> None:
    """The files the entry names exist (a tool reading it would otherwise fail far away)."""
    if not (root / m.hardware / "README.md").is_file():
        raise fail(f"{m.hardware}/README.md does not exist; every module has its hardware folder "
                   "with a README (copy hardware/template/README.md)", "hardware")
    for key, what in (("board_file", "write the board file (docs/board-files.md)"),
                      ("app", "make the application crate (from firmware/apps/template)")):
        p = getattr(m, key)
        if p and not (root / p).exists():
            raise fail(f"{key} {p} does not exist; {what} or remove the key", key)
    for key in ("fab", "case"):
        if getattr(m, key) and not (root / m.pcb).is_file():
            raise fail(f"`{key} = true` but {m.pcb} does not exist; design the board first "
                       f"(scripts/hwgen) or set `{key} = false`", key)
    if m.image and not (root / "firmware" / m.image.workspace / m.image.package / "Cargo.toml").is_file():
        raise fail(f"image: firmware/{m.image.workspace}/{m.image.package}/Cargo.toml does not "
                   "exist; add the image crate (scripts/new-module writes one) or remove the image",
                   "image")


def names(root: Path = ROOT) -> list[str]:
    return [m.name for m in load(root)]


def main(argv: list[str] | None = None) -> int:
    try:
        modules = load(Path(argv[0]) if argv else ROOT)
    except ManifestError as e:
        print(f"manifest: {e}", file=sys.stderr)
        return 1
    for m in modules:
        flags = [k for k in ("fab", "case") if getattr(m, k)]
        print(f"{m.name:<12} {'image' if m.image else '-':<6} {' '.join(flags):<9} {m.kind}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
