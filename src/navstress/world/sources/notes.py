"""What an import could not bring over, said once: :class:`SourceWarning`, one line per import
(docs/worlds.md, "Imported Gazebo worlds (SDF)"). ``navstress world import`` prints it as
``warning: ...`` on stderr; elsewhere it is a Python warning of this category."""

from __future__ import annotations

import warnings
from pathlib import Path

#: Names shown per group of the line; the rest are counted.
SHOWN = 6


class SourceWarning(UserWarning):
    """Elements of an imported world that were left out or approximated (one line)."""


def one_line(path: Path, groups: dict[str, list[str]]) -> str:
    """The warning's text: ``FILE: N elements not imported or approximated: GROUP (n): a, b, c (+k more); ...``
    (groups in insertion order, empty ones left out, every name on one line)."""
    parts = []
    total = 0
    for what, names in groups.items():
        if not names:
            continue
        total += len(names)
        flat = [" ".join(n.split()) for n in names]
        shown = ", ".join(flat[:SHOWN]) + (f" (+{len(flat) - SHOWN} more)" if len(flat) > SHOWN else "")
        parts.append(f"{what} ({len(flat)}): {shown}")
    return f"{path}: {total} element{'s' if total != 1 else ''} not imported or approximated: " + "; ".join(parts)


def warn(path: Path, groups: dict[str, list[str]]) -> str | None:
    """Emit the one :class:`SourceWarning` of an import when a group is non-empty; returns its text."""
    if not any(groups.values()):
        return None
    text = one_line(path, groups)
    warnings.warn(text, SourceWarning, stacklevel=3)
    return text
