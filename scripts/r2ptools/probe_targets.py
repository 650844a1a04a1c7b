"""Checks firmware images against probe-rs's own description of their chip.

probe-rs flashes an ELF by its loadable segments, into the memory regions its target
description gives for the chip (`targets/<Family>_Series.yaml` in the `probe-rs` crate). This
module reads those descriptions from the `probe-rs` crate pinned in firmware/tools/probe-rs
(fetched by cargo from crates.io into its registry cache: seconds, nothing is built) and checks
an image against them: every loaded byte inside the chip's flash, every allocated section inside
its flash or RAM, and the vector table where images are linked to start (`image_origin` of the
MCU in firmware/images.toml, the one place it is named: the chip boots through it, and item 2's
bootloader will jump through it).

    scripts/py -m r2ptools.probe_targets        # check every image of the manifests
"""
from __future__ import annotations

import json
import struct
import subprocess
import sys
import tomllib
from dataclasses import dataclass
from pathlib import Path

import yaml

from . import ROOT
from . import firmware

PIN = Path("firmware") / "tools" / "probe-rs"
"""The package that pins the probe-rs crate (its Cargo.toml and Cargo.lock)."""


class TargetsError(RuntimeError):
    """The target descriptions could not be had: the message says why and what to do."""


def crate_dir(root: Path = ROOT) -> Path:
    """The pinned probe-rs crate's source, fetched by cargo if it is not in its cache yet."""
    manifest = root / PIN / "Cargo.toml"
    fetch = subprocess.run(["cargo", "fetch", "--locked", "--manifest-path", str(manifest)],
                           capture_output=True, text=True)
    if fetch.returncode != 0:
        raise TargetsError(f"`cargo fetch --locked --manifest-path {PIN}/Cargo.toml` failed (crates.io "
                           f"must be reachable once, to fetch the probe-rs crate):\n{fetch.stderr}")
    meta = subprocess.run(["cargo", "metadata", "--locked", "--offline", "--format-version", "1",
                           "--manifest-path", str(manifest)], capture_output=True, text=True, check=True)
    pkgs = [p for p in json.loads(meta.stdout)["packages"] if p["name"] == "probe-rs"]
    if len(pkgs) != 1:
        raise TargetsError(f"{PIN}/Cargo.lock resolves {len(pkgs)} probe-rs packages, expected one")
    return Path(pkgs[0]["manifest_path"]).parent


class _Loader(yaml.SafeLoader):
    """probe-rs's YAML tags its memory regions (`!Nvm`, `!Ram`, …): keep the tag as `kind`."""


def _tagged(loader: _Loader, suffix: str, node: yaml.Node) -> dict:
    if isinstance(node, yaml.MappingNode):
        value = loader.construct_mapping(node, deep=True)
    elif isinstance(node, yaml.SequenceNode):
        value = loader.construct_sequence(node, deep=True)
    else:
        value = loader.construct_scalar(node)
    return {"kind": suffix, "value": value}


_Loader.add_multi_constructor("!", _tagged)


@dataclass(frozen=True)
class Region:
    kind: str      # "Nvm" (flash), "Ram", …
    name: str
    start: int
    end: int       # exclusive

    def holds(self, lo: int, hi: int) -> bool:
        return self.start <= lo and hi <= self.end


def chip_regions(crate: Path, chip: str) -> list[Region]:
    """The memory map probe-rs gives `chip` (its exact variant name, as modules.toml's `mcu`)."""
    for f in sorted((crate / "targets").glob("*.yaml")):
        text = f.read_text()
        if f"name: {chip}\n" not in text:
            continue
        for variant in yaml.load(text, Loader=_Loader).get("variants", []):
            if variant["name"] == chip:
                return [Region(r["kind"], r["value"].get("name", ""), r["value"]["range"]["start"],
                               r["value"]["range"]["end"]) for r in variant["memory_map"]]
    raise TargetsError(f"probe-rs {crate.name} has no chip named {chip} in {crate / 'targets'}: "
                       f"an image's `mcu` must be probe-rs's name of its chip")


@dataclass(frozen=True)
class Segment:
    vaddr: int
    paddr: int
    filesz: int
    memsz: int


@dataclass(frozen=True)
class Section:
    name: str
    addr: int
    size: int


@dataclass
class Elf:
    segments: list[Segment]   # the PT_LOAD ones: what probe-rs writes
    sections: list[Section]   # the allocated ones (SHF_ALLOC), non-empty
    data: bytes
    offsets: list[int]        # each segment's offset in `data`

    def word_at(self, addr: int) -> int | None:
        """The 32-bit word the image loads at flash address `addr`, or None."""
        for s, off in zip(self.segments, self.offsets):
            if s.paddr <= addr and addr + 4 <= s.paddr + s.filesz:
                return struct.unpack_from("<I", self.data, off + addr - s.paddr)[0]
        return None


