"""Every numeric option of every command at extreme values (tiny, huge, zero, negative, NaN,
infinite): the command takes the value and goes on, or refuses it with one line that names the
option (``--dt=1e-09 is invalid: ...``), never a line that names something else (the analysis's
own ``dt``, a ``memory=exhausted``) and never a traceback.

Each command runs with the base arguments of ``test_cli_fuzz`` (they stop it at its last check,
before any real work): a value it takes ends on that same base line. An option whose extreme values
matter only once the work has started (``--dt`` of ``report`` and ``analyze``: the points of the
indeterminism curves over the runs' length) is also run on a campaign that has repeated runs with
traces, where the value is used.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import pytest

from tests.support.analysis_synth import line, make_store, record, save_flat_worlds, write_trace
from tests.support.cli_inputs import assert_one_line_error, invoke, leaf_commands, prepare
from test_cli_fuzz import BASE, DEFAULTS

COMMANDS = leaf_commands()
#: The options whose value is a number, by parameter name.
NUMERIC = {"size", "cell", "subdivisions", "deformation", "trees", "buildings", "obstruction", "seed", "runs",
           "timeout", "goal_tolerance", "workers", "wall_limit", "budget", "threshold", "k", "dt", "min_success",
           "confidence", "alpha", "max_collisions", "live_port", "live_wait", "speed", "heightmap_bits", "wall_height"}
#: The others (paths, names, choices, lists): a new option must be put in one of the two sets.
NOT_NUMERIC = {"kind_names", "output", "out", "json_out", "keep", "junit", "world_dir", "directory", "directories", "spec", "trace",
               "run_id", "name", "navigator", "navigator_config", "fault", "fmt", "table", "preset", "objective",
               "executor", "ray_address", "live_host", "a", "b", "weights", "course", "ground", "mix", "movers",
               "mover_behaviour", "baseline", "robot", "ref", "sensor", "sensor_add", "source", "kind", "unknown", "meshes", "start", "goal",
               "generator", "barn"}
#: Options read only with --live.
LIVE_ONLY = {"live_port", "live_wait", "speed"}
EXTREMES = ["1e-300", "5e-324", "1e-9", "1e300", "9" * 30, "0", "-0", "-1", "-1e300", "nan", "inf", "-inf"]
#: Extra base arguments where the fuzz base stops a command before its numeric options are read,
#: and what an option needs beside it.
EXTRA: dict[str, list[str]] = {"compare": ["--a", "reference-v1", "--b", "reference-v1:small-footprint"]}
WITH: dict[str, list[str]] = {"obstruction": ["--mix", "trees=1"]}
#: Base values that stop a command sooner than the fuzz base (``run`` reads its numbers before it
#: loads the world: no world, no navigator built in a worker for each value).
SOONER: dict[str, dict[str, str]] = {"run": {"world_dir": "{root}/no-world"}}


def _options() -> list[tuple[str, str]]:
    return sorted((name, p.name) for name, cmd in COMMANDS.items() for p in cmd.params
                  if p.name in NUMERIC)


@pytest.fixture(scope="module")
def root(tmp_path_factory: pytest.TempPathFactory) -> Path:
    r = tmp_path_factory.mktemp("numeric")
    prepare(r)
    for d in ("notaworld", "full", "adir"):
        (r / d).mkdir()
        (r / d / "keep.txt").write_text("mine")
    (r / "afile").write_text("a file")
    return r


def _argv(cmd_name: str, root: Path, option: str | None, value: str | None) -> list[str]:
    cmd = COMMANDS[cmd_name]
    base = {**BASE.get(cmd_name, {}), **SOONER.get(cmd_name, {})}
    argv = cmd_name.split()
    for p in cmd.params:
        if getattr(p, "is_flag", False):
            continue
        v = value if p.name == option else base.get(p.name, DEFAULTS.get(p.name, "x") if p.required else None)
        if v is None:
            continue
        v = v.replace("{root}", str(root))
        argv += [v] if p.param_type_name == "argument" else [p.opts[0], v]
    if option in LIVE_ONLY:
        argv.append("--live")
    return argv + EXTRA.get(cmd_name, []) + WITH.get(option or "", [])


def test_every_option_is_classified() -> None:
    names = {p.name for cmd in COMMANDS.values() for p in cmd.params if not getattr(p, "is_flag", False)}
    assert names - NUMERIC - NOT_NUMERIC == set(), "classify the new options as NUMERIC or NOT_NUMERIC"
    assert {"dt", "k", "threshold", "workers", "budget", "live_port"} <= {o for _c, o in _options()}


@pytest.mark.parametrize("cmd_name,option", _options(), ids=[f"{c} {o}" for c, o in _options()])
def test_extreme_values_are_taken_or_refused_naming_the_option(root: Path, cmd_name: str, option: str) -> None:
    flag = next(p.opts[0] for p in COMMANDS[cmd_name].params if p.name == option)
    base = _argv(cmd_name, root, None, None)
    base_code, out, err = invoke(base)
    # the base stops the command at its last check (one line), or lets it end (analyze, gate)
    base_line = assert_one_line_error(base_code, out, err, base) if base_code == 2 else None
    assert base_line is None or flag not in base_line, f"the base itself fails on {flag}: {base_line}"
    for value in EXTREMES:
        argv = _argv(cmd_name, root, option, value)
        t0 = time.perf_counter()
        code, out, err = invoke(argv)
        assert time.perf_counter() - t0 < 20
        if code != 2 and base_code != 2:
            continue  # taken: the command did its work (exit 1: a gate not met)
        line = assert_one_line_error(code, out, err, argv)
        if line == base_line:
            continue  # taken: the command went on to its last check
        # refused: the option is named (``--dt=...``, or click's ``invalid value for '--k'``)
        assert line.startswith(f"error: {flag}=") or f"'{flag}'" in line, f"{cmd_name} {flag} {value}: {line}"


# ---- --dt where it is used: a campaign with repeated runs ------------------------------------------


@pytest.fixture(scope="module")
def traced(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A campaign of one configuration, one map, two runs of 3 s with traces."""
    d = tmp_path_factory.mktemp("dt") / "c"
    with make_store(d, trees=[0], defs=[], maps=1, runs=2) as s:
        save_flat_worlds(s)
        for r in range(2):
            trace = write_trace(d / f"t{r}.mcap", line(3.0, 1.0, 1.0 + r, 18.0, 18.0))
            rec = record("trees", "tree=0", 0, r, duration=3.0, trace=str(Path(trace).name))
            s.add(rec)
    return d


@pytest.mark.parametrize("dt", ["1e-9", "1e-300", "5e-324", "1e-5"])
@pytest.mark.parametrize("cmd", ["report", "analyze"])
def test_a_time_step_too_small_for_the_runs_is_refused_naming_dt(traced: Path, tmp_path: Path, cmd: str,
                                                                 dt: str) -> None:
    argv = [cmd, str(traced), "--dt", dt] + (["-o", str(tmp_path / "r.html")] if cmd == "report" else [])
    t0 = time.perf_counter()
    line = assert_one_line_error(*invoke(argv), argv)
    assert time.perf_counter() - t0 < 20
    assert line.startswith("error: --dt=") and "points" in line and "use dt >=" in line, line
    assert not (tmp_path / "r.html").exists()


def test_a_time_step_that_fits_is_used(traced: Path) -> None:
    code, out, err = invoke(["analyze", str(traced), "--dt", "0.001", "--json", "-"])
    assert code == 0, err
    curves = json.loads(out)["indeterminism"]
    assert curves and all(c["n_runs"] == 2 for c in curves), curves  # the two runs' spread, on 3,001 points
