"""The navigator registry: versioned names ("name-vN") mapped to lazy "module:attr" factories.

Navigators are found in two places, in the spirit of Gymnasium's ``envs/registration.py``:

* the entry-point group ``navstress.navigators`` of any installed distribution, so a third-party
  package registers its navigator in its own ``pyproject.toml`` with no change to navstress::

      [project.entry-points."navstress.navigators"]
      straightline-v1 = "navstress_example_straightline.navigator:StraightLineNavigator"

* :func:`register` in the running process (takes precedence over entry points).

A factory is a class or a callable taking the configuration mapping as keyword ``config=``.
Nothing is imported until :func:`make_navigator` asks for it.

    >>> from navstress.nav.api import Command
    >>> class Stop:
    ...     def __init__(self, config): self.config = config
    ...     def reset(self, mission, robot, *, seed): pass
    ...     def step(self, obs): return Command(0.0, 0.0)
    ...     def close(self): pass
    >>> register("stop-v1", Stop)
    >>> make_navigator("stop-v1", {"gain": 2}).config
    {'gain': 2}
    >>> unregister("stop-v1")
"""

from __future__ import annotations

import difflib
import importlib
import re
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path
from typing import Any

from navstress.errors import NavigatorError, SpecError
from navstress.nav.api import Navigator
from navstress.nav.faults import apply_fault
from navstress.specfile import load_file, parse_text

__all__ = [
    "ENTRY_POINT_GROUP", "NavigatorFactory", "NavigatorNote", "NavigatorSpec", "load_config",
    "call_factory", "list_navigators", "load_factory", "make_navigator", "parse_name",
    "reference_2d_v1", "reference_global_v1", "reference_v1", "register", "resolve", "unregister", "validate_config", "validate_each",
    "builds_to_validate", "make_spec", "registered", "set_registered",
]

ENTRY_POINT_GROUP = "navstress.navigators"

NavigatorFactory = Callable[..., Navigator]
"""Called as ``factory(config=mapping)``; returns a :class:`~navstress.nav.api.Navigator`."""

_NAME_RE = re.compile(r"^(?P<base>[A-Za-z0-9][A-Za-z0-9_.-]*?)(?:-v(?P<version>\d+))?$")
_TARGET_RE = re.compile(r"^[A-Za-z_][\w.]*:[A-Za-z_][\w.]*$")


class NavigatorNote(UserWarning):
    """Informational note from the registry (e.g. which version an unversioned name chose)."""


@dataclass(frozen=True)
class NavigatorSpec:
    """One registered navigator: its full id, its factory and where it was registered."""

    id: str  # "name-vN"
    base: str
    version: int
    target: str | NavigatorFactory  # "module:attr" (lazy) or the factory itself
    source: str  # "register()" or "entry point of <distribution>"

    @property
    def target_text(self) -> str:
        t = self.target
        if isinstance(t, str):
            return t
        return f"{getattr(t, '__module__', '?')}:{getattr(t, '__qualname__', repr(t))}"


_registered: dict[str, NavigatorSpec] = {}


def parse_name(name: str) -> tuple[str, int | None]:
    """``"reference-v1"`` -> ``("reference", 1)``; ``"reference"`` -> ``("reference", None)``."""
    m = _NAME_RE.match(name) if isinstance(name, str) else None
    if m is None:
        raise NavigatorError(
            f"navigator name {name!r} is invalid: expected 'name-vN' (letters, digits, '_', '.', "
            "'-'), e.g. 'reference-v1'"
        )
    v = m.group("version")
    return m.group("base"), None if v is None else int(v)


