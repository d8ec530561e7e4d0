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

from typing import Any


class NavstressError(Exception):
    """Root of every error navstress raises on purpose."""


class SpecError(NavstressError, ValueError):
    """An invalid specification (world, campaign, navigator config, CLI flag)."""

    def __init__(self, field: str, value: Any, expected: str, fix: str | None = None) -> None:
        self.field = field
        self.value = value
        self.expected = expected
        self.fix = fix
        msg = f"{field}={value!r} is invalid: expected {expected}"
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
