"""The report's **Search** section (``navstress report DIR``, DIR a search directory): what was
searched, the illumination map, the worlds found against runs spent (with a baseline search, e.g.
random sampling, on the same axis: ``--baseline DIR2``), the best worlds with their confirmation
runs' trajectories, the elites' confirmation verdicts and the suite to re-run.

It reads the directory's files only: ``search.json`` (:func:`navstress.search.driver.load_result`),
``search.yaml`` (the space's ranges) and the campaign store (the confirmation runs' traces), and
returns a :class:`~navstress.analysis.report.Section` that the report places after its summary:
the analysis layer never imports the search (docs/design.md, "Layers").

Wording: a world is *seen* when the search's own runs showed what the objective looks for (a
failure, a revealing pair, both outcomes), and *confirmed* when its re-runs with fresh run seeds
prove it at the confirmation's confidence (docs/search.md, "Confirmation").
"""

from __future__ import annotations

import html
import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import yaml

from navstress.analysis.report import Section, figure_html
from navstress.analysis.report import cell_html as _cell
from navstress.analysis.stats import config_key
from navstress.campaign.store import DB_NAME, Store
from navstress.errors import NavstressError, SpecError
from navstress.search.driver import CONFIRM, RESULT_NAME, SEARCH_SPEC_NAME, SUITE_DIR, load_result
from navstress.analysis.charts import chart_html
from navstress.search.figures import (BestWorld, Found, best_worlds_figure, found_against_runs, illumination_grid,
                                      illumination_map, tracks_of)
from navstress.search.objectives import DESCRIPTORS
from navstress.world.world import World

#: The anchor of the section (``<section id="search">``) and its title in the navigation bar.
SECTION_ID = "search"
#: At most this many best worlds are drawn (the table lists every elite).
MAX_DRAWN = 6
#: What a candidate's fitness is, per objective (the map's colour bar).
FITNESS_LABEL = {"failure": "failure probability", "illumination": "failure probability",
                 "fault-revealing": "share of revealing pairs", "boundary": "closeness to the target"}
#: Why the generations stopped, for a person.
STOPPED = {"budget.runs": "the run budget: one more generation would have passed budget.runs",
           "budget.sim_hours": "the simulated-time budget (budget.sim_hours)",
           "budget.wall_s": "the wall-time budget (budget.wall_s)"}


def _e(x: Any) -> str:
    return html.escape(str(x), quote=True)


def _num(v: Any, digits: int = 3) -> str:
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        return "\u2013" if v is None else str(v)
    if isinstance(v, int):
        return str(v)
    return f"{v:.{digits}g}" if math.isfinite(v) else "\u2013"


def load_search_dir(directory: str | Path, field: str = "directory") -> dict[str, Any]:
    """``search.json`` of ``directory``; a :class:`SpecError` naming ``field`` when it holds none."""
    root = Path(directory)
    data = load_result(root) if root.is_dir() else None
    if data is None:
        raise SpecError(field, str(root), f"a search directory (one holding {RESULT_NAME}, written when "
                        "`navstress search SPEC -o DIR` ends)",
                        "run the search to its end first, e.g. the same spec with algorithm: {name: random}")
    return data


def _space(root: Path) -> dict[str, Any]:
    """The search spec as run (``search.yaml``), read as plain data ({} when unreadable): the report
    only shows its ranges, so it does not validate it again."""
    try:
        data = yaml.safe_load((root / SEARCH_SPEC_NAME).read_text(encoding="utf-8"))
    except (OSError, yaml.YAMLError):
        return {}
    return data if isinstance(data, dict) else {}


def _axis(d: Mapping[str, Any]) -> tuple[str, str]:
    """(name, a person's label) of one archive axis: a registry descriptor or a space path."""
    name = str(d.get("name", ""))
    desc = DESCRIPTORS.get(name)
    return name, desc.axis_label if desc is not None else name


# ---------------------------------------------------------------- the parts of the section