def make_spec(name: str, target: str | NavigatorFactory, source: str) -> NavigatorSpec:
    """The :class:`NavigatorSpec` of ``name`` ("name-vN") bound to ``target`` ("module:attr" or a
    factory), found in ``source``; NavigatorError naming what is wrong (no version, a malformed
    target). Nothing is registered or imported."""
    base, version = parse_name(name)
    if version is None:
        raise NavigatorError(
            f"navigator id {name!r} needs a version: register it as '{name}-v1'"
        )
    if isinstance(target, str) and not _TARGET_RE.match(target):
        raise NavigatorError(
            f"navigator {name!r}: entry point {target!r} is invalid: expected 'module:attr', "
            "e.g. 'my_package.nav:MyNavigator'"
        )
    if not isinstance(target, str) and not callable(target):
        raise NavigatorError(f"navigator {name!r}: factory {target!r} is not callable")
    return NavigatorSpec(f"{base}-v{version}", base, version, target, source)


def register(name: str, target: str | NavigatorFactory, *, override: bool = False) -> None:
    """Register ``name`` ("name-vN") in this process. ``target``: "module:attr" or a factory.

    Registering the same target again is a no-op; another target needs ``override=True``.
    """
    spec = make_spec(name, target, "register()")
    old = _registered.get(spec.id)
    if old is not None and old.target != spec.target and not override:
        raise NavigatorError(
            f"navigator {spec.id!r} is already registered to {old.target_text}; pass "
            "override=True to replace it"
        )
    _registered[spec.id] = spec


def registered() -> dict[str, NavigatorSpec]:
    """A copy of the navigators registered in this process with :func:`register` (entry points not
    included), by id."""
    return dict(_registered)


def set_registered(specs: dict[str, NavigatorSpec]) -> None:
    """Make ``specs`` (what :func:`registered` returned) this process's registrations again, undoing
    any :func:`register` since."""
    _registered.clear()
    _registered.update(specs)


def unregister(name: str) -> None:
    """Remove a navigator registered with :func:`register` (entry points stay)."""
    _registered.pop(name, None)


def _entry_point_specs() -> dict[str, NavigatorSpec]:
    """Navigators declared by installed distributions (read fresh on each call)."""
    found: dict[str, NavigatorSpec] = {}
    conflicts: dict[str, list[str]] = {}
    for ep in metadata.entry_points(group=ENTRY_POINT_GROUP):
        dist = getattr(ep.dist, "name", None) or "an unknown distribution"
        try:
            spec = make_spec(ep.name, ep.value, f"entry point of {dist}")
        except NavigatorError:
            continue  # a malformed third-party entry must not break every other navigator
        old = found.get(spec.id)
        if old is not None and old.target != spec.target:
            conflicts.setdefault(spec.id, [f"{old.source} ({old.target_text})"]).append(
                f"{spec.source} ({spec.target_text})"
            )
            continue
        found[spec.id] = spec
    for name, where in conflicts.items():
        found[name] = NavigatorSpec(
            name, found[name].base, found[name].version, found[name].target,
            "CONFLICT: " + "; ".join(where),
        )
    return found


#: navstress's own navigators that are known even when the installed metadata predates them (a
#: source checkout on PYTHONPATH over an older install): name -> "module:attr". An entry point of
#: the same name wins. Added only beside navstress's own entry points (reference-v1).
_BUILTIN = {"reference-2d-v1": "navstress.nav.registry:reference_2d_v1"}


def _all_specs() -> dict[str, NavigatorSpec]:
    specs = _entry_point_specs()
    if "reference-v1" in specs:  # navstress's own entry points are installed, perhaps older than its source
        for name, target in _BUILTIN.items():
            specs.setdefault(name, make_spec(name, target, "navstress (built in)"))
    specs.update(_registered)
    return specs


def list_navigators() -> list[NavigatorSpec]:
    """Every known navigator, sorted by name then version."""
    return sorted(_all_specs().values(), key=lambda s: (s.base, s.version))


