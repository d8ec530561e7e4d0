"""The one root exception of navstress and its families.

Every error a user can cause derives from :class:`NavstressError`. The CLI catches
it, prints ``str(err)`` on one line and exits with code 2, writing nothing partial.

Messages name the field, the value, the allowed range and, where possible, the fix::

    >>> raise SpecError("obstacles.obstruction.tree", -3, "a percentage in [0, 100)")
    Traceback (most recent call last):
    ...
    navstress.errors.SpecError: obstacles.obstruction.tree=-3 is invalid: expected a percentage in [0, 100)
"""

from __future__ import annotations

from typing import Any, Final

#: Longest text of a value an error message shows (its start and its end are kept).
MAX_SHOWN = 200


class _Missing:
    """The value of a field that was not given (:data:`MISSING`)."""

    _instance: "_Missing | None" = None

    def __new__(cls) -> "_Missing":
        if cls._instance is None:
            cls._instance = super().__new__(cls)
        return cls._instance

    def __repr__(self) -> str:
        return "<missing>"

    def __reduce__(self) -> str:
        return "MISSING"  # one object, also after pickling (worker processes, Ray)


#: The value of a required field the user left out: its error reads ``field is missing: ...``
#: (never the mapping that lacks it).
MISSING: Final = _Missing()


def shown(value: Any) -> str:
    """``repr(value)``, at most :data:`MAX_SHOWN` characters (a long one keeps its start and end).

        >>> shown("x" * 1000)[:20], len(shown("x" * 1000)) <= MAX_SHOWN
        ("'xxxxxxxxxxxxxxxxxxx", True)
    """
    r = repr(value)
    if len(r) <= MAX_SHOWN:
        return r
    tail = f" ({len(r):,} characters) "
    keep = MAX_SHOWN - len(tail) - 3
    return r[: keep - keep // 4] + "..." + tail + r[len(r) - keep // 4:]


class NavstressError(Exception):
    """Root of every error navstress raises on purpose."""


class SpecError(NavstressError, ValueError):
    """An invalid specification (world, campaign, navigator config, CLI flag)."""

    def __init__(self, field: str, value: Any, expected: str, fix: str | None = None) -> None:
        self.field = field
        self.value = value
        self.expected = expected
        self.fix = fix
        if value is MISSING:
            msg = f"{field} is missing: expected {expected}"
        else:
            msg = f"{field}={shown(value)} is invalid: expected {expected}"
        if fix:
            msg += f"; {fix}"
        super().__init__(msg)

    def __reduce__(self) -> tuple[Any, ...]:
        # picklable with its fields (it crosses process boundaries: worker processes, Ray)
        return (type(self), (self.field, self.value, self.expected, self.fix))


class GenerationError(NavstressError):
    """A world could not be generated as specified (e.g. obstruction target unreachable)."""


class WorldFileError(NavstressError):
    """A world directory is missing, corrupt, or not a world."""


class SimulationError(NavstressError):
    """The simulation could not be built or became unstable."""


class NavigatorError(NavstressError):
    """A navigator could not be found, loaded or configured."""


class StoreError(NavstressError):
    """A campaign store is missing, corrupt or incompatible."""


class OutputPathError(NavstressError):
    """A path inside an output directory that would make navstress write or delete outside it
    (a symbolic link planted inside the directory, a stored path that leaves it)."""