def _what(data: Mapping[str, Any], spec: Mapping[str, Any]) -> str:
    obj = data.get("objective") or {}
    opts = [f"{k} {obj[k]}" for k in ("outcome", "fault", "target") if obj.get(k) is not None
            and not (k == "target" and obj.get("name") != "boundary")]
    nav = data.get("navigator") or {}
    faults = ", ".join("nominal" if f is None else str(f) for f in data.get("faults", [None]))
    budget = data.get("budget") or {}
    limits = [f"{budget['runs']} runs"] + [f"{budget[k]:g} {u}" for k, u in (("sim_hours", "simulated hours"),
                                                                              ("wall_s", "wall seconds"))
                                             if isinstance(budget.get(k), (int, float))]
    space = spec.get("space") or {}
    params = {p.get("path"): p for p in space.get("parameters") or [] if isinstance(p, dict)}
    prow = "".join(
        f'<tr data-parameter="{_e(path)}"><td class="l">{_e(path)}</td>'
        + (_cell("low", params[path].get("low"), _num(params[path].get("low")))
           + _cell("high", params[path].get("high"), _num(params[path].get("high")))
           + f'<td class="l">{_e(params[path].get("kind", "float"))}</td>' if path in params
           else '<td>\u2013</td><td>\u2013</td><td class="l">\u2013</td>') + "</tr>"
        for path in data.get("parameters", []))
    moves = space.get("moves")
    if isinstance(moves, dict):
        prow += (f'<tr data-parameter="moves"><td class="l">obstacle moves</td><td colspan="3" class="l">'
                 f'{_e(moves.get("count", "?"))} moves of the obstacle nearest a point of the map, by up to '
                 f'{_e(moves.get("radius_m", "?"))} m along x and y</td></tr>')
    if space.get("map_seed", True):
        prow += (f'<tr data-parameter="map_seed"><td class="l">map seed</td><td colspan="3" class="l">one of '
                 f'{_e(space.get("map_seeds", "?"))} seeds</td></tr>')
    rpc = spec.get("runs_per_candidate")
    rows = [("objective", f"{obj.get('name')}" + (f" ({', '.join(opts)})" if opts else "")),
            ("algorithm", f"{data.get('algorithm')}, {data.get('batch')} candidates per generation"),
            ("stack under test", f"{nav.get('name')}; faults: {faults}"),
            ("seed", data.get("seed")),
            ("budget", ", ".join(limits)),
            ("runs per candidate and fault", "adaptive " + yaml.safe_dump(rpc, default_flow_style=True).strip()
             if isinstance(rpc, dict) else rpc if rpc is not None else "\u2013"),
            ("search runs spent", f"{data.get('runs')} in {data.get('generations')} generations"),
            ("why it stopped", STOPPED.get(str(data.get("stopped")), str(data.get("stopped") or "\u2013"))),
            ("candidates evaluated", f"{len(data.get('evaluated', []))} "
                                     f"({len({e['key'] for e in data.get('evaluated', [])})} distinct worlds)"),
            ("confirmation runs (fresh run seeds)", data.get("confirm_runs")),
            ("simulated time", f"{float(data.get('sim_hours') or 0.0):.2f} h")]
    ids = ["objective", "algorithm", "stack", "seed", "budget", "runs-per-candidate", "runs", "stopped",
           "evaluated", "confirm-runs", "sim-hours"]
    trs = "".join(f'<tr data-field="{i}"><th class="l">{_e(k)}</th><td class="l">{_e(v)}</td></tr>'
                  for i, (k, v) in zip(ids, rows))
    return (f'<table id="search-what">{trs}</table>'
            '<table id="search-space"><tr><th class="l">searched parameter</th><th>low</th><th>high</th>'
            f'<th class="l">kind</th></tr>{prow}</table>')


def _found_counts(data: Mapping[str, Any]) -> tuple[int, int, int]:
    """(worlds seen, elites, elites confirmed) of one search."""
    seen = len({e["key"] for e in data.get("evaluated", []) if e.get("found")})
    elites = data.get("elites", [])
    return seen, len(elites), sum(bool(e.get("confirmed")) for e in elites)


def _method(data: Mapping[str, Any], own: bool) -> str:
    if own:
        return "search"
    return "random" if data.get("algorithm") == "random" else "baseline"


def _baseline_notes(data: Mapping[str, Any], base: Mapping[str, Any]) -> list[str]:
    """What makes the comparison with the baseline unequal (empty when it is fair)."""
    notes = []
    for k, what in (("objective", "objective"), ("parameters", "searched parameters"), ("navigator", "stack"),
                    ("faults", "faults")):
        if data.get(k) != base.get(k):
            notes.append(f"the baseline's {what} differ from this search's")
    b1, b2 = (data.get("budget") or {}).get("runs"), (base.get("budget") or {}).get("runs")
    if b1 != b2:
        notes.append(f"the run budgets differ ({b1} here, {b2} in the baseline)")
    return notes