def resolve(name: str) -> tuple[NavigatorSpec, str | None]:
    """The spec for ``name`` and an optional note (e.g. "'reference' means 'reference-v1'").

    Unknown names raise :class:`NavigatorError` listing the known ones and the closest match.
    """
    base, version = parse_name(name)
    specs = _all_specs()
    known = sorted(specs)
    if version is not None and f"{base}-v{version}" in specs:
        spec = specs[f"{base}-v{version}"]
        note = None
    else:
        versions = sorted(s.version for s in specs.values() if s.base == base)
        if versions and version is None:
            spec = specs[f"{base}-v{versions[-1]}"]
            note = (f"navigator {name!r} has no version; using the latest, {spec.id!r} "
                    f"(write {spec.id!r} to pin it)")
        elif versions:
            raise NavigatorError(
                f"navigator {name!r} has no version v{version}; known versions of {base!r}: "
                + ", ".join(f"{base}-v{v}" for v in versions)
            )
        else:
            close = difflib.get_close_matches(name, known + sorted({s.base for s in specs.values()}),
                                              n=1, cutoff=0.5)
            hint = f" Did you mean {close[0]!r}?" if close else ""
            listing = ", ".join(known) if known else "none (is navstress installed with pip?)"
            raise NavigatorError(f"unknown navigator {name!r}.{hint} Known navigators: {listing}")
    if spec.source.startswith("CONFLICT"):
        raise NavigatorError(
            f"navigator {spec.id!r} is declared by several packages with different targets: "
            f"{spec.source[len('CONFLICT: '):]}; uninstall one of them"
        )
    return spec, note


def load_factory(spec: NavigatorSpec) -> NavigatorFactory:
    """Import the factory of ``spec`` (the lazy "module:attr")."""
    if not isinstance(spec.target, str):
        return spec.target
    module_name, _, attr = spec.target.partition(":")
    try:
        obj: Any = importlib.import_module(module_name)
        for part in attr.split("."):
            obj = getattr(obj, part)
    except Exception as e:
        raise NavigatorError(
            f"navigator {spec.id!r} ({spec.source}) could not be loaded from {spec.target!r}: "
            f"{type(e).__name__}: {e}"
        ) from e
    if not callable(obj):
        raise NavigatorError(f"navigator {spec.id!r}: {spec.target!r} is not callable")
    return obj  # type: ignore[no-any-return]


def load_config(config: Mapping[str, Any] | str | Path | None, *,
                field: str = "navigator-config") -> dict[str, Any]:
    """A navigator configuration as a dict, from a mapping, a path to a JSON/YAML file, inline
    JSON or YAML text (``'{"command": ["node", "nav.js"]}'``, ``"max_speed: 1.0"``), or None (empty).

    A string names a file when one exists at that path; otherwise it is parsed as inline text.
    Files and text go through :mod:`navstress.specfile` (UTF-8, bounded size, nesting and alias
    expansion). Errors are one-line SpecErrors naming ``field``.

        >>> load_config('{"gain": 2}'), load_config("gain: 2"), load_config(None)
        ({'gain': 2}, {'gain': 2}, {})
    """
    if config is None:
        return {}
    if isinstance(config, Mapping):
        return dict(config)
    text_value = str(config)
    expected = "a JSON/YAML file path or an inline JSON/YAML mapping"
    path = Path(text_value) if "\n" not in text_value and text_value.strip() else None
    try:
        is_file = path is not None and path.is_file()
        is_dir = path is not None and path.is_dir()
    except (OSError, ValueError):  # e.g. a name too long for the file system, or a NUL byte
        is_file = is_dir = False
    if is_dir:
        raise SpecError(field, text_value, expected, "this is a directory")
    data: Any
    if is_file:
        assert path is not None
        data = load_file(path, field=field)
    elif isinstance(config, Path):
        raise SpecError(field, text_value, expected, "no such file")
    else:
        inline = text_value.strip()
        if inline.startswith(("{", "[")):
            try:
                data = parse_text(inline, field=field, fmt="json")
            except SpecError as json_err:
                if '"' in inline:  # meant as JSON: say what is wrong with it
                    raise SpecError(field, text_value, "an inline JSON mapping or a file path",
                                    f"fix the JSON: {json_err.fix}") from None
                data = parse_text(inline, field=field)  # YAML flow style, e.g. {gain: 2}
        else:
            data = parse_text(inline, field=field)
            if isinstance(data, str) or (data is None and inline):
                raise SpecError(field, text_value, expected, "no such file (and not an inline mapping)")
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise SpecError(field, text_value, "a mapping of option names to values",
                        f"got a {type(data).__name__}")
    return data


