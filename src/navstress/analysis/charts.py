"""The report's charts as Vega-Lite specifications, built with Altair and drawn in the page by the
Vega libraries that the report embeds once (vl-convert's offline bundle of Vega, Vega-Lite and
Vega-Embed: the page loads nothing from outside).

Every chart can be zoomed with the mouse wheel, panned by dragging and reset with a double
click (along both axes, or along the value axis where the other one is a set of categories);
hovering a mark shows its numbers; the chart's menu saves it as SVG or PNG. The charts:

- :func:`class_chart`: the paper's Fig. 7-9 layout for one experiment class (success rate with its
  95 % interval and the difficulty level, median duration and tortuousness of successes);
- :func:`verdict_chart`: per configuration, the pass probability of each world with its exact
  interval and verdict, beside the pooled configuration;
- :func:`indeterminism_chart`: Fig. 10-11, the max distance between repeated runs over time;
- :func:`fault_power_chart`: Fig. 12, runs with a collision per difficulty level, faulty beside
  nominal;
- :func:`found_chart` and :func:`illumination_chart`: the search's worlds found against runs
  spent, and its illumination map.

Each returns the chart's specification as a plain dict (JSON-ready, deterministic: the same
input gives the same text); :func:`chart_html` writes it into the page and :func:`page_script`
is what draws them.
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
from collections.abc import Iterable, Mapping, Sequence
from html import escape
from importlib import metadata
from typing import Any, Final

import altair as alt
import vl_convert

from navstress import _files, _json
from navstress._paths import cache_dir
from navstress.analysis.difficulty import finite_number as _finite  # None: left out of a continuous scale
from navstress.errors import SpecError

#: Difficulty levels: (Vega-Lite point shape, colour).
LEVEL_STYLE: dict[str, tuple[str, str]] = {
    "easy": ("circle", "#1a9641"),
    "challenging": ("square", "#f08a24"),
    "very difficult": ("cross", "#d7191c"),
    "no data": ("circle", "#bbbbbb"),
    "no generated maps": ("diamond", "#8c6d31"),
}
VERDICT_COLOURS: dict[str, str] = {
    "passes": "#1a9641", "fails": "#d7191c", "flaky": "#7b3294", "undecided": "#999999",
}
#: Line colours of the search's methods in :func:`found_chart` (others get Vega's palette).
METHOD_COLOURS = {"search": "#d7191c", "random": "#2b83ba"}
#: The colour scheme of the illumination map (Vega's name).
MAP_SCHEME: Final = "plasma"
#: A five-pointed star (Vega-Lite takes an SVG path as a point shape), for confirmed counts.
STAR = ("M0,-1L0.2245,-0.309L0.9511,-0.309L0.3633,0.118L0.5878,0.809L0,0.382L-0.5878,0.809"
        "L-0.3633,0.118L-0.9511,-0.309L-0.2245,-0.309Z")
#: The Vega-Lite version of Altair's schema, the one the page's libraries are bundled at.
VL_VERSION = ".".join(alt.SCHEMA_VERSION.lstrip("v").split(".")[:2])
#: The width of one chart of the page (a row of panels shares about 1,050 px).
WIDTH = 1000


def _data(rows: list[dict[str, Any]], sets: dict[str, list[dict[str, Any]]]) -> Any:
    """A reference to ``rows``, kept in ``sets`` for the specification's ``datasets``: named by
    their content (the same input, the same text), and not walked by Altair's schema validation
    (which costs seconds on a few thousand points)."""
    name = "data-" + hashlib.sha256(_json.dumps(rows, sort_keys=True).encode()).hexdigest()[:16]
    sets[name] = rows
    return alt.NamedData(name=name)


def _zoom(name: str, *, y_only: bool = False) -> Any:
    """Wheel zoom, drag pan and double-click reset, bound to the panel's scales; named so that
    the specification is the same text for the same input (Altair numbers unnamed ones)."""
    return alt.selection_interval(bind="scales", name=name, encodings=["y"] if y_only else ["x", "y"])


#: Whether :func:`_spec` has Altair validate each specification against the Vega-Lite schema.
#: The test suite turns it on (every chart a test builds is validated); a report leaves it off:
#: a specification's shape is fixed by the code that builds it (its data are named datasets,
#: outside validation anyway), and validating the paper preset's charts took 2.4 s.
VALIDATE = False


def _spec(chart: Any, sets: dict[str, list[dict[str, Any]]]) -> dict[str, Any]:
    """The chart's specification (validated against the Vega-Lite schema when :data:`VALIDATE`),
    with the report's common look and its data ``sets``."""
    spec: dict[str, Any] = chart.configure_view(stroke="#dddddd").configure_axis(
        gridOpacity=0.5, labelFontSize=11, titleFontSize=11).configure_title(fontSize=13, anchor="start").to_dict(
        validate=VALIDATE)
    spec.pop("$schema", None)  # a URL; the embedded libraries need no schema to draw
    spec["datasets"] = {**spec.get("datasets", {}), **sets}
    return spec