def _found(data: Mapping[str, Any], base: Mapping[str, Any] | None, base_dir: Path | None) -> str:
    what = str(data.get("found_what", "worlds found"))
    methods: dict[str, list[Found]] = {}
    confirmed: dict[str, tuple[int, int]] = {}
    rows = []
    for d, own in ((data, True), *(((base, False),) if base is not None else ())):
        name = _method(d, own)
        methods[name] = [Found(int(e["runs_spent"]), str(e["key"]), bool(e["found"])) for e in d.get("evaluated", [])]
        seen, n_el, n_conf = _found_counts(d)
        confirmed[name] = (int(d.get("runs", 0)), n_conf)
        where = "this directory" if own else str(base_dir)
        rows.append(f'<tr data-method="{_e(name)}"><td class="l">{_e(name)} <small class="sub">'
                    f'{_e(d.get("algorithm"))}; {_e(where)}</small></td>'
                    + _cell("seen", seen) + _cell("confirmed", n_conf) + _cell("elites", n_el)
                    + _cell("runs", d.get("runs")) + _cell("confirm-runs", d.get("confirm_runs")) + "</tr>")
    budget = (data.get("budget") or {}).get("runs")
    chart = found_against_runs(methods, what=what, budget=budget if isinstance(budget, int) else None,
                               confirmed=confirmed)
    out = ['<h3 id="search-found-title">Worlds found against runs spent</h3>',
           f'<p class="note">Distinct {_e(what)} <i>seen</i> (the search\'s own runs showed it) against the '
           'search runs spent, one step per generation; the marker at the end is how many elites were '
           '<i>confirmed</i> by re-running them with fresh run seeds (those runs come on top of the budget, '
           'dashed).' + ('' if base is not None else ' Add <code>--baseline DIR2</code> (another search '
                         'directory, typically the same spec with <code>algorithm: {name: random}</code>) to '
                         'draw random sampling on the same axis.') + '</p>',
           chart_html(chart, "search-found", f"{what} found against runs spent"),
           '<table id="search-found" class="keyed"><tr><th class="l">method</th><th class="key">seen</th>'
           '<th class="key">confirmed</th><th>elites</th><th>search runs</th><th>confirmation runs</th></tr>'
           f'{"".join(rows)}</table>']
    if base is not None:
        for n in _baseline_notes(data, base):
            out.append(f'<p class="warn search-baseline-note">Not an equal comparison: {_e(n)}.</p>')
    return "\n".join(out)


def _map(data: Mapping[str, Any]) -> str:
    descs = data.get("descriptors") or []
    evaluated = data.get("evaluated", [])
    if len(descs) != 2:
        return '<p class="note" id="search-map-none">This search has no two-descriptor archive to map.</p>'
    (xn, xl), (yn, yl) = _axis(descs[0]), _axis(descs[1])
    xr = (float(descs[0]["low"]), float(descs[0]["high"]))
    yr = (float(descs[1]["low"]), float(descs[1]["high"]))
    bins = (int(descs[0].get("cells", 10)), int(descs[1].get("cells", 10)))
    pts = [{"x": float(e["descriptors"][0]), "y": float(e["descriptors"][1]), "fitness": float(e["fitness"]),
            "key": str(e["key"])} for e in evaluated if len(e.get("descriptors", [])) == 2]
    obj = str((data.get("objective") or {}).get("name"))
    label = FITNESS_LABEL.get(obj, "fitness")
    chart = illumination_map(pts, x=xn, y=yn, x_range=xr, y_range=yr, bins=bins, x_label=xl, y_label=yl,
                             fitness_label=label)
    fit, keys = illumination_grid(pts, xr, yr, bins)
    by_key = {str(e["key"]): e for e in evaluated}
    confirmed = {str(e["key"]): bool(e.get("confirmed")) for e in data.get("elites", [])}
    rows = []
    for i in range(bins[1]):
        for j in range(bins[0]):
            if not math.isfinite(fit[i, j]):
                continue
            k = keys[i][j]
            ev = by_key.get(k, {})
            x0 = xr[0] + (xr[1] - xr[0]) * j / bins[0]
            y0 = yr[0] + (yr[1] - yr[0]) * i / bins[1]
            x1, y1 = x0 + (xr[1] - xr[0]) / bins[0], y0 + (yr[1] - yr[0]) / bins[1]
            conf = "confirmed" if confirmed.get(k) else ("not confirmed" if k in confirmed else "not re-run")
            rows.append(f'<tr data-cell="{i},{j}" data-key="{_e(k)}"><td class="l">{_num(x0)} \u2013 {_num(x1)} '
                        f'<small class="sub">{_e(yl)}: {_num(y0)} \u2013 {_num(y1)}</small></td>'
                        + _cell("fitness", float(fit[i, j]), f"{fit[i, j]:.2f}")
                        + f'<td class="l" data-field="confirmation">{_e(conf)}</td>'
                        + _cell("seen", f"{ev.get('events')}/{ev.get('trials')}")
                        + f'<td class="l">{_e(k)}</td></tr>')
    n_pts = len(pts)
    return "\n".join([
        '<h3 id="search-map-title">Illumination map</h3>',
        f'<p class="note">Every candidate the search evaluated ({n_pts}), placed by the archive\'s two descriptors '
        f'({_e(xl)} and {_e(yl)}, {bins[0]} x {bins[1]} cells; values outside the range fall in the edge cells); '
        f'each cell is coloured by its best world\'s {_e(label)} as <i>seen</i> in the search\'s runs. Where the '
        'colour is bright, the stack fails there; a blank cell holds no evaluated world.</p>',
        chart_html(chart, "search-illumination", f"illumination map over {xl} and {yl}"),
        '<details><summary>The filled cells and their best worlds</summary>'
        f'<table id="search-cells" class="keyed"><tr><th class="l">cell: {_e(xl)} <small class="sub">and '
        f'{_e(yl)}</small></th><th class="key">{_e(label)}</th><th class="l key">confirmation</th><th>seen (events/trials)</th>'
        f'<th class="l">best world</th></tr>{"".join(rows)}</table></details>'])