def call_factory(factory: NavigatorFactory, config: Mapping[str, Any], *, name: str) -> Navigator:
    """``factory(config=config)``, checked to return a Navigator; errors become NavigatorError."""
    try:
        nav = factory(config=dict(config))
    except NavigatorError:
        raise
    except SpecError:
        raise
    except Exception as e:
        raise NavigatorError(
            f"navigator {name!r} could not be built with config {dict(config)!r}: "
            f"{type(e).__name__}: {e}"
        ) from e
    if not isinstance(nav, Navigator):
        raise NavigatorError(
            f"navigator {name!r}: its factory returned {type(nav).__name__}, which lacks "
            "reset/step/close of the Navigator protocol"
        )
    return nav


def validate_config(name: str, config: Mapping[str, Any] | str | Path | None = None, *,
                    fault: str | None = None, field: str = "navigator-config") -> None:
    """Check that navigator ``name`` accepts ``config`` without starting a run; SpecError naming
    ``<field>.<key>`` otherwise (NavigatorError for an unknown or unloadable navigator).

    A factory may carry a ``validate_config(config: Mapping) -> None`` attribute (a plain
    attribute of a function, or a static/class method of a class factory) that raises
    :class:`~navstress.errors.SpecError` (field relative to the config) or ``ValueError``; it is
    called alone, nothing is built. A factory without one is built with the config and closed
    at once (``reset`` is never called), so that it can refuse the config in its constructor.
    """
    spec, _note = resolve(name)
    factory = load_factory(spec)
    cfg = load_config(config)
    hook = getattr(factory, "validate_config", None)
    try:
        if callable(hook):
            hook(cfg)
        else:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                make_navigator(spec.id, cfg, fault=fault).close()
    except SpecError as err:
        sub = err.field
        for prefix in ("navigator-config.", "config."):
            if sub.startswith(prefix):
                sub = sub[len(prefix):]
        where = field if sub in ("", "config", "navigator-config") else f"{field}.{sub}"
        raise SpecError(where, err.value, err.expected, err.fix) from None
    except NavigatorError as err:
        raise SpecError(field, cfg, f"a configuration that navigator {spec.id!r} accepts", str(err)) from None
    except Exception as err:
        raise SpecError(field, cfg, f"a configuration that navigator {spec.id!r} accepts",
                        f"{type(err).__name__}: {err}".splitlines()[0]) from None


def builds_to_validate(name: str) -> bool:
    """Whether :func:`validate_config` of ``name`` builds the navigator (its factory has no
    ``validate_config`` hook): navigator code then runs, which commands do in a worker process
    (:func:`validate_each` there), never in their own. NavigatorError for an unknown name."""
    spec, _note = resolve(name)
    return not callable(getattr(load_factory(spec), "validate_config", None))


def validate_each(items: Sequence[tuple[str, Mapping[str, Any], str]]) -> None:
    """:func:`validate_config` of each ``(name, config, field)`` (run in a worker process for
    the navigators that :func:`builds_to_validate`)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for name, config, field in items:
            validate_config(name, config, field=field)


def make_navigator(
    name: str,
    config: Mapping[str, Any] | str | Path | None = None,
    *,
    fault: str | None = None,
) -> Navigator:
    """Build the navigator registered as ``name`` with ``config``; optionally under ``fault``
    (see :func:`navstress.nav.faults.list_faults`).

    An unversioned name resolves to the latest version and emits a :class:`NavigatorNote`.
    """
    spec, note = resolve(name)
    if note:
        warnings.warn(note, NavigatorNote, stacklevel=2)
    factory = load_factory(spec)
    cfg = load_config(config)
    if fault is not None:
        factory = apply_fault(factory, fault, navigator=spec.id)
    return call_factory(factory, cfg, name=spec.id)


def build_and_close(name: str, fault: str | None, config: Mapping[str, Any]) -> None:
    """Validate ``config``, build the navigator ``name`` (under ``fault``) and close it: raises
    what building it raises (``navstress run`` calls this in a worker process, before a run)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        validate_config(name, config, fault=fault)
        nav = make_navigator(name, config or None, fault=fault)
    nav.close()