def read_elf(path: Path) -> Elf:
    """The loadable segments and allocated sections of a 32-bit little-endian ELF."""
    data = path.read_bytes()
    if data[:4] != b"\x7fELF" or data[4] != 1 or data[5] != 1:
        raise ValueError(f"{path}: not a 32-bit little-endian ELF")
    (phoff, shoff, _flags, _ehsize, phentsize, phnum, shentsize, shnum, shstrndx) = struct.unpack_from(
        "<IIIHHHHHH", data, 28)
    segments, offsets = [], []
    for i in range(phnum):
        p_type, p_offset, p_vaddr, p_paddr, p_filesz, p_memsz = struct.unpack_from("<IIIIII", data, phoff + i * phentsize)
        if p_type == 1:  # PT_LOAD
            segments.append(Segment(p_vaddr, p_paddr, p_filesz, p_memsz))
            offsets.append(p_offset)
    headers = [struct.unpack_from("<IIIIIIIIII", data, shoff + i * shentsize) for i in range(shnum)]
    strtab = headers[shstrndx][4]
    sections = []
    for name, _type, flags, addr, _off, size, *_ in headers:
        if flags & 0x2 and size:  # SHF_ALLOC
            sections.append(Section(data[strtab + name:data.index(b"\0", strtab + name)].decode(), addr, size))
    return Elf(segments, sections, data, offsets)


def image_origin(mcu: str, root: Path = ROOT) -> int:
    """Where images for `mcu` are linked to start: their vector table (firmware/images.toml)."""
    return tomllib.loads((root / "firmware" / "images.toml").read_text())["mcu"][mcu]["image_origin"]


def contiguous(regions: list[Region]) -> list[Region]:
    """Regions of one kind that touch, merged (the F4's SRAM and SRAM2 are one range to a linker)."""
    out: list[Region] = []
    for r in sorted(regions, key=lambda r: (r.kind, r.start)):
        if out and out[-1].kind == r.kind and out[-1].end == r.start:
            out[-1] = Region(r.kind, f"{out[-1].name}+{r.name}", out[-1].start, r.end)
        else:
            out.append(r)
    return out


def check(name: str, elf: Elf, regions: list[Region], origin: int) -> list[str]:
    """What is wrong with image `name` on a chip with `regions`: empty when probe-rs can flash it
    and the chip (or a bootloader) finds its vector table at `origin`."""
    flash = [r for r in contiguous(regions) if r.kind == "Nvm"]
    ram = [r for r in contiguous(regions) if r.kind == "Ram"]
    errs = []
    for s in elf.segments:
        if s.filesz and not any(r.holds(s.paddr, s.paddr + s.filesz) for r in flash):
            errs.append(f"{name}: {s.filesz} B loaded at {s.paddr:#010x} lie outside the chip's flash "
                        f"({', '.join(f'{r.name} {r.start:#x}..{r.end:#x}' for r in flash)})")
    for s in elf.sections:
        if not any(r.holds(s.addr, s.addr + s.size) for r in flash + ram):
            errs.append(f"{name}: section {s.name} ({s.size} B at {s.addr:#010x}) lies outside the chip's flash and RAM")
    vt = next((s for s in elf.sections if s.name == ".vector_table"), None)
    if vt is None or vt.addr != origin:
        errs.append(f"{name}: the vector table is at {vt.addr:#010x}, " if vt else f"{name}: no .vector_table section, ")
        errs[-1] += (f"expected at {origin:#010x} (image_origin in firmware/images.toml, or the active "
                     "slot of its flash map for an image behind the bootloader)")
    else:
        sp, reset = elf.word_at(origin), elf.word_at(origin + 4)
        if sp is None or not any(r.start < sp <= r.end for r in ram):
            errs.append(f"{name}: the initial stack pointer {sp and hex(sp)} is not in the chip's RAM")
        if reset is None or not reset & 1 or not any(r.holds(reset & ~1, (reset & ~1) + 2) for r in flash):
            errs.append(f"{name}: the reset vector {reset and hex(reset)} is not Thumb code in the chip's flash")
    return errs


def check_all(root: Path = ROOT) -> list[str]:
    """Checks every committed image of the manifests (firmware/images.toml, modules.toml)."""
    crate = crate_dir(root)
    errs = []
    for img in firmware.manifest(root):
        elf = read_elf(root / firmware.IMAGES_DIR / f"{img.name}.elf")
        errs += check(img.name, elf, chip_regions(crate, img.mcu), img.origin)
    return errs


def main() -> int:
    try:
        errs = check_all()
    except TargetsError as e:
        print(f"probe_targets: {e}", file=sys.stderr)
        return 2
    for e in errs:
        print(f"probe_targets: {e}", file=sys.stderr)
    if not errs:
        print(f"probe_targets: all {len(firmware.manifest())} images fit probe-rs's description of their chip")
    return 1 if errs else 0


if __name__ == "__main__":
    sys.exit(main())
