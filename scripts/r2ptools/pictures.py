"""Committed plots that regenerate byte for byte on any machine of this kind (issue 23, item 6).

A plot is drawn only from numbers committed beside it (`docs/img/NAME.json` beside
`docs/img/NAME.png`): `make bench` measures, writes the numbers rounded (`write_data`), reads
them back (`read_data`) and draws from what it read. tests/test_pictures.py draws again from the
committed numbers, without measuring, and compares the bytes; so a plot is checked in a second,
and a change of the code it measures (RTCAN, the middleware) changes the numbers and the picture
together, in one run of `make bench`.

The drawing itself is made the same everywhere by:
- `style()`: matplotlib's own defaults, not the user's matplotlibrc nor what an earlier plot in
  the same process set, and the Agg renderer (no display, no GPU);
- fonts: matplotlib's defaults name DejaVu Sans, which the pinned matplotlib wheel ships with
  its own FreeType (scripts/python/requirements.lock); a system copy of DejaVu (Debian's
  fonts-dejavu) is seen too, but the font manager lists matplotlib's files first and picks them
  on a tie. tests/test_pictures.py records the font files each plot opens and refuses any other;
- `save()`: a PNG with no software tag and no date in it.
"""
from __future__ import annotations

import contextlib
import json
import math

from pathlib import Path

SIGNIFICANT = 6
"""Digits a number keeps in a data file: more than a plot can show, few enough that the file
reads as the measurement rather than as floating-point noise."""


def rounded(value):
    """`value` with every float rounded to SIGNIFICANT digits (ints, strings, bools, None as
    they are); a NaN or an infinity is refused: JSON has none, and a plot of one shows
    nothing."""
    if isinstance(value, bool) or value is None or isinstance(value, (int, str)):
        return value
    if isinstance(value, float):
        if not math.isfinite(value):
            raise ValueError(f"{value} is not a number a data file can hold")
        return float(f"{value:.{SIGNIFICANT}g}")
    if isinstance(value, dict):
        return {str(k): rounded(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [rounded(v) for v in value]
    raise TypeError(f"{type(value).__name__} {value!r} is not a number, text or list")


def dumps(generated_by: str, data: dict) -> str:
    """The text of a data file: `{"generated_by": …, **data}` with its numbers rounded, one
    value a line (diffs show which number moved)."""
    if "generated_by" in data:
        raise ValueError("generated_by is the data file's own key")
    body = {"generated_by": generated_by, **rounded(data)}
    return json.dumps(body, indent=1, ensure_ascii=False, allow_nan=False) + "\n"


def write_data(path: Path, generated_by: str, data: dict) -> Path:
    """Writes the data file `path` (see `dumps`)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(dumps(generated_by, data), encoding="utf-8")
    return path


def read_data(path: Path) -> dict:
    """The data file `path`, as written (its `generated_by` included). A file that is missing
    or not one of these is a ValueError that names it and says how to make it again."""
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as e:
        raise ValueError(f"{path}: {e}: regenerate it with make bench") from None
    if not isinstance(data, dict) or "generated_by" not in data:
        raise ValueError(f"{path}: not a plot's data file (no generated_by): regenerate it with "
                         "make bench")
    return data


@contextlib.contextmanager
def style(**rc):
    """pyplot with matplotlib's default style, the Agg renderer and `rc` on top, restored after."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    with plt.style.context("default"), matplotlib.rc_context({"svg.hashsalt": "r2p", **rc}):
        yield plt


def save(fig, path: Path) -> Path:
    """Writes `fig` as a PNG without software tag or date, and closes it."""
    import matplotlib.pyplot as plt
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, metadata={"Software": None})
    plt.close(fig)
    return path