# ---------------------------------------------------------------- built-in factories
# _LOCAL: navstress.nav.reference is imported inside these functions: it compiles numba kernels,
# and this module is loaded by `import navstress.nav.api` (the contract stays cheap to import).
# (declared as entry points in navstress's own pyproject.toml; the reference classes take a
# ReferenceConfig object, the registry hands factories a mapping: these adapt.)


def reference_v1(*, config: Mapping[str, Any] | None = None) -> Navigator:
    """``reference-v1``: :class:`~navstress.nav.reference.ReferenceNavigator` with its
    :class:`~navstress.nav.reference.config.ReferenceConfig` parsed from ``config``."""
    from navstress.nav.reference import ReferenceNavigator, parse_config  # local: numba kernels, see _LOCAL

    return ReferenceNavigator(parse_config(dict(config or {})))


def reference_global_v1(*, config: Mapping[str, Any] | None = None) -> Navigator:
    """``reference-global-v1``: :class:`~navstress.nav.reference.GlobalNavigator` with a
    :class:`~navstress.nav.reference.config.GlobalConfig` parsed from ``config``."""
    from navstress.nav.reference import GlobalConfig, GlobalNavigator, parse_config  # local: see _LOCAL

    return GlobalNavigator(parse_config(dict(config or {}), cls=GlobalConfig))


def reference_2d_v1(*, config: Mapping[str, Any] | None = None) -> Navigator:
    """``reference-2d-v1``: :class:`~navstress.nav.reference2d.Reference2dNavigator` (robots with a
    2D scanner) with its :class:`~navstress.nav.reference2d.Reference2dConfig` parsed from ``config``."""
    from navstress.nav.reference2d import Reference2dNavigator, parse_config as parse_2d  # local: see _LOCAL

    return Reference2dNavigator(parse_2d(dict(config or {})))


def _validate_reference_2d(config: Mapping[str, Any]) -> None:
    from navstress.nav.reference2d import parse_config as parse_2d  # local: see _LOCAL

    parse_2d(dict(config))


def _validate_reference(config: Mapping[str, Any]) -> None:
    from navstress.nav.reference import parse_config  # local: see _LOCAL

    parse_config(dict(config))


def _validate_reference_global(config: Mapping[str, Any]) -> None:
    from navstress.nav.reference import GlobalConfig, parse_config  # local: see _LOCAL

    parse_config(dict(config), cls=GlobalConfig)


reference_v1.validate_config = _validate_reference  # type: ignore[attr-defined]
reference_global_v1.validate_config = _validate_reference_global  # type: ignore[attr-defined]
reference_2d_v1.validate_config = _validate_reference_2d  # type: ignore[attr-defined]
# config-mutant faults (navstress.nav.faults) apply to factories carrying this mark
reference_v1.__navstress_reference__ = True  # type: ignore[attr-defined]
reference_global_v1.__navstress_reference__ = True  # type: ignore[attr-defined]
reference_2d_v1.__navstress_reference__ = True  # type: ignore[attr-defined]
# the config model whose defaults the config mutants read (permissive-slope doubles max_slope_deg)
reference_2d_v1.__navstress_config__ = "navstress.nav.reference2d.config:Reference2dConfig"  # type: ignore[attr-defined]
