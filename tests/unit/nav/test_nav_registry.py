"""Registry: entry points (built-ins and a third-party package), versions, errors, configs."""

from __future__ import annotations

import json
import subprocess
import sys
import warnings
from collections.abc import Iterator, Mapping
from importlib import metadata
from pathlib import Path
from typing import Any

import pytest

from navstress.errors import NavigatorError, SpecError
from navstress.nav import registry
from navstress.nav.api import Command, NavMission, Observation, Status
from navstress.nav.registry import (
    NavigatorNote,
    list_navigators,
    make_navigator,
    parse_name,
    register,
    resolve,
    unregister,
)
from navstress.robot import RobotSpec


class Recorder:
    """A navigator that remembers its config."""

    def __init__(self, config: Mapping[str, Any]) -> None:
        self.config = dict(config)

    def reset(self, mission: NavMission, robot: RobotSpec, *, seed: int) -> None: ...

    def step(self, obs: Observation) -> Command | Status:
        return Command(0.0, 0.0)

    def close(self) -> None: ...


@pytest.fixture
def scratch() -> Iterator[list[str]]:
    """Names registered in a test, unregistered after it."""
    names: list[str] = []
    yield names
    for n in names:
        unregister(n)


def test_builtins_come_from_navstress_entry_points() -> None:
    specs = {s.id: s for s in list_navigators()}
    for name in ("reference-v1", "reference-global-v1", "external-v1"):
        assert specs[name].source == "entry point of navstress", specs[name]
    eps = {ep.name: ep.value for ep in metadata.entry_points(group="navstress.navigators")
           if ep.dist is not None and ep.dist.name == "navstress"}
    assert eps["reference-v1"] == "navstress.nav.registry:reference_v1"


def test_builtin_reference_navigators_build_with_config() -> None:
    nav = make_navigator("reference-v1", {"max_slope_deg": 20.0})
    assert type(nav).__name__ == "ReferenceNavigator"
    assert nav.config.max_slope_deg == 20.0  # type: ignore[attr-defined]
    glob = make_navigator("reference-global-v1", {"replan_period_s": 3.0})
    assert glob.config.replan_period_s == 3.0  # type: ignore[attr-defined]
    with pytest.raises(SpecError, match=r"n_arcs=0 is invalid"):
        make_navigator("reference-v1", {"n_arcs": 0})


def test_third_party_package_registers_by_entry_point(example_package: Path) -> None:
    from navstress_example_straightline import StraightLineNavigator

    spec, note = resolve("straightline-v1")
    assert note is None and spec.source == "entry point of navstress-example-straightline"
    nav = make_navigator("straightline-v1", {"heading_gain": 0.5})
    assert isinstance(nav, StraightLineNavigator) and nav.params["heading_gain"] == 0.5
    with pytest.raises(SpecError, match=r"navigator-config.gain=1 is invalid"):
        make_navigator("straightline-v1", {"gain": 1})


def test_unknown_name_lists_known_and_suggests_closest(example_package: Path) -> None:
    with pytest.raises(NavigatorError) as err:
        make_navigator("straigthline-v1")
    msg = str(err.value)
    assert "unknown navigator 'straigthline-v1'. Did you mean 'straightline-v1'?" in msg
    assert "Known navigators: " in msg and "reference-v1" in msg and "external-v1" in msg
    with pytest.raises(NavigatorError) as err2:
        make_navigator("zzzzzzzz-v1")
    assert "Did you mean" not in str(err2.value)


def test_unversioned_name_takes_latest_with_a_note(scratch: list[str]) -> None:
    register("demo-v1", Recorder)
    register("demo-v2", lambda *, config: Recorder({**config, "v": 2}))
    scratch += ["demo-v1", "demo-v2"]
    with pytest.warns(NavigatorNote, match=r"'demo' has no version; using the latest, 'demo-v2'"):
        nav = make_navigator("demo")
    assert nav.config == {"v": 2}  # type: ignore[attr-defined]
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a pinned name gives no note
        assert make_navigator("demo-v1").config == {}  # type: ignore[attr-defined]
    with pytest.raises(NavigatorError, match=r"'demo-v7' has no version v7; known versions of "
                                             r"'demo': demo-v1, demo-v2"):
        make_navigator("demo-v7")


@pytest.mark.parametrize(("name", "base", "version"), [
    ("reference-v1", "reference", 1), ("reference-global-v12", "reference-global", 12),
    ("reference", "reference", None), ("my.nav_x", "my.nav_x", None), ("a-v", "a-v", None),
])
def test_parse_name(name: str, base: str, version: int | None) -> None:
    assert parse_name(name) == (base, version)


@pytest.mark.parametrize("bad", ["", "-v1", "a b", "nav/x", "é-v1"])
def test_invalid_names_rejected(bad: str) -> None:
    with pytest.raises(NavigatorError, match=r"expected 'name-vN'"):
        parse_name(bad)