def _verdict(c: Mapping[str, Any]) -> str:
    return "confirmed" if c.get("confirmed") else "not confirmed"


def _elites(data: Mapping[str, Any], root: Path) -> str:
    elites = sorted(data.get("elites", []), key=lambda e: not e.get("confirmed"))  # confirmed first, stable
    what = str(data.get("found_what", "worlds"))
    if not elites:
        return ('<h3 id="search-best-title">The best worlds</h3>'
                f'<p class="note" id="search-no-elites">The search saw no {_e(what)}: no elite to confirm, '
                'no suite.</p>')
    by_key = {str(e["key"]): e for e in data.get("evaluated", [])}
    records = []
    if (root / DB_NAME).exists():
        try:
            with Store.open(root) as s:
                records = [r for r in s.records() if r.experiment == CONFIRM]
        except NavstressError:
            records = []
    drawn: list[BestWorld] = []
    notes = []
    for el in elites[:MAX_DRAWN]:
        key = str(el["key"])
        wdir = root / "worlds" / CONFIRM / key / "m0"
        if not (wdir / "world.json").exists() and not wdir.is_dir():
            notes.append(f"{key}: world directory not found ({wdir})")
            continue
        c = el.get("confirmation") or {}
        runs = sorted((r for r in records if config_key(r) == key), key=lambda r: (r.run_index, str(r.fault)))
        title = f"{key}: {_verdict(c)}, {c.get('events')}/{c.get('trials')} fresh-seed runs ({c.get('kind')})"
        try:
            world = World.load(wdir)
        except NavstressError as err:  # a world still being written, or damaged
            notes.append(f"{key}: world not readable ({type(err).__name__})")
            continue
        drawn.append(BestWorld(world, tracks_of(runs, root, movers=bool(world.movers)), title))
    parts = ['<h3 id="search-best-title">The best worlds</h3>',
             f'<p class="note">The elites (the best worlds the search kept among those whose runs showed {_e(what)}), '
             'confirmed ones first, each re-run with fresh run seeds (experiment <code>confirm</code>); drawn with '
             'those confirmation runs\' trajectories, coloured by outcome (a cross marks a first collision).</p>']
    if drawn:
        try:
            png = best_worlds_figure(drawn)
            parts.append(figure_html(png, "search-best-worlds", "the best worlds with their confirmation runs"))
        except (NavstressError, OSError, ValueError) as err:
            notes.append(f"the worlds could not be drawn ({type(err).__name__}: {err})")
    if len(elites) > MAX_DRAWN:
        notes.append(f"{len(elites) - MAX_DRAWN} more elites are in the table, not drawn")
    parts += [f'<p class="note">{_e(n)}</p>' for n in notes]
    rows = []
    for el in elites:
        key = str(el["key"])
        c = el.get("confirmation") or {}
        ev = by_key.get(key, {})
        iv = c.get("interval") or [None, None]
        params = ", ".join(f"{k}={_num(v, 4)}" for k, v in sorted((el.get("params") or {}).items()))
        rows.append(
            f'<tr data-key="{_e(key)}" data-confirmed="{str(bool(el.get("confirmed"))).lower()}">'
            f'<td class="l">{_e(key)}</td>'
            + f'<td class="l" data-field="verdict" data-value="{_e(_verdict(c))}">{_e(_verdict(c))}</td>'
            + _cell("fitness", el.get("fitness"), _num(el.get("fitness"), 2))
            + _cell("events", c.get("events")) + _cell("trials", c.get("trials"))
            + _cell("interval", f"{iv[0]},{iv[1]}", f"[{_num(iv[0])}, {_num(iv[1])}]")
            + _cell("seen", f"{ev.get('events')}/{ev.get('trials')}") + _cell("generation", el.get("generation"))
            + f'<td class="l">{_e(params)}; map seed {_e(el.get("map_seed"))}</td>'
            + f'<td class="l" data-field="reason">{_e(c.get("reason", ""))}</td></tr>')
    parts.append('<table id="search-elites" class="keyed"><tr><th class="l">world</th><th class="l key">confirmation</th>'
                 '<th class="key">fitness</th><th>events</th><th>fresh runs</th><th>interval</th>'
                 '<th>seen (search runs)</th><th>found in generation</th><th class="l">parameters</th>'
                 f'<th class="l">why</th></tr>{"".join(rows)}</table>')
    return "\n".join(parts)


