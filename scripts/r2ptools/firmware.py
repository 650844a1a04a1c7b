"""Builds the MCU firmware images listed in firmware/images.toml and modules.toml, reproducibly, and sizes them.

For each image: `cargo build --release --locked` in its workspace with path prefixes remapped
(the repository to /r2p, cargo's home to /cargo, by scripts/rustc-reproducible), so an image built from any folder by any user
is byte-identical; then `.elf`, `.bin` and `.hex` go to firmware/images/. Flash and static RAM
are read from the ELF's sections and checked against the image's budget.

    scripts/firmware build [--out DIR] [--root DIR] [NAME ...]
    scripts/firmware sizes              # table of the committed images
    scripts/firmware verify             # rebuild in another folder, compare with the committed
"""
from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tomllib
from dataclasses import dataclass
from pathlib import Path

from . import ROOT
from . import manifest as modules

IMAGES_DIR = Path("firmware") / "images"
DEFMT_LOG = "warn"
"""defmt's log level in the committed images (debug builds log everything: .cargo/config.toml):
warnings and errors (storage faults, a panic's report) cost ~0.8 KiB of flash, info's few boot
messages 64 B more on a module image, which the A/B slot cannot spare (docs/flashing.md)."""


@dataclass
class Image:
    name: str
    workspace: str
    package: str
    mcu: str
    target: str
    mcu_flash: int
    mcu_ram: int
    budget_flash: int
    budget_ram: int
    origin: int
    """Where the image is linked to start (its vector table): its MCU's `image_origin`, or the
    flash map's active slot for an image behind the bootloader (`slot = "active"`)."""
    features: tuple[str, ...] = ()
    """Cargo features of the release build (module images: `RELEASE_LOG_FEATURES`)."""


FLASH_BASE = 0x0800_0000

RELEASE_LOG_FEATURES = {"targets/f103": ("module-core/raw-log",)}
"""Features a committed module image is built with, by workspace: the F103 module images log
with defmt's raw encoding (module-core's Cargo.toml says what it saves and costs)."""


def manifest(root: Path = ROOT) -> list[Image]:
    """The images to build: firmware/images.toml's own (the core's footprints), then each
    module's image from the module manifest (modules.toml), which lists modules once."""
    data = tomllib.loads((root / "firmware" / "images.toml").read_text())
    out = []
    for i in data.get("image", []):
        mcu = data["mcu"][i["mcu"]]
        out.append(Image(i["name"], i["workspace"], i["package"], i["mcu"], mcu["target"],
                         mcu["flash"], mcu["ram"], i["budget_flash"], i["budget_ram"], mcu["image_origin"]))
    for m in modules.load(root, check_tree=False):
        if m.image:
            i, mcu = m.image, data["mcu"][m.image.mcu]
            origin = (FLASH_BASE + mcu["partitions"]["active"]["offset"] if i.slot == "active"
                      else mcu["image_origin"])
            out.append(Image(m.name, i.workspace, i.package, i.mcu, mcu["target"], mcu["flash"],
                             mcu["ram"], i.budget_flash, i.budget_ram, origin,
                             RELEASE_LOG_FEATURES.get(i.workspace, ())))
    return out


def cargo_home() -> Path:
    return Path(os.environ.get("CARGO_HOME", Path.home() / ".cargo")).resolve()


def reproducible_env(root: Path) -> dict[str, str]:
    """Environment for a build whose output does not depend on where the sources are."""
    env = dict(os.environ)
    env["RUSTC_WRAPPER"] = str(ROOT / "scripts" / "rustc-reproducible")
    env["R2P_ROOT"] = str(root.resolve())
    env["R2P_CARGO_HOME"] = str(cargo_home())
    # R2P_BOOT_PUBLIC_KEY builds a bootloader for a user's key; the committed one trusts the
    # development key whatever the environment says.
    for var in ("RUSTFLAGS", "CARGO_ENCODED_RUSTFLAGS", "CARGO_BUILD_RUSTFLAGS", "R2P_BOOT_PUBLIC_KEY"):
        env.pop(var, None)
    # defmt's compile-time log filter: the committed images log warnings and errors (module-core's
    # storage faults, a panic's report); a DEFMT_LOG in the caller's environment must not change them.
    env["DEFMT_LOG"] = DEFMT_LOG
    return env


