"""KiCad's S-expression files: a small reader and a deterministic writer.

KiCad files are nested lists of atoms (`yes`, `1.27`, `pin`) and quoted strings. The reader keeps
the distinction (`Q` marks a quoted string) so a symbol copied out of a library is written back
exactly as KiCad wrote it; the writer indents like KiCad 9 so generated files diff cleanly.
"""
from __future__ import annotations

from typing import Union


class Q(str):
    """A quoted string (as opposed to a bare atom such as `yes` or `1.27`)."""


Node = Union[str, Q, list]


def parse(text: str) -> list:
    """Parses one top-level S-expression."""
    stack: list[list] = []
    top: list | None = None
    i, n = 0, len(text)
    while i < n:
        c = text[i]
        if c == "(":
            new: list = []
            if stack:
                stack[-1].append(new)
            stack.append(new)
            i += 1
        elif c == ")":
            top = stack.pop()
            i += 1
        elif c in " \t\r\n":
            i += 1
        elif c == '"':
            j, buf = i + 1, []
            while text[j] != '"':
                if text[j] == "\\":
                    nxt = text[j + 1]
                    buf.append({"n": "\n", "t": "\t", "\\": "\\", '"': '"'}.get(nxt, nxt))
                    j += 2
                else:
                    buf.append(text[j])
                    j += 1
            stack[-1].append(Q("".join(buf)))
            i = j + 1
        else:
            j = i
            while j < n and text[j] not in ' \t\r\n()"':
                j += 1
            stack[-1].append(text[i:j])
            i = j
    if top is None or stack:
        raise ValueError("unbalanced S-expression")
    return top


def quote(s: str) -> str:
    return '"' + s.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n") + '"'


def num(x: float) -> str:
    """KiCad's number format: up to 4 decimals, no trailing zeros, no `-0`."""
    s = f"{x:.4f}".rstrip("0").rstrip(".")
    return "0" if s in ("-0", "") else s


def dump(node: Node, indent: int = 0) -> str:
    """Writes a node KiCad-style: short atom-only lists on one line, others one child a line."""
    if isinstance(node, Q):
        return quote(node)
    if isinstance(node, str):
        return node
    if isinstance(node, (int, float)):
        return num(node)
    if all(not isinstance(c, list) for c in node):
        return "(" + " ".join(dump(c) for c in node) + ")"
    pad = "\t" * (indent + 1)
    head = []
    rest = []
    for c in node:
        (rest if rest or isinstance(c, list) else head).append(c)
    out = "(" + " ".join(dump(c) for c in head)
    for c in rest:
        out += "\n" + pad + dump(c, indent + 1)
    return out + "\n" + "\t" * indent + ")"


def find(node: list, key: str) -> list | None:
    """The first child list whose head is `key`."""
    for c in node:
        if isinstance(c, list) and c and c[0] == key:
            return c
    return None


def find_all(node: list, key: str) -> list[list]:
    return [c for c in node if isinstance(c, list) and c and c[0] == key]