# ---------------------------------------------------------------- the analysis report


def class_chart(experiment: str, stats: Sequence[Any], levels: Mapping[tuple[str, str], str], *,
                navigator: str | None = None, fault: str = "nominal", by_key: bool = False) -> dict[str, Any]:
    """One experiment class against its swept parameter (``by_key``: against the configuration
    keys, for explicit worlds): success rate with its 95 % interval (Wilson) and difficulty level
    per configuration, the 25 % line dotted; median duration and tortuousness of the successful
    runs. ``stats``: ConfigStats; with ``navigator``, only its rows with ``fault``."""
    ds: dict[str, list[dict[str, Any]]] = {}
    items = [s for s in stats if s.experiment == experiment
             and (navigator is None or (s.navigator == navigator and s.fault == fault))]
    param = "world" if by_key else next(iter(items[0].params), "configuration") if items else "configuration"
    raw = [s.config_key if by_key else s.params.get(param, s.config_key) for s in items]
    numeric = not by_key and all(_finite(v) is not None for v in raw)
    rows = []
    for s, v in zip(items, raw):
        r = s.successes / s.runs if s.runs else None
        rows.append({"x": float(v) if numeric else str(v), "configuration": s.config_key,
                     "level": levels.get(s.key, "no data"), "runs": s.runs, "successes": s.successes,
                     "success": None if r is None else 100 * r,
                     "low": None if r is None else 100 * s.ci_low, "high": None if r is None else 100 * s.ci_high,
                     "duration": _finite(s.median_duration_s), "tortuousness": _finite(s.median_tortuousness)})
    short = param.rsplit(".", 1)[-1]
    xs = [float(v) for v in raw] if numeric else []
    # one x range for the three panels (a panel with one point would otherwise get a range of its own)
    dom: Any = [min(xs), max(xs)] if xs and min(xs) < max(xs) else [xs[0] - 0.5, xs[0] + 0.5] if xs else alt.Undefined
    x = (alt.X("x:Q", title=short, scale=alt.Scale(zero=False, padding=16, domain=dom)) if numeric
         else alt.X("x:N", title=short, sort=list(dict.fromkeys(str(v) for v in raw)), axis=alt.Axis(labelAngle=-30)))
    lv = [k for k in LEVEL_STYLE if any(r["level"] == k for r in rows)] or ["no data"]
    colour = alt.Color("level:N", title="level", scale=alt.Scale(domain=lv, range=[LEVEL_STYLE[k][1] for k in lv]))
    shape = alt.Shape("level:N", title="level", scale=alt.Scale(domain=lv, range=[LEVEL_STYLE[k][0] for k in lv]))
    tips = [alt.Tooltip("configuration:N"), alt.Tooltip("level:N"), alt.Tooltip("runs:Q"), alt.Tooltip("successes:Q"),
            alt.Tooltip("success:Q", title="success %", format=".1f"),
            alt.Tooltip("low:Q", title="95 % low", format=".1f"), alt.Tooltip("high:Q", title="95 % high", format=".1f"),
            alt.Tooltip("duration:Q", title="median duration s", format=".1f"),
            alt.Tooltip("tortuousness:Q", title="median tortuousness", format=".4f")]
    base = alt.Chart(_data(rows, ds)).properties(width=WIDTH // 3 - 70, height=230)
    rate = alt.layer(
        # (unnamed: Altair gives a concatenated layer's zoom to every named unit of it, twice over)
        base.mark_rule().encode(x=x, y=alt.Y("low:Q"), y2="high:Q", color=colour),
        base.mark_point(size=90, filled=True).encode(
            x=x, y=alt.Y("success:Q", title="success rate [%]", scale=alt.Scale(domain=[-5, 105])),
            color=colour, shape=shape, tooltip=tips).add_params(_zoom("zoom_rate", y_only=not numeric)).properties(
            name="rate_points"),
        alt.Chart().mark_rule(color="#d7191c", strokeDash=[2, 3]).encode(y=alt.datum(25)),
    )
    panels = [rate]
    for field, title in (("duration", "median duration of successes [s]"),
                         ("tortuousness", "median tortuousness of successes [rad/step]")):
        if all(r[field] is None for r in rows):  # no successful run: said, not an empty plot
            panels.append(alt.Chart(_data([{"text": "no successful run yet"}], ds)).mark_text(
                color="#777777", fontSize=12).encode(text="text:N").properties(
                width=WIDTH // 3 - 70, height=230, title=alt.TitleParams(title, fontSize=11),
                name=f"{field}_none"))
            continue
        panels.append(base.mark_point(size=90, filled=True).encode(
            x=x, y=alt.Y(f"{field}:Q", title=title, scale=alt.Scale(zero=False, padding=16),
                         axis=alt.Axis(format="~g")), color=colour, shape=shape,
            tooltip=tips).add_params(_zoom(f"zoom_{field}", y_only=not numeric)).properties(name=f"{field}_points"))
    who = f" ({navigator}, {fault} runs)" if navigator is not None else ""
    return _spec(alt.hconcat(*panels).properties(title=f"{experiment}: difficulty against {short}{who}"), ds)


def verdict_chart(title: str, configs: Sequence[Any], worlds: Sequence[Any], threshold: float) -> dict[str, Any]:
    """Per configuration (x), its worlds side by side: pass probability with its exact interval,
    coloured by verdict, beside the pooled configuration (a black diamond, its verdict written
    over it); the threshold dashed. ``configs`` and ``worlds``: WorldVerdicts of one experiment,
    navigator and fault."""
    ds: dict[str, list[dict[str, Any]]] = {}
    rows: list[dict[str, Any]] = []
    slots: list[str] = []
    for c in configs:
        ws = [w for w in worlds if w.config_key == c.config_key and w.runs]
        for j, w in enumerate(ws):
            slot = f"world {j + 1}"
            if slot not in slots:
                slots.append(slot)
            rows.append({"configuration": c.config_key, "slot": slot, "kind": "world",
                         "map": w.map_index, "runs": w.runs, "successes": w.successes,
                         "p": w.successes / w.runs, "low": w.ci[0], "high": w.ci[1], "verdict": w.verdict})
        if c.runs:
            rows.append({"configuration": c.config_key, "slot": "pooled", "kind": "configuration (pooled)",
                         "map": None, "runs": c.runs, "successes": c.successes, "p": c.successes / c.runs,
                         "low": c.ci[0], "high": c.ci[1], "verdict": c.verdict})
    slots.append("pooled")
    x = alt.X("configuration:N", title=None, sort=[c.config_key for c in configs], axis=alt.Axis(labelAngle=-20))
    off = alt.XOffset("slot:N", sort=slots, scale=alt.Scale(paddingOuter=0.3))
    seen = [v for v in VERDICT_COLOURS if any(r["verdict"] == v for r in rows)] or ["undecided"]
    colour = alt.Color("verdict:N", scale=alt.Scale(domain=seen, range=[VERDICT_COLOURS[v] for v in seen]))
    kinds = ["world", "configuration (pooled)"]
    tips = [alt.Tooltip("configuration:N"), alt.Tooltip("kind:N"), alt.Tooltip("map:Q"), alt.Tooltip("runs:Q"),
            alt.Tooltip("successes:Q"), alt.Tooltip("p:Q", title="pass probability", format=".3f"),
            alt.Tooltip("low:Q", format=".3f"), alt.Tooltip("high:Q", format=".3f"), alt.Tooltip("verdict:N")]
    base = alt.Chart(_data(rows, ds)).properties(width=min(WIDTH, max(360, 110 * len(configs))), height=250)
    chart = alt.layer(
        base.mark_rule().encode(x=x, xOffset=off, y=alt.Y("low:Q"), y2="high:Q", color=colour).properties(
            name="intervals"),
        base.mark_point(filled=True, size=70).encode(
            x=x, xOffset=off, y=alt.Y("p:Q", title="pass probability (exact interval)",
                                      scale=alt.Scale(domain=[-0.05, 1.15])),
            color=colour, shape=alt.Shape("kind:N", title=None,
                                          scale=alt.Scale(domain=kinds, range=["circle", "diamond"])),
            tooltip=tips).add_params(_zoom("zoom", y_only=True)).properties(name="points"),
        base.transform_filter(alt.datum.slot == "pooled").mark_text(dy=-8, fontSize=10).encode(
            x=x, xOffset=off, y=alt.datum(1.06), text="verdict:N", color=colour).properties(name="verdicts"),
        alt.Chart().mark_rule(color="#555555", strokeDash=[5, 3]).encode(y=alt.datum(threshold)),
    )
    return _spec(chart.properties(title=title), ds)


def indeterminism_chart(title: str, curves: Mapping[str, Mapping[str, Any]], *, max_points: int = 400) -> dict[str, Any]:
    """Fig. 10-11: the mean max distance between repeated runs over time, one line per
    configuration (``curves[config][group]``: arrays ``t``, ``d`` and ``n_maps``), for the
    successful and the unsuccessful runs side by side; a long curve is thinned to about
    ``max_points`` evenly spaced points (its ends kept)."""
    ds: dict[str, list[dict[str, Any]]] = {}
    panels = []
    for group, name in (("success", "successful runs"), ("failure", "unsuccessful runs")):
        rows = []
        for cfg, cs in curves.items():
            c = cs.get(group)
            if c is None:
                continue
            label = f"{cfg} ({c.n_maps} map{'s' if c.n_maps != 1 else ''})"
            n = len(c.t)
            step = max(1, math.ceil(n / max_points))
            idx = list(range(0, n, step)) + ([n - 1] if n and (n - 1) % step else [])
            rows += [{"configuration": label, "t": float(c.t[i]), "d": float(c.d[i])} for i in idx]
        head = alt.TitleParams(f"{title}: {name}", fontSize=12)
        if not rows:
            panels.append(alt.Chart(_data([{"text": "no map with 2+ such runs"}], ds)).mark_text(
                color="#777777", fontSize=12).encode(text="text:N").properties(
                width=WIDTH // 2 - 120, height=240, title=head, name=f"empty_{group}"))
            continue
        panels.append(alt.Chart(_data(rows, ds)).mark_line(strokeWidth=1.5, point=False).encode(
            x=alt.X("t:Q", title="time t [s]"), y=alt.Y("d:Q", title="max distance between runs [m]"),
            color=alt.Color("configuration:N", title=None, legend=alt.Legend(orient="bottom", columns=2)),
            tooltip=[alt.Tooltip("configuration:N"), alt.Tooltip("t:Q", format=".1f"),
                     alt.Tooltip("d:Q", title="distance m", format=".2f")],
        ).add_params(_zoom(f"zoom_{group}")).properties(width=WIDTH // 2 - 120, height=240, title=head,
                                                        name=f"curves_{group}"))
    return _spec(alt.hconcat(*panels).resolve_scale(color="independent"), ds)


def fault_power_chart(level_powers: Sequence[Any], *, navigator: str | None = None) -> dict[str, Any]:
    """Fig. 12: runs with a collision per difficulty level and fault, the faulty navigator beside
    the nominal one on the same maps, each bar labelled with its count of runs."""
    ds: dict[str, list[dict[str, Any]]] = {}
    who = f"{navigator} " if navigator else ""
    faulty, nominal = f"{who}faulty: runs with collision", f"{who}nominal: runs with collision"
    rows = []
    for p in level_powers:
        group = f"{p.level or 'no level'} / {p.fault}"
        rows.append({"group": group, "who": faulty, "collisions": p.collisions, "runs": p.runs,
                     "label": f"{p.collisions}/{p.runs}"})
        rows.append({"group": group, "who": nominal, "collisions": p.nominal_collisions, "runs": p.nominal_runs,
                     "label": f"{p.nominal_collisions}/{p.nominal_runs}"})
    x = alt.X("group:N", title=None, sort=list(dict.fromkeys(r["group"] for r in rows)), axis=alt.Axis(labelAngle=-20))
    off = alt.XOffset("who:N", sort=[faulty, nominal])
    top = max([r["collisions"] for r in rows] + [1])
    base = alt.Chart(_data(rows, ds)).properties(width=min(WIDTH, max(360, 90 * len(level_powers))), height=250)
    chart = alt.layer(
        base.mark_bar().encode(
            x=x, xOffset=off, y=alt.Y("collisions:Q", title="runs with a collision",
                                      scale=alt.Scale(domain=[0, 1.15 * top])),
            color=alt.Color("who:N", title=None, scale=alt.Scale(domain=[faulty, nominal],
                                                                 range=["#d7191c", "#1a9641"]),
                            legend=alt.Legend(orient="top", labelLimit=400)),
            tooltip=[alt.Tooltip("group:N", title="level / fault"), alt.Tooltip("who:N", title="runs of"),
                     alt.Tooltip("collisions:Q"), alt.Tooltip("runs:Q")]).add_params(
            _zoom("zoom", y_only=True)).properties(name="bars"),
        base.mark_text(dy=-6, fontSize=10).encode(x=x, xOffset=off, y="collisions:Q", text="label:N").properties(
            name="labels"),
    )
    return _spec(chart.properties(
        title=f"Fault-revealing power per difficulty level{': ' + navigator if navigator else ''}"), ds)


# ---------------------------------------------------------------- the search


def found_chart(curves: Mapping[str, Sequence[tuple[int, int]]], *, what: str = "revealing worlds",
                budget: int | None = None, title: str | None = None,
                confirmed: Mapping[str, tuple[int, int]] | None = None) -> dict[str, Any]:
    """Distinct worlds found against runs spent, one step line per method (``curves``: method ->
    its (runs spent, found so far) points, as :func:`navstress.search.figures.found_curve` gives);
    ``budget`` is drawn as a dashed line; ``confirmed`` maps a method to (runs spent, worlds
    confirmed), drawn as a star of the method's colour."""
    ds: dict[str, list[dict[str, Any]]] = {}
    names = list(curves)
    labels = {m: f"{m}: {c[-1][1] if c else 0} in {c[-1][0] if c else 0} runs" for m, c in curves.items()}
    rows = [{"method": m, "line": labels[m], "runs": r, "found": n} for m, c in curves.items() for r, n in c]
    palette = ["#4c78a8", "#f58518", "#54a24b", "#b279a2", "#9d755d"]
    colours = {m: METHOD_COLOURS.get(m, palette[i % len(palette)]) for i, m in enumerate(names)}
    line_dom = [labels[m] for m in names]
    layers: list[Any] = [alt.Chart(_data(rows, ds)).mark_line(interpolate="step-after", strokeWidth=2).encode(
        x=alt.X("runs:Q", title="evaluations [runs spent]"), y=alt.Y("found:Q", title=f"{what} found (distinct)"),
        color=alt.Color("line:N", title=None, scale=alt.Scale(domain=line_dom, range=[colours[m] for m in names]),
                        legend=alt.Legend(orient="top-left")),
        tooltip=[alt.Tooltip("method:N"), alt.Tooltip("runs:Q"), alt.Tooltip("found:Q")],
    ).add_params(_zoom("zoom")).properties(name="lines")]
    stars: list[dict[str, Any]] = [{"method": m, "label": f"{m}: {n} confirmed", "runs": r, "found": n}
             for m, (r, n) in (confirmed or {}).items() if m in curves]
    if stars:
        layers.append(alt.Chart(_data(stars, ds)).mark_point(shape=STAR, size=260, filled=True, stroke="black",
                                                                   strokeWidth=0.6, opacity=1).encode(
            x="runs:Q", y="found:Q",
            fill=alt.Fill("label:N", title=None, legend=alt.Legend(orient="top-left"),
                          scale=alt.Scale(domain=[s["label"] for s in stars],
                                          range=[colours[s["method"]] for s in stars])),
            tooltip=[alt.Tooltip("label:N", title="confirmed"), alt.Tooltip("runs:Q")]).properties(name="confirmed"))
    if budget is not None:
        layers.append(alt.Chart().mark_rule(color="#555555", strokeDash=[5, 3]).encode(x=alt.datum(budget)))
    return _spec(alt.layer(*layers).properties(
        width=560, height=300, title=title or f"{what.capitalize()} found against runs spent"), ds)


def illumination_chart(cells: Iterable[Mapping[str, Any]], *, x_range: tuple[float, float],
                       y_range: tuple[float, float], bins: tuple[int, int], x_label: str, y_label: str,
                       fitness_label: str = "failure probability", vmax: float = 1.0,
                       title: str | None = None) -> dict[str, Any]:
    """The illumination map: each filled cell (``cells``: dicts with ``i`` (y cell), ``j`` (x
    cell), ``fitness`` and ``key``) a rectangle over its descriptor ranges coloured by its best
    world's fitness from 0 to ``vmax``; empty cells blank; the cell borders as the grid."""
    ds: dict[str, list[dict[str, Any]]] = {}
    if isinstance(vmax, bool) or not isinstance(vmax, (int, float)) or not (math.isfinite(vmax) and vmax > 0):
        raise SpecError("vmax", vmax, "a number > 0 (the fitness of the brightest colour)")
    nx, ny = bins
    wx, wy = (x_range[1] - x_range[0]) / nx, (y_range[1] - y_range[0]) / ny
    rows = [{"x0": x_range[0] + c["j"] * wx, "x1": x_range[0] + (c["j"] + 1) * wx,
             "y0": y_range[0] + c["i"] * wy, "y1": y_range[0] + (c["i"] + 1) * wy,
             "fitness": float(c["fitness"]), "world": c["key"]} for c in cells]
    xs = [x_range[0] + k * wx for k in range(nx + 1)]
    ys = [y_range[0] + k * wy for k in range(ny + 1)]
    chart = alt.Chart(_data(rows, ds)).mark_rect(stroke="white", strokeWidth=0.5).encode(
        x=alt.X("x0:Q", title=x_label, scale=alt.Scale(domain=list(x_range), nice=False, zero=False),
                axis=alt.Axis(values=xs if nx <= 20 else alt.Undefined, format="~g")),
        x2="x1:Q",
        y=alt.Y("y0:Q", title=y_label, scale=alt.Scale(domain=list(y_range), nice=False, zero=False),
                axis=alt.Axis(values=ys if ny <= 20 else alt.Undefined, format="~g")),
        y2="y1:Q",
        color=alt.Color("fitness:Q", title=f"best world's {fitness_label}",
                        scale=alt.Scale(scheme=alt.SchemeParams(name=MAP_SCHEME), domain=[0.0, float(vmax)], clamp=True)),
        tooltip=[alt.Tooltip("world:N"), alt.Tooltip("fitness:Q", title=fitness_label, format=".3f"),
                 alt.Tooltip("x0:Q", title=f"{x_label} from", format=".3g"),
                 alt.Tooltip("y0:Q", title=f"{y_label} from", format=".3g")],
    ).add_params(_zoom("zoom")).properties(name="cells")
    filled = len(rows)
    return _spec(chart.properties(width=440, height=380,
                                  title=title or f"Illumination map: {filled} of {nx * ny} cells filled"), ds)


# ---------------------------------------------------------------- the page


def chart_html(spec: Mapping[str, Any], name: str, alt_text: str, navigator: str | None = None,
               fault: str | None = None) -> str:
    """A chart as the report writes it: a ``div.chart`` (``data-figure`` = ``name``, and
    ``data-navigator``/``data-fault`` when given) holding its specification as JSON, drawn by
    :func:`page_script` (``data-rendered`` is set once it is drawn)."""
    who = "".join(f' data-{k}="{escape(v)}"' for k, v in (("navigator", navigator), ("fault", fault)) if v is not None)
    text = json.dumps(spec, separators=(",", ":"), sort_keys=True, allow_nan=False).replace("<", "\\u003c")
    return (f'<div class="chart" data-figure="{escape(name)}"{who} role="img" aria-label="{escape(alt_text)}">'
            f'<div class="vl"></div><script type="application/json">{text}</script></div>')


#: Draws every ``div.chart`` of the page (after the libraries' bundle); ``window.navstressCharts``
#: holds each chart's Vega view by its ``data-figure`` (for a reader's console, and the tests).
_DRAW = r"""
window.navstressCharts={};
document.querySelectorAll('div.chart').forEach(function(el){
  var spec=JSON.parse(el.querySelector('script[type="application/json"]').textContent);
  vegaEmbed(el.querySelector('.vl'),spec,{renderer:'svg',actions:{export:true,source:false,compiled:false,editor:false}})
    .then(function(r){window.navstressCharts[el.dataset.figure]=r.view;el.setAttribute('data-rendered','1');})
    .catch(function(e){el.setAttribute('data-rendered','error');console.error('chart '+el.dataset.figure+': '+e);});
});
"""

CSS = """
div.chart{margin:.5em 0;max-width:100%;overflow-x:auto}
div.chart .vega-embed{display:inline-block}
"""


#: How the bundle ends (it sets the global ``vegaEmbed`` last): a kept copy without it is damaged.
_WHOLE = "window.vegaEmbed="


@functools.lru_cache(maxsize=1)
def _bundle() -> str:
    """The libraries' bundle: made by vl-convert (2-4 s, holding the GIL) once per installed
    version and kept in navstress's cache folder (``navstress.cache_dir()``); a cache that cannot
    be read or written is only slower."""
    path = cache_dir() / f"vega-bundle-{metadata.version('vl-convert-python')}-vl{VL_VERSION}.js"
    try:
        kept = path.read_text(encoding="utf-8")
        if _WHOLE in kept[-4000:]:  # else damaged: made again
            return kept
    except (OSError, UnicodeDecodeError):
        pass
    # the snippet is optional (the default one sets the globals vegaEmbed, vega, vegaLite); the
    # package's type stub says otherwise
    text: str = vl_convert.javascript_bundle(vl_version=f"v{VL_VERSION}")  # type: ignore[call-arg]
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        _files.write_atomic(path, text)
    except OSError:
        pass
    return text


def page_script() -> str:
    """The ``<script>`` elements that draw the page's charts: the Vega libraries (about 0.9 MB,
    offline, at the Vega-Lite version of Altair's schema) and the drawing loop."""
    return f'<script type="module">{_bundle()}</script>\n<script type="module">{_DRAW}</script>'


__all__ = ["CSS", "LEVEL_STYLE", "VL_VERSION", "MAP_SCHEME", "METHOD_COLOURS", "VERDICT_COLOURS", "chart_html", "class_chart",
           "fault_power_chart", "found_chart", "illumination_chart", "indeterminism_chart", "page_script",
           "verdict_chart"]
