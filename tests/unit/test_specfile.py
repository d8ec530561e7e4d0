"""Every spec loader (world spec, campaign spec, navigator config) behind the one safe reader:
bad bytes, deep nesting, alias bombs and huge files fail fast with one SpecError, never a
traceback, a RecursionError or gigabytes of memory."""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from navstress.campaign.spec import load_campaign, parse_campaign_text
from navstress.errors import SpecError
from navstress.nav.registry import load_config
from navstress.specfile import MAX_BYTES, MAX_DEPTH, MAX_NODES, parse_text
from navstress.world.spec import load_spec

FAST_S = 1.0  # "fails fast": well under a second each

# every loader, as a function of a file path
FILE_LOADERS: dict[str, Callable[[Path], Any]] = {
    "world spec": load_spec,
    "campaign spec": load_campaign,
    "navigator config": load_config,
    "navigator config (str)": lambda p: load_config(str(p)),
}


def _bomb(width: int, levels: int) -> str:
    """A "billion laughs": level k is a list of ``width`` aliases of level k-1."""
    lines = [f"a: &a [{','.join(['lol'] * width)}]"]
    names = [chr(ord("a") + k) if k < 26 else f"z{k}" for k in range(levels + 1)]
    for k in range(1, levels + 1):
        lines.append(f"{names[k]}: &{names[k]} [{','.join([f'*{names[k - 1]}'] * width)}]")
    return "\n".join(lines) + "\n"


def _deep_yaml_flow(n: int) -> str:
    return "a: " + "[" * n + "]" * n + "\n"


def _deep_yaml_block(n: int) -> str:
    return "a:\n" + "".join(" " * (i + 1) + "- \n" for i in range(n))


def _deep_json(n: int) -> str:
    return '{"a": ' + "[" * n + "]" * n + "}"


def _timed_spec_error(fn: Callable[[], Any]) -> SpecError:
    t0 = time.perf_counter()
    with pytest.raises(SpecError) as info:
        fn()
    assert time.perf_counter() - t0 < FAST_S, f"took {time.perf_counter() - t0:.2f} s"
    assert "\n" not in str(info.value) or str(info.value).count("\n") == 0
    return info.value