def _suite(data: Mapping[str, Any], root: Path) -> str:
    suite = data.get("suite")
    if not suite:
        return ('<p class="note" id="search-suite">No elite was confirmed, so no suite was written '
                f'(<code>{_e(root / SUITE_DIR / "suite.json")}</code> still lists the elites and their verdicts).</p>')
    path = root / str(suite)
    return (f'<div id="search-suite"><p>The confirmed worlds form a regression suite: <code>{_e(path)}</code> (a '
            'campaign spec of these worlds, with <code>suite.json</code> beside it: their measured verdicts and how '
            'they were found). Re-run it, after editing its navigators or faults to test another version of the '
            'stack (the worlds and run seeds stay the same), and gate on it:</p>'
            f'<pre>navstress campaign run {_e(path)} -o RUN\nnavstress gate RUN</pre></div>')


def search_section(directory: str | Path, *, baseline: str | Path | None = None) -> Section | None:
    """The Search section of the report of ``directory`` (None when it holds no ``search.json``),
    with ``baseline`` (another search directory) drawn on the found-against-runs axis. A
    :class:`SpecError` naming ``--baseline`` when ``baseline`` holds no search result, or naming
    the directory when a baseline is given for a directory that is no search."""
    root = Path(directory)
    base = base_dir = None
    if baseline is not None:
        base_dir = Path(baseline)
        base = load_search_dir(base_dir, "--baseline")
        data = load_search_dir(root, "directory")
    else:
        found = load_result(root) if root.is_dir() else None
        if found is None:
            return None
        data = found
    seen, n_el, n_conf = _found_counts(data)
    what = str(data.get("found_what", "worlds found"))
    head = ('<h2 id="search-title">Search</h2>'
            f'<p>Search <b>{_e(data.get("name"))}</b>: <b id="search-seen" data-value="{seen}">{seen}</b> distinct '
            f'{_e(what)} <i>seen</i> in {_e(data.get("runs"))} search runs; '
            f'<b id="search-confirmed" data-value="{n_conf}">{n_conf}</b> of {n_el} elites <i>confirmed</i> with '
            f'fresh run seeds ({_e(data.get("confirm_runs"))} more runs). Seen is what the search\'s own runs '
            'showed; confirmed is what re-runs with run seeds the search never used prove at the confirmation\'s '
            'confidence (docs/search.md).</p>')
    body = [head, _what(data, _space(root)), _map(data), _found(data, base, base_dir), _elites(data, root),
            _suite(data, root)]
    return Section(SECTION_ID, "Search", f'<section id="{SECTION_ID}">' + "\n".join(body) + "</section>")


def search_sections(directory: str | Path, *, baseline: str | Path | None = None) -> Sequence[Section]:
    """:func:`search_section` as the report's ``sections`` argument (empty for a plain campaign)."""
    s = search_section(directory, baseline=baseline)
    return [s] if s is not None else []


__all__ = ["FITNESS_LABEL", "MAX_DRAWN", "SECTION_ID", "load_search_dir", "search_section", "search_sections"]