@dataclass
class Size:
    flash: int   # bytes of flash the image spans: code, read-only data, .data's initial values, padding
    ram: int     # bytes of static RAM: .data + .bss (+ uninit); the stack is what is left


def size_of(elf: Path) -> Size:
    """Reads the ELF's program headers: flash is the span of the loaded bytes (what the .bin holds
    and the programmer writes), static RAM the memory size of the segments that live in RAM."""
    out = subprocess.run(["arm-none-eabi-readelf", "-lW", str(elf)], capture_output=True, text=True,
                         check=True).stdout
    lo, hi, ram = None, 0, 0
    for line in out.splitlines():
        parts = line.split()
        if not parts or parts[0] != "LOAD":
            continue
        vaddr, paddr, filesz, memsz = (int(x, 16) for x in parts[2:6])
        if filesz:
            lo = paddr if lo is None else min(lo, paddr)
            hi = max(hi, paddr + filesz)
        if vaddr >= 0x2000_0000 or 0x1000_0000 <= vaddr < 0x1001_0000:  # SRAM; the F4's CCM RAM
            ram += memsz
    return Size(hi - (lo or 0) if lo is not None else 0, ram)


def build(img: Image, root: Path, out: Path) -> Size:
    ws = root / "firmware" / img.workspace
    # A target dir of its own: cargo's fingerprints ignore RUSTC_WRAPPER, so a plain `cargo build`
    # in the same dir would otherwise be reused as if it had been remapped.
    target_dir = ws / "target" / "reproducible"
    # embassy-stm32's build script runs rustfmt on the code it generates, and rustfmt takes the
    # first rustfmt.toml found above the file: pin it here, or a rustfmt.toml in any folder
    # above the checkout would change the image's line tables.
    target_dir.mkdir(parents=True, exist_ok=True)
    (target_dir / "rustfmt.toml").write_text("# Written by scripts/firmware: rustfmt defaults for generated code.\n")
    features = ["--features", ",".join(img.features)] if img.features else []
    subprocess.run(["cargo", "build", "--release", "--locked", "-p", img.package, *features,
                    "--target-dir", str(target_dir)], cwd=ws, env=reproducible_env(root), check=True)
    elf = target_dir / img.target / "release" / img.package
    out.mkdir(parents=True, exist_ok=True)
    dst = out / f"{img.name}.elf"
    shutil.copyfile(elf, dst)
    subprocess.run(["arm-none-eabi-objcopy", "-O", "binary", str(dst), str(out / f"{img.name}.bin")], check=True)
    subprocess.run(["arm-none-eabi-objcopy", "-O", "ihex", str(dst), str(out / f"{img.name}.hex")], check=True)
    return size_of(dst)


def over_budget(img: Image, s: Size) -> list[str]:
    errs = []
    if s.flash > img.budget_flash:
        errs.append(f"{img.name}: flash {s.flash} B exceeds its budget of {img.budget_flash} B "
                    f"(firmware/images.toml, modules.toml for a module): shrink the image or raise the budget with a reason")
    if s.ram > img.budget_ram:
        errs.append(f"{img.name}: static RAM {s.ram} B exceeds its budget of {img.budget_ram} B "
                    f"(firmware/images.toml, modules.toml for a module): shrink the image or raise the budget with a reason")
    return errs


# Where `verify` rebuilds: another folder, so a path leaking into an image shows up as a
# difference. It persists (and keeps its cargo target dirs) so that reruns are incremental.
VERIFY_COPY = ROOT / ".cache" / "reproducible-copy"
COPIED = ["rust-toolchain.toml", "rustfmt.toml", "modules.toml", "firmware"]


def sync_copy(src: Path, dst: Path) -> None:
    """Mirrors the firmware sources into dst, keeping dst's cargo target dirs, and file mtimes
    so that cargo rebuilds only what changed."""
    dst.mkdir(parents=True, exist_ok=True)
    subprocess.run(["rsync", "-a", "--delete", "--exclude", "target/", "--exclude", "/firmware/images/",
                    *[str(src / n) for n in COPIED], f"{dst}/"], check=True)


