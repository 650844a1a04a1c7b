"""Reading pass/fail counts out of test runners' own closing lines."""
from __future__ import annotations

import re
from dataclasses import dataclass

# libtest (cargo test) and our QEMU runner both close with this line.
_LIBTEST = re.compile(r"^test result: (ok|FAILED)\. (\d+) passed; (\d+) failed(?:; (\d+) ignored)?", re.M)
# pytest's last line, e.g. "==== 3 passed, 1 failed, 2 skipped in 1.2s ====" (bare with -q).
_PYTEST = re.compile(r"^(?:=+ )?(\d+ \w+(?:, \d+ \w+)*) in [\d.]+s", re.M)


@dataclass
class Counts:
    passed: int = 0
    failed: int = 0
    skipped: int = 0

    def __iadd__(self, other: "Counts") -> "Counts":
        self.passed += other.passed
        self.failed += other.failed
        self.skipped += other.skipped
        return self

    @property
    def total(self) -> int:
        return self.passed + self.failed


def libtest(output: str) -> Counts:
    """Sums every `test result:` line (cargo test prints one per test binary and doc tests)."""
    c = Counts()
    for m in _LIBTEST.finditer(output):
        c.passed += int(m.group(2))
        c.failed += int(m.group(3))
        c.skipped += int(m.group(4) or 0)
    return c


def pytest(output: str) -> Counts:
    """Reads pytest's closing line."""
    c = Counts()
    matches = _PYTEST.findall(output)
    if not matches:
        return c
    for part in matches[-1].split(","):
        words = part.split()
        if len(words) >= 2 and words[0].isdigit():
            n, kind = int(words[0]), words[1]
            if kind == "passed":
                c.passed += n
            elif kind in ("failed", "error", "errors"):
                c.failed += n
            elif kind in ("skipped", "xfailed", "deselected"):
                c.skipped += n
    return c
