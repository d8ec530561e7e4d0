"""How navstress writes a rate or a probability for a person: one set of rules for the gate,
``compare``, ``analyze``, ``campaign status`` and the report.

- :func:`percent`, a measured rate (successes of runs, a bound, a share): whole percent, as
  counts of a few dozen runs carry no more; one decimal near the ends, so that a rate that is not
  exactly 0 or 1 never reads ``0%`` or ``100%`` (``99.6%``, ``0.4%``); beyond that ``<0.1%`` /
  ``>99.9%``. No value prints more than one decimal (never ``66.6667%``).
- :func:`percent_vs`, a measured value written next to a bar it is compared with: as
  :func:`percent`, with the decimals needed for the text to stand on the same side of the bar as
  the value (a bound of 79.96% against a bar of 80% reads ``79.96% < 80%``, never ``80% < 80%``).
- :func:`setting`, a number the user chose (a confidence, a threshold, a bar): as written,
  ``95%``, ``97.5%``, ``99.99%``.
- :func:`points`, a difference of two rates in percentage points, signed: ``+12``, ``-0.4``.

A missing value (None, NaN) is ``-``, as in every table.

    >>> percent(2 / 3), percent(0.996), percent(1.0), percent(0.99999), percent(None)
    ('67%', '99.6%', '100%', '>99.9%', '-')
    >>> percent_vs(0.79996, 0.8), setting(0.975), points(-0.004)
    ('79.996%', '97.5%', '-0.4')
"""

from __future__ import annotations

import math

__all__ = ["percent", "percent_vs", "points", "setting"]

_MISSING = "-"


#: The bounded texts near the ends and the open interval of percentages each stands for.
_ENDS = {"<0.1": (0.0, 0.1), ">99.9": (99.9, 100.0)}


def _missing(x: float | None) -> bool:
    return x is None or not math.isfinite(x)


def _number(x: float) -> str:
    """``100 * x`` with 0 or 1 decimals (no sign for a zero), bounded text near 0 and 100."""
    v = 100.0 * x
    s = f"{v:.0f}"
    if (s in ("0", "-0") and x != 0.0) or (s == "100" and x < 1.0) or (s == "-100" and x > -1.0):
        s = f"{v:.1f}"
        if s in ("0.0", "-0.0"):
            return "<0.1" if v > 0 else "-<0.1" if v < 0 else "0"
        if s == "100.0" and x < 1.0:
            return ">99.9"
        if s == "-100.0" and x > -1.0:
            return "->99.9"
    return "0" if s == "-0" else s


def percent(x: float | None) -> str:
    """A measured rate in [0, 1] as a percentage (module doc): ``67%``, ``99.6%``, ``100%``."""
    if _missing(x):
        return _MISSING
    assert x is not None
    return f"{_number(x)}%"


def percent_vs(x: float | None, bar: float) -> str:
    """``x`` as :func:`percent` writes it, with more decimals when needed for the text to relate
    to ``bar`` (written exactly, as :func:`setting` does) as ``x`` does: below, equal or above."""
    if _missing(x):
        return _MISSING
    assert x is not None
    want = (x > bar) - (x < bar)
    target = 100.0 * bar
    for text in [_number(x), *(f"{100.0 * x:.{d}f}" for d in range(2, 10))]:
        if text in _ENDS:  # "<0.1", ">99.9": the value lies inside the open interval
            lo, hi = _ENDS[text]
            if (want > 0 and target <= lo) or (want < 0 and target >= hi):
                return f"{text}%"
            continue
        shown = float(text)
        if (shown == 100.0 and x < 1.0) or (shown == 0.0 and x > 0.0):
            continue  # never an end the value does not reach
        if (shown > target) - (shown < target) == want:
            return f"{text}%"
    return f"{100.0 * x!r}%"


def setting(x: float) -> str:
    """A number the user chose, as a percentage without rounding it (up to 4 decimals):
    ``95%``, ``97.5%``, ``99.99%``."""
    if _missing(x):
        return _MISSING
    v = 100.0 * x
    s = f"{v:.4f}".rstrip("0").rstrip(".")
    return f"{'0' if s == '-0' else s}%"


def points(d: float | None) -> str:
    """A difference of two rates (B - A) in signed percentage points: ``+12``, ``-0.4``, ``0``."""
    if _missing(d):
        return _MISSING
    assert d is not None
    s = _number(d)
    if s == "0":
        return "0"
    return s if s.startswith("-") else f"+{s}"
