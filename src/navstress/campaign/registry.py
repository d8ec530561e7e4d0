"""The executor registry: names (``local``, ``ray``, a plug-in's) mapped to lazy "module:attr" factories.

Executors are found as navigators are (:mod:`navstress.nav.registry`): in the entry-point group
``navstress.executors`` of any installed distribution, so that a package adds one (a batch
scheduler) in its own ``pyproject.toml`` with no change to navstress::

    [project.entry-points."navstress.executors"]
    slurm = "navstress_slurm:open_executor"

navstress declares its own two there too; they are also known from :data:`BUILTIN`, so that a
checkout whose installed metadata predates the group (an editable install not reinstalled) finds
them, and no other distribution can take their names. A factory is called with
:class:`ExecutorOptions` and returns an object with the :class:`~navstress.campaign.scheduler.Executor`
interface; nothing is imported until :func:`make_executor` asks for it, so that listing the names
(the command line's ``--executor`` and its help) loads no executor.

    >>> executor_names()[:2]
    ['local', 'ray']
    >>> check_executor("slurm")
    Traceback (most recent call last):
    ...
    navstress.errors.SpecError: --executor='slurm' is invalid: expected one of the executors: local, ray
"""

from __future__ import annotations

import importlib
import re
from collections.abc import Callable
from dataclasses import dataclass, field
from importlib import metadata

from navstress.campaign.scheduler import Executor
from navstress.errors import SpecError

__all__ = ["BUILTIN", "DEFAULT_EXECUTOR", "ENTRY_POINT_GROUP", "ExecutorFactory", "ExecutorOptions",
           "check_executor", "executor_help", "executor_names", "executors", "make_executor"]

ENTRY_POINT_GROUP = "navstress.executors"


@dataclass(frozen=True)
class Builtin:
    """One of navstress's own executors: its factory and what it is, for the help."""

    target: str
    what: str


#: navstress's own executors (also declared in its pyproject.toml under :data:`ENTRY_POINT_GROUP`).
BUILTIN: dict[str, Builtin] = {
    "local": Builtin("navstress.campaign.local:open_local", "a process pool on this machine"),
    "ray": Builtin("navstress.campaign.ray_executor:open_ray", "Ray tasks; pip extra ray"),
}
#: The executor a command uses when none is named.
DEFAULT_EXECUTOR = "local"

_TARGET_RE = re.compile(r"^[A-Za-z_][\w.]*:[A-Za-z_][\w.]*$")
_NAME_RE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]*$")


@dataclass(frozen=True)
class ExecutorOptions:
    """What a factory is told. ``workers``: jobs at once (None: the executor's default, e.g. all
    cores or the cluster's CPUs); ``targets``: spec-given navigators ("module:attr", registered
    in every worker); ``address``: the cluster to join (``--ray-address``; None: the executor's
    own); ``keep``: keep the workers from one session to the next (a search runs one per
    generation), ended by ``close()``."""

    workers: int | None = None
    targets: dict[str, str] = field(default_factory=dict)
    address: str | None = None
    keep: bool = False


ExecutorFactory = Callable[[ExecutorOptions], Executor]
"""Called as ``factory(options)``; returns an :class:`~navstress.campaign.scheduler.Executor`."""


def executors() -> dict[str, str]:
    """Every known executor name -> its "module:attr" factory: the built-ins first, then the
    entry points of installed distributions, by name (read fresh on each call; a malformed entry,
    or one that names a built-in, is left out)."""
    found = {name: b.target for name, b in BUILTIN.items()}
    extra: dict[str, str] = {}
    for ep in metadata.entry_points(group=ENTRY_POINT_GROUP):
        if ep.name in found or not _NAME_RE.match(ep.name) or not _TARGET_RE.match(ep.value):
            continue
        extra.setdefault(ep.name, ep.value)
    return {**found, **dict(sorted(extra.items()))}


def executor_names() -> list[str]:
    """The names :func:`check_executor` accepts, built-ins first."""
    return list(executors())


def executor_help() -> str:
    """The ``--executor`` option's help: every known name, and what a built-in one is."""
    names = [f"{n} ({BUILTIN[n].what})" if n in BUILTIN else n for n in executor_names()]
    return f"Where the runs run: {', '.join(names)}."


def check_executor(name: str, field: str = "--executor") -> str:
    """``name`` when it is a known executor, else SpecError naming ``field`` and the known ones."""
    known = executor_names()
    if name not in known:
        raise SpecError(field, name, "one of the executors: " + ", ".join(known))
    return name


def make_executor(name: str, options: ExecutorOptions, field: str = "--executor") -> Executor:
    """The executor ``name`` made with ``options`` (SpecError naming ``field`` when the name is
    unknown or its factory cannot be loaded; the factory's own errors pass through)."""
    target = executors().get(name)
    if target is None:
        check_executor(name, field)
    assert target is not None
    module, _, attr = target.partition(":")
    try:
        obj: object = importlib.import_module(module)
        for part in attr.split("."):
            obj = getattr(obj, part)
    except Exception as err:  # a plug-in's module that fails to import: one line, not its traceback
        raise SpecError(field, name, f"an executor whose factory {target!r} can be loaded",
                        " ".join(f"{type(err).__name__}: {err}".split())) from None
    if not callable(obj):
        raise SpecError(field, name, f"an executor whose factory {target!r} is callable")
    factory: ExecutorFactory = obj
    return factory(options)