def verify(names: list[str] | None = None) -> list[str]:
    """Rebuilds the images from a copy of the sources in another folder; returns the committed
    files that differ from the rebuild (empty when everything regenerates byte for byte)."""
    sync_copy(ROOT, VERIFY_COPY)
    out = VERIFY_COPY / "rebuilt-images"
    if out.exists():
        shutil.rmtree(out)
    for img in manifest(VERIFY_COPY):
        if names and img.name not in names:
            continue
        build(img, VERIFY_COPY, out)
    diffs = []
    committed = ROOT / IMAGES_DIR
    for f in sorted(out.iterdir()):
        c = committed / f.name
        if not c.exists():
            diffs.append(f"{IMAGES_DIR / f.name}: not committed (run `make firmware` and commit it)")
        elif c.read_bytes() != f.read_bytes():
            diffs.append(f"{IMAGES_DIR / f.name}: differs from a rebuild in {out}")
    return diffs


def table(rows: list[tuple[Image, Size | None]]) -> str:
    lines = [f"{'image':<18} {'MCU':<12} {'flash used':>22} {'static RAM':>20}  budget (flash/RAM)"]
    for img, s in rows:
        if s is None:
            lines.append(f"{img.name:<18} {img.mcu:<12} {'not built':>22}")
            continue
        fl = f"{s.flash/1024:6.1f} / {img.mcu_flash//1024} KiB {100*s.flash/img.mcu_flash:4.1f}%"
        ra = f"{s.ram/1024:5.1f} / {img.mcu_ram//1024} KiB {100*s.ram/img.mcu_ram:4.1f}%"
        ok = "ok" if not over_budget(img, s) else "OVER"
        lines.append(f"{img.name:<18} {img.mcu:<12} {fl:>22} {ra:>20}  "
                     f"{img.budget_flash//1024}/{img.budget_ram//1024} KiB {ok}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="firmware", description="Build and size R2P firmware images.")
    sub = ap.add_subparsers(dest="cmd", required=True)
    b = sub.add_parser("build", help="build images into firmware/images (or --out)")
    b.add_argument("names", nargs="*", help="image names from firmware/images.toml (default: all)")
    b.add_argument("--root", type=Path, default=ROOT, help="repository to build from (default: this one)")
    b.add_argument("--out", type=Path, help="where to put the images (default: ROOT/firmware/images)")
    sub.add_parser("sizes", help="size table of the images in firmware/images")
    sub.add_parser("verify", help="rebuild from another folder; fail unless identical to the committed images")
    args = ap.parse_args(argv)

    if args.cmd == "sizes":
        rows = []
        for img in manifest():
            elf = ROOT / IMAGES_DIR / f"{img.name}.elf"
            rows.append((img, size_of(elf) if elf.exists() else None))
        print(table(rows))
        return 0

    if args.cmd == "verify":
        diffs = verify()
        for d in diffs:
            print(f"firmware verify: {d}", file=sys.stderr)
        if diffs:
            print("firmware verify: committed images are stale or not reproducible: run `make firmware`, "
                  "commit firmware/images, and if they still differ look for a path or date in the image",
                  file=sys.stderr)
            return 1
        print(f"firmware verify: all {len(manifest())} images regenerate byte for byte from another folder")
        return 0

    root = args.root.resolve()
    imgs = manifest(root)
    unknown = set(args.names) - {i.name for i in imgs}
    if unknown:
        print(f"firmware: no image named {', '.join(sorted(unknown))} in firmware/images.toml or modules.toml; "
              f"known: {', '.join(i.name for i in imgs)}", file=sys.stderr)
        return 2
    out = (args.out or root / IMAGES_DIR).resolve()
    rows, errors = [], []
    for img in imgs:
        if args.names and img.name not in args.names:
            continue
        try:
            s = build(img, root, out)
        except subprocess.CalledProcessError as e:
            print(f"firmware: building {img.name} failed: `{' '.join(map(str, e.cmd))}` exited "
                  f"{e.returncode} in firmware/{img.workspace}; cargo's message is above", file=sys.stderr)
            return 1
        rows.append((img, s))
        errors += over_budget(img, s)
    print(table(rows))
    for e in errors:
        print(f"firmware: {e}", file=sys.stderr)
    return 1 if errors else 0


if __name__ == "__main__":
    sys.exit(main())
