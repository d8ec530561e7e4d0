"""A WorldSpec from command-line flags (``navstress world generate``): an optional spec file with
flag values overriding its fields; an invalid value names the flag that set it.

    >>> build_spec(size="40", trees="5").size_m
    (40.0, 40.0)
    >>> build_spec(movers="pedestrians=5,vehicle=1", mover_behaviour="vehicle=intercept").movers.counts((100.0, 100.0))
    {'pedestrian': 5, 'vehicle': 1}
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from navstress._flags import integer, number
from navstress.errors import MISSING, SpecError
from navstress.world.spec import WorldSpec, load_spec, parse_spec

_KIND_ALIASES = {"trees": "tree", "buildings": "building"}
_MOVER_ALIASES = {"pedestrians": "pedestrian", "vehicles": "vehicle"}


def parse_pairs(flag: str, raw: str, expected: str, fix: str) -> dict[str, str]:
    """``"a=1,b=2"`` -> ``{"a": "1", "b": "2"}`` (names lower-cased, plural mover names singular);
    SpecError naming ``flag`` on a malformed or repeated pair."""
    out: dict[str, str] = {}
    for part in raw.split(","):
        name, sep, value = part.partition("=")
        name = name.strip().lower()
        name = _MOVER_ALIASES.get(name, name)
        if not sep or not name or not value.strip() or name in out:
            raise SpecError(flag, raw, expected, fix)
        out[name] = value.strip()
    return out


def parse_mover_counts(raw: str) -> dict[str, int]:
    """``"pedestrians=5,vehicle=1"`` -> ``{"pedestrian": 5, "vehicle": 1}``."""
    expected = "comma-separated TYPE=COUNT pairs with whole counts >= 0, each type once"
    fix = "e.g. --movers pedestrians=5,vehicles=1"
    out: dict[str, int] = {}
    for name, value in parse_pairs("--movers", raw, expected, fix).items():
        try:
            n = int(value)
        except ValueError:
            raise SpecError("--movers", raw, expected, fix) from None
        if n < 0:
            raise SpecError("--movers", raw, expected, fix)
        out[name] = n
    return out


def parse_mix(raw: str) -> dict[str, float]:
    """``"trees=3,buildings=1"`` -> ``{"tree": 3.0, "building": 1.0}`` (plural names accepted)."""
    expected = "comma-separated TYPE=WEIGHT pairs with weights >= 0"
    fix = "e.g. --mix trees=1,buildings=1"
    out: dict[str, float] = {}
    for part in raw.split(","):
        name, sep, weight = part.partition("=")
        name = name.strip().lower()
        if not sep or not name:
            raise SpecError("--mix", raw, expected, fix)
        try:
            w = float(weight)
        except ValueError:
            raise SpecError("--mix", raw, expected, fix) from None
        if not w >= 0 or math.isinf(w):
            raise SpecError("--mix", raw, expected, fix)
        key = _KIND_ALIASES.get(name, name)
        if key in out:
            raise SpecError("--mix", raw, f"{expected}, each type once", fix)
        out[key] = w
    return out


# spec field (prefix) -> flag that sets it
_FIELD_FLAGS = {
    "size_m": "--size", "cell_m": "--cell", "ground.subdivisions": "--subdivisions",
    "ground.deformation": "--deformation", "ground.model": "--ground",
    "obstacles.obstruction.tree": "--trees", "obstacles.obstruction.building": "--buildings",
    "obstacles.total": "--obstruction", "obstacles.mix": "--mix",
    "movers.count": "--movers", "movers.behaviour": "--mover-behaviour", "generator": "--generator",
}


def build_spec(*, spec_file: Path | None = None, size: str | None = None, cell: str | None = None,
               subdivisions: str | None = None, deformation: str | None = None, ground: str | None = None,
               trees: str | None = None, buildings: str | None = None, obstruction: str | None = None,
               mix: str | None = None, movers: str | None = None, mover_behaviour: str | None = None,
               generator: str | None = None) -> WorldSpec:
    """The WorldSpec from an optional spec file with flags overriding it (raises SpecError
    naming the flag when a flag value is the culprit)."""
    data: dict[str, Any] = load_spec(spec_file).model_dump(mode="python") if spec_file else {}
    given: set[str] = set()
    if size is not None:
        parts = size.lower().split("x")
        if len(parts) > 2:
            raise SpecError("--size", size, "a map side M or WxH in meters")
        vals = [number("--size", p, "a map side M or WxH in meters") for p in parts]
        data["size_m"] = (vals[0], vals[-1])
        given.add("--size")
    if cell is not None:
        data["cell_m"] = number("--cell", cell, "a cell size in meters")
        given.add("--cell")
    g = dict(data.get("ground", {}))
    if subdivisions is not None:
        g["subdivisions"] = integer("--subdivisions", subdivisions, "an integer >= 0")
        given.add("--subdivisions")
    if deformation is not None:
        g["deformation"] = number("--deformation", deformation, "a displacement scale in meters >= 0")
        given.add("--deformation")
    if ground is not None:
        g["model"] = ground
        given.add("--ground")
    data["ground"] = g
    o = dict(data.get("obstacles", {}))
    per_type = {k: v for k, v in (("tree", trees), ("building", buildings)) if v is not None}
    if per_type and obstruction is not None:
        raise SpecError("--obstruction", obstruction, "either --trees/--buildings or --obstruction with --mix",
                        "not both")
    if per_type:
        obs = dict(o.get("obstruction", {})) if o.get("total") is None else {}
        for kind, raw in per_type.items():
            flag = "--trees" if kind == "tree" else "--buildings"
            obs[kind] = number(flag, raw, "a percentage in [0, 100)")
            given.add(flag)
        o.update(obstruction=obs, total=None, mix=None)
    if obstruction is not None:
        o.update(total=number("--obstruction", obstruction, "a percentage in [0, 100)"), obstruction={})
        given.add("--obstruction")
    if mix is not None:
        if o.get("total") is None:
            raise SpecError("--mix", mix, "to be used with --obstruction (a total to split)",
                            "add --obstruction PCT or use --trees/--buildings")
        o["mix"] = parse_mix(mix)
        given.add("--mix")
    data["obstacles"] = o
    mv = dict(data.get("movers", {}))
    if movers is not None:
        mv["count"] = {**dict(mv.get("count", {})), **parse_mover_counts(movers)}
        given.add("--movers")
    if mover_behaviour is not None:
        kinds = parse_pairs("--mover-behaviour", mover_behaviour, "comma-separated TYPE=BEHAVIOUR pairs, each type once",
                            "e.g. --mover-behaviour pedestrians=intercept,vehicles=crossing")
        beh = {k: dict(v) for k, v in dict(mv.get("behaviour", {})).items()}
        for name, kind in kinds.items():
            beh[name] = {**beh.get(name, {}), "kind": kind}
        mv["behaviour"] = beh
        given.add("--mover-behaviour")
    if mv:
        data["movers"] = mv
    if generator is not None:  # outdoor (the default), rooms or clutter; their parameters in a --spec file
        data["generator"] = generator
        given.add("--generator")
    try:
        return parse_spec(data)
    except SpecError as e:
        for prefix, flag in _FIELD_FLAGS.items():
            flagged = flag in given or (flag == "--mix" and "--obstruction" in given)
            if flagged and (e.field == prefix or e.field.startswith(prefix + ".")):
                raise SpecError(flag, e.value, e.expected, e.fix) from None
        raise


def _floats(flag: str, raw: str, n: int, expected: str) -> list[float]:
    parts = [p.strip() for p in raw.split(",")]
    if len(parts) != n:
        raise SpecError(flag, raw, expected)
    out = [number(flag, p, expected) for p in parts]
    if not all(math.isfinite(v) for v in out):
        raise SpecError(flag, raw, expected)
    return out


def import_spec(source: Path, *, kind: str = "auto", wall_height: str | None = None, unknown: str | None = None,
                meshes: str | None = None, start: str | None = None, goal: str | None = None) -> WorldSpec:
    """The WorldSpec of ``navstress world import``: ``source`` (made absolute) with the flags'
    import options and mission (in the source's frame); an invalid value names its flag.

        >>> s = import_spec(Path("/maps/office.yaml"), wall_height="2.5", start="1,2,0", goal="5,6")
        >>> s.source.path, s.source.wall_height_m, s.mission.start, s.mission.goal
        ('/maps/office.yaml', 2.5, (1.0, 2.0, 0.0), (5.0, 6.0))
    """
    src: dict[str, Any] = {"path": str(Path(source).absolute()), "kind": kind}
    flags = {"--kind": "kind"}
    if wall_height is not None:
        src["wall_height_m"] = number("--wall-height", wall_height, "a height in (0, 100] m")
        if not 0.0 < src["wall_height_m"] <= 100.0:
            raise SpecError("--wall-height", wall_height, "a height in (0, 100] m")
        flags["--wall-height"] = "wall_height_m"
    if unknown is not None:
        src["unknown"], flags["--unknown"] = unknown, "unknown"
    if meshes is not None:
        src["meshes"], flags["--meshes"] = meshes, "meshes"
    data: dict[str, Any] = {"source": src}
    if (start is None) != (goal is None):
        raise SpecError("--start" if start is None else "--goal", MISSING, "--start and --goal given together")
    if start is not None and goal is not None:
        data["mission"] = {"start": _floats("--start", start, 3, "X,Y,YAW: three numbers (m, m, rad)"),
                           "goal": _floats("--goal", goal, 2, "X,Y: two numbers (m)")}
    try:
        return parse_spec(data)
    except SpecError as err:
        for flag, field in flags.items():
            if err.field == f"source.{field}":
                raise SpecError(flag, err.value, err.expected, err.fix) from None
        raise
