"""R2P message schemas: one `.msg` file per message type in firmware/msgs, ROS-style, with
fixed-size fields only (every message has one size, so the bus and the pools know it up front).

This module is the one reader of that language: `scripts/msggen` turns it into the Rust types
(firmware/crates/r2p-msgs/src/generated.rs), and host tools decode payloads with it directly.

Grammar, one field per line:  TYPE NAME  or  TYPE[N] NAME, then an optional `# comment`.
TYPE is bool, int8..int64, uint8..uint64, float32 or float64. Layout: fields in file order,
little-endian, packed (no padding). The type hash, FNV-1a of the canonical text
`Name:type name;type[N] name;…`, lets publisher and subscriber check that they agree.
"""
from __future__ import annotations

import math
import re
import struct
from dataclasses import dataclass
from pathlib import Path

from . import ROOT

MSG_DIR = ROOT / "firmware" / "msgs"

# schema type -> (struct code, Rust type, bytes)
PRIMITIVES = {
    "bool": ("?", "bool", 1),
    "int8": ("b", "i8", 1), "uint8": ("B", "u8", 1),
    "int16": ("h", "i16", 2), "uint16": ("H", "u16", 2),
    "int32": ("i", "i32", 4), "uint32": ("I", "u32", 4),
    "int64": ("q", "i64", 8), "uint64": ("Q", "u64", 8),
    "float32": ("f", "f32", 4), "float64": ("d", "f64", 8),
}
_FIELD = re.compile(r"^(?P<type>[a-z0-9]+)(?:\[(?P<n>\d+)\])?\s+(?P<name>[a-z][a-z0-9_]*)\s*(?:#\s*(?P<doc>.*))?$")
_TYPE_NAME = re.compile(r"^[A-Z][A-Za-z0-9]*$")
MAX_SIZE = 1014  # one RTCAN message (rtcan::fragment::MAX_MESSAGE_LEN: 127 frames less the transfer CRC)


class SchemaError(ValueError):
    """A .msg file is malformed: the message says which file, which line, and what to do."""


@dataclass(frozen=True)
class Field:
    type: str
    count: int | None       # None: a scalar; N: a fixed array of N
    name: str
    doc: str

    @property
    def size(self) -> int:
        return PRIMITIVES[self.type][2] * (self.count or 1)

    @property
    def canonical(self) -> str:
        return f"{self.type}[{self.count}] {self.name}" if self.count else f"{self.type} {self.name}"


@dataclass(frozen=True)
class MsgType:
    name: str
    doc: str
    fields: tuple[Field, ...]
    path: Path

    @property
    def size(self) -> int:
        return sum(f.size for f in self.fields)

    @property
    def canonical(self) -> str:
        return f"{self.name}:" + ";".join(f.canonical for f in self.fields)

    @property
    def type_hash(self) -> int:
        h = 0x811C9DC5
        for b in self.canonical.encode():
            h = ((h ^ b) * 0x01000193) & 0xFFFFFFFF
        return h

    @property
    def struct_format(self) -> str:
        return "<" + "".join(f"{f.count or ''}{PRIMITIVES[f.type][0]}" for f in self.fields)

    def decode(self, payload: bytes) -> dict:
        """Decodes a payload into {field: value}; arrays become lists."""
        if len(payload) != self.size:
            raise ValueError(f"{self.name} is {self.size} bytes, got {len(payload)}")
        values = list(struct.unpack(self.struct_format, payload))
        out = {}
        for f in self.fields:
            n = f.count or 1
            chunk, values = values[:n], values[n:]
            out[f.name] = chunk if f.count else chunk[0]
        return out

    def encode(self, values: dict) -> bytes:
        """Encodes {field: value} (every field required) into a payload."""
        missing = [f.name for f in self.fields if f.name not in values]
        unknown = sorted(set(values) - {f.name for f in self.fields})
        if missing or unknown:
            raise ValueError(f"{self.name}: missing fields {missing}, unknown fields {unknown}")
        flat = []
        for f in self.fields:
            v = values[f.name]
            if f.count:
                if len(v) != f.count:
                    raise ValueError(f"{self.name}.{f.name} has {f.count} elements, got {len(v)}")
                flat.extend(v)
            else:
                flat.append(v)
        return struct.pack(self.struct_format, *flat)


def parse(path: Path) -> MsgType:
    name = path.stem
    where = path.relative_to(ROOT) if path.is_relative_to(ROOT) else path
    if not _TYPE_NAME.match(name):
        raise SchemaError(f"{where}: message type name {name!r} must be CamelCase letters and digits; rename the file")
    doc_lines, fields, seen = [], [], set()
    for lineno, raw in enumerate(path.read_text().splitlines(), 1):
        line = raw.strip()
        if not line:
            continue
        if line.startswith("#"):
            if not fields:
                doc_lines.append(line.lstrip("#").strip())
            continue
        m = _FIELD.match(line)
        if not m:
            raise SchemaError(f"{where}:{lineno}: cannot read {line!r}: write `TYPE name` or `TYPE[N] name`, "
                              f"name in lower_snake_case")
        ty, n, fname = m.group("type"), m.group("n"), m.group("name")
        if ty not in PRIMITIVES:
            raise SchemaError(f"{where}:{lineno}: unknown type {ty!r}: use one of {', '.join(PRIMITIVES)} "
                              f"(fixed-size fields only)")
        if n is not None and not 1 <= int(n) <= MAX_SIZE:
            raise SchemaError(f"{where}:{lineno}: array length {n} out of range 1..{MAX_SIZE}")
        if fname in seen:
            raise SchemaError(f"{where}:{lineno}: field {fname!r} appears twice")
        seen.add(fname)
        fields.append(Field(ty, int(n) if n else None, fname, (m.group("doc") or "").strip()))
    if not fields:
        raise SchemaError(f"{where}: no fields: a message needs at least one")
    msg = MsgType(name, " ".join(doc_lines), tuple(fields), path)
    if msg.size > MAX_SIZE:
        raise SchemaError(f"{where}: {msg.size} bytes is more than one RTCAN message ({MAX_SIZE} bytes)")
    return msg


def load(directory: Path = MSG_DIR) -> dict[str, MsgType]:
    """Every message type in `directory`, by name."""
    return {m.name: m for m in (parse(p) for p in sorted(directory.glob("*.msg")))}


def nan_safe_equal(a, b) -> bool:
    """Equality for decoded values, with NaN equal to NaN."""
    if isinstance(a, list):
        return len(a) == len(b) and all(nan_safe_equal(x, y) for x, y in zip(a, b))
    if isinstance(a, float) and math.isnan(a):
        return isinstance(b, float) and math.isnan(b)
    return a == b