def test_register_rules(scratch: list[str]) -> None:
    with pytest.raises(NavigatorError, match=r"'plain' needs a version: register it as 'plain-v1'"):
        register("plain", Recorder)
    with pytest.raises(NavigatorError, match=r"entry point 'no_colon' is invalid: expected 'module:attr'"):
        register("x-v1", "no_colon")
    register("dup-v1", "navstress.nav.check:flat_ground_scan")
    scratch.append("dup-v1")
    register("dup-v1", "navstress.nav.check:flat_ground_scan")  # same target: no-op
    with pytest.raises(NavigatorError, match=r"already registered to navstress.nav.check:flat_ground_scan; pass override=True"):
        register("dup-v1", Recorder)
    register("dup-v1", Recorder, override=True)
    assert isinstance(make_navigator("dup-v1"), Recorder)


def test_in_process_registration_is_lazy_and_load_errors_are_clear(scratch: list[str]) -> None:
    register("lazy-v1", "navstress_no_such_module_xyz:Nav")  # nothing imported yet
    scratch.append("lazy-v1")
    assert "navstress_no_such_module_xyz" not in sys.modules
    with pytest.raises(NavigatorError, match=r"'lazy-v1' \(register\(\)\) could not be loaded from "
                                             r"'navstress_no_such_module_xyz:Nav': ModuleNotFoundError"):
        make_navigator("lazy-v1")
    register("attr-v1", "navstress.nav.api:NoSuchClass")
    scratch.append("attr-v1")
    with pytest.raises(NavigatorError, match=r"AttributeError"):
        make_navigator("attr-v1")


def test_factory_problems_become_navigator_errors(scratch: list[str]) -> None:
    register("notnav-v1", lambda *, config: object())
    register("positional-v1", lambda cfg: Recorder(cfg))
    scratch += ["notnav-v1", "positional-v1"]
    with pytest.raises(NavigatorError, match=r"returned object, which lacks reset/step/close"):
        make_navigator("notnav-v1")
    with pytest.raises(NavigatorError, match=r"'positional-v1' could not be built with config \{\}: TypeError"):
        make_navigator("positional-v1")


def test_config_from_file_inline_json_and_yaml(tmp_path: Path, scratch: list[str]) -> None:
    register("rec-v1", Recorder)
    scratch.append("rec-v1")
    (tmp_path / "c.json").write_text(json.dumps({"a": 1}))
    (tmp_path / "c.yaml").write_text("a: 2\nb: [1, 2]\n")
    assert make_navigator("rec-v1", tmp_path / "c.json").config == {"a": 1}  # type: ignore[attr-defined]
    assert make_navigator("rec-v1", str(tmp_path / "c.yaml")).config == {"a": 2, "b": [1, 2]}  # type: ignore[attr-defined]
    assert make_navigator("rec-v1", '{"a": 3}').config == {"a": 3}  # type: ignore[attr-defined]
    with pytest.raises(SpecError, match=r"navigator-config='/no/such.yaml' is invalid.*no such file"):
        make_navigator("rec-v1", "/no/such.yaml")
    with pytest.raises(SpecError, match=r"fix the JSON"):
        make_navigator("rec-v1", '{"a": }')
    (tmp_path / "list.yaml").write_text("- 1\n- 2\n")
    with pytest.raises(SpecError, match=r"expected a mapping of option names to values; got a list"):
        make_navigator("rec-v1", tmp_path / "list.yaml")


def test_conflicting_entry_points_are_reported(monkeypatch: pytest.MonkeyPatch) -> None:
    fake = [metadata.EntryPoint("clash-v1", "pkg_a.nav:A", "navstress.navigators"),
            metadata.EntryPoint("clash-v1", "pkg_b.nav:B", "navstress.navigators"),
            metadata.EntryPoint("bad name!", "x:y", "navstress.navigators")]
    monkeypatch.setattr(registry.metadata, "entry_points", lambda group: fake)
    assert [s.id for s in list_navigators()] == ["clash-v1"]  # the malformed one is skipped
    with pytest.raises(NavigatorError, match=r"declared by several packages.*pkg_a.nav:A.*pkg_b.nav:B.*uninstall one"):
        make_navigator("clash-v1")


def test_make_navigator_with_fault(example_package: Path) -> None:
    from navstress.nav.faults import FaultyNavigator

    nav = make_navigator("straightline-v1", fault="small-footprint")
    assert isinstance(nav, FaultyNavigator)
    with pytest.raises(NavigatorError, match=r"unknown fault 'small-foot'"):
        make_navigator("straightline-v1", fault="small-foot")


def test_nav_plugin_modules_never_import_sim_or_world() -> None:
    """DESIGN invariant 1, checked in a fresh interpreter."""
    code = ("import sys, navstress.nav, navstress.nav.registry, navstress.nav.external, "
            "navstress.nav.check, navstress.nav.faults, navstress.nav.wire; "
            "navstress.nav.make_navigator('reference-v1'); "
            "bad = sorted(m for m in sys.modules if m.startswith(('navstress.sim', 'navstress.world'))); "
            "print(bad); sys.exit(1 if bad else 0)")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stdout + proc.stderr