@pytest.mark.parametrize("loader", FILE_LOADERS)
@pytest.mark.parametrize("suffix", [".yaml", ".json"])
@pytest.mark.parametrize("content,words", [
    (b"\xff\xfe\x00b\x00i\x00n", "UTF-8"),                      # UTF-16 / binary
    (b"size_m: [20, 20]\ncell_m: \xe9\n", "UTF-8"),              # latin-1 byte in a text file
    (bytes(range(256)) * 4, "UTF-8"),                            # random binary
    (b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR", "UTF-8"),           # a picture named like a spec
    (b"a: 1\x00\n", "NUL"),                                       # NUL in otherwise UTF-8 text
    (_deep_yaml_flow(100_000).encode(), "nested"),
    (_deep_json(100_000).encode(), "nested"),
    (_bomb(9, 9).encode(), "aliases"),
    (b"x: " + b"a" * (MAX_BYTES + 10), "bytes"),
])
def test_every_loader_refuses_bad_files_with_one_spec_error(tmp_path: Path, loader: str, suffix: str,
                                                             content: bytes, words: str) -> None:
    p = tmp_path / f"spec{suffix}"
    p.write_bytes(content)
    err = _timed_spec_error(lambda: FILE_LOADERS[loader](p))
    msg = str(err)
    assert str(p) in msg or words in msg, msg
    if suffix == ".yaml" or words not in ("nested", "aliases"):  # JSON files: the JSON parser's own words
        assert words in msg or "valid" in msg, msg


def test_billion_laughs_of_365_bytes_fails_fast_in_every_loader(tmp_path: Path) -> None:
    text = _bomb(9, 9)
    assert len(text) < 400
    p = tmp_path / "bomb.yaml"
    p.write_text(text)
    for name, loader in FILE_LOADERS.items():
        err = _timed_spec_error(lambda: loader(p))
        assert "aliases" in str(err), (name, str(err))
    _timed_spec_error(lambda: parse_campaign_text(text, "bomb.yaml"))
    _timed_spec_error(lambda: load_config(text))  # inline text too


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(width=st.integers(2, 12), levels=st.integers(1, 30), style=st.sampled_from(["flow", "block", "merge"]))
def test_generated_alias_bombs_fail_fast_or_parse_small(width: int, levels: int, style: str) -> None:
    """Any bomb is refused within a second when its expansion exceeds MAX_NODES; a small one parses."""
    if style == "flow":
        text = _bomb(width, levels)
    elif style == "block":
        lines = ["l0: &l0"] + [f"  - lol{i}" for i in range(width)]
        for k in range(1, levels + 1):
            lines += [f"l{k}: &l{k}"] + [f"  - *l{k - 1}" for _ in range(width)]
        text = "\n".join(lines) + "\n"
    else:  # mappings: each level a mapping holding the previous one under several keys
        lines = ["l0: &l0 {" + ", ".join(f"k{i}: v" for i in range(width)) + "}"]
        for k in range(1, levels + 1):
            lines.append(f"l{k}: &l{k} {{" + ", ".join(f"m{i}: *l{k - 1}" for i in range(width)) + "}")
        text = "\n".join(lines) + "\n"
    # exact count of values after expansion: the root mapping, each key, each level's values
    size = 1 + (2 * width if style == "merge" else width)
    total = 1 + 1 + size
    for _ in range(levels):
        size = 1 + width * (size + (1 if style == "merge" else 0))
        total += 1 + size
    t0 = time.perf_counter()
    try:
        data = parse_text(text, field="spec")
    except SpecError as e:
        assert total > MAX_NODES, (total, str(e))  # refused exactly when over the bound
        assert "aliases" in str(e)
    else:
        assert total <= MAX_NODES and isinstance(data, dict)
    assert time.perf_counter() - t0 < FAST_S


@settings(max_examples=30, deadline=None)
@given(depth=st.integers(MAX_DEPTH + 1, 200_000), kind=st.sampled_from(["flow", "block", "json", "mixed"]))
def test_deep_nesting_fails_fast_in_every_format(depth: int, kind: str) -> None:
    if kind == "block":
        depth = min(depth, 3000)  # block indentation grows quadratically in bytes
        text, fmt = _deep_yaml_block(depth), "yaml"
    elif kind == "json":
        text, fmt = _deep_json(depth), "json"
    elif kind == "mixed":
        text, fmt = "a: " + "{b: [" * (depth // 2 + 1), "yaml"  # unclosed too
    else:
        text, fmt = _deep_yaml_flow(depth), "yaml"
    err = _timed_spec_error(lambda: parse_text(text, field="spec", fmt=fmt))  # type: ignore[arg-type]
    assert "nested" in str(err) or "valid" in str(err) or "bytes" in str(err)


def test_recursive_alias_and_limits_at_the_edge() -> None:
    _timed_spec_error(lambda: parse_text("a: &a [*a]", field="spec"))
    ok = "a: " + "[" * (MAX_DEPTH - 1) + "]" * (MAX_DEPTH - 1)
    assert parse_text(ok, field="spec") is not None
    with pytest.raises(SpecError, match="nested"):
        parse_text("a: " + "[" * MAX_DEPTH + "]" * MAX_DEPTH, field="spec")


@settings(max_examples=150, deadline=None)
@given(st.binary(max_size=400))
def test_random_bytes_never_escape_as_anything_but_spec_error(data: bytes) -> None:
    """Random bytes: a parsed value or a SpecError, from the text reader and every loader."""
    import tempfile

    with tempfile.TemporaryDirectory() as d:
        for suffix in (".yaml", ".json"):
            p = Path(d) / f"x{suffix}"
            p.write_bytes(data)
            for loader in FILE_LOADERS.values():
                try:
                    loader(p)
                except SpecError as e:
                    assert "\n" not in str(e)


@settings(max_examples=100, deadline=None)
@given(st.recursive(st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=20),
                    lambda kids: st.lists(kids, max_size=4) | st.dictionaries(st.text(max_size=8), kids, max_size=4),
                    max_leaves=30))
def test_random_structures_as_campaign_text_give_a_spec_or_one_spec_error(value: Any) -> None:
    import json

    for text in (json.dumps(value), "campaign: " + json.dumps(value)):
        try:
            parse_campaign_text(text)
        except SpecError as e:
            assert "\n" not in str(e)


def test_a_directory_or_missing_file_is_a_spec_error(tmp_path: Path) -> None:
    for loader in FILE_LOADERS.values():
        with pytest.raises(SpecError):
            loader(tmp_path)
        with pytest.raises(SpecError):
            loader(tmp_path / "missing.yaml")


_HOSTILE_SCALARS = st.one_of(
    st.integers(-10**40, 10**40), st.floats(allow_nan=True, allow_infinity=True), st.sampled_from(
        [1e308, -1e308, 5e-324, 10**400, "1e999", "nan", "", "x" * 10_000, True, None, [], {}, [1e308, 1e308]]),
    st.text(max_size=30))
_WORLD_FIELDS = ["size_m", "cell_m", "ground.subdivisions", "ground.deformation", "ground.model", "ground.octaves",
                 "ground.persistence", "ground.wavelength_m", "ground.amplitude_m", "obstacles.total",
                 "obstacles.obstruction.tree", "obstacles.mix.tree", "obstacles.types.rock.base_m",
                 "obstacles.types.rock.height_m", "obstacles.types.rock.variability", "mission.start", "mission.goal",
                 "mission.inset_m", "mission.free_radius_m", "mission.min_distance_m", "mission.mode"]
_CAMPAIGN_FIELDS = ["seed", "maps_per_config", "runs_per_map", "timeout_s", "goal_tolerance_m", "name",
                    "experiments.0.sweep.cell_m.start", "experiments.0.sweep.cell_m.step",
                    "experiments.0.sweep.cell_m.stop", "experiments.0.sweep.cell_m.values", "faults",
                    "navigators", "world.size_m", "world.cell_m"]


def _put(data: dict[str, Any], path: str, value: Any) -> dict[str, Any]:
    node: Any = data
    parts = path.split(".")
    for p in parts[:-1]:
        key: Any = int(p) if p.isdigit() else p
        if isinstance(node, list):
            node = node[key]
        else:
            node = node.setdefault(key, {})
    node[parts[-1]] = value
    return data


@settings(max_examples=100, deadline=None)
@given(field=st.sampled_from(_WORLD_FIELDS), value=_HOSTILE_SCALARS)
def test_huge_and_odd_values_in_every_world_spec_field_give_a_spec_or_a_spec_error(field: str, value: Any) -> None:
    from navstress.world.spec import parse_spec

    base: dict[str, Any] = {"size_m": [20, 20], "cell_m": 0.5}
    if field.startswith("obstacles.types.rock"):
        base["obstacles"] = {"types": {"rock": {"base_m": [1, 1], "height_m": 1}}}
    try:
        parse_spec(_put(base, field, value))
    except SpecError as e:
        assert "\n" not in str(e)


@settings(max_examples=100, deadline=None)
@given(field=st.sampled_from(_CAMPAIGN_FIELDS), value=_HOSTILE_SCALARS)
def test_huge_and_odd_values_in_every_campaign_field_give_a_spec_or_a_spec_error(field: str, value: Any) -> None:
    from navstress.campaign.spec import parse_campaign

    base: dict[str, Any] = {"name": "t", "world": {"size_m": [20, 20], "cell_m": 0.5},
                            "experiments": [{"name": "e", "sweep": {"cell_m": {"values": [0.5]}}}]}
    if ".sweep.cell_m." in field and not field.endswith("values"):
        base["experiments"][0]["sweep"]["cell_m"] = {"start": 0.5, "stop": 1.0, "step": 0.5}
    try:
        spec = parse_campaign(_put(base, field, value))
    except SpecError as e:
        assert "\n" not in str(e)
    else:
        spec.canonical_json()
