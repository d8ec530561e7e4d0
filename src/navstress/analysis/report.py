"""``navstress report DIR -o report.html``: one self-contained HTML file for a person.

Charts are Vega-Lite specifications drawn by the Vega libraries embedded once in the page
(:mod:`navstress.analysis.charts`: zoom, pan, the numbers of a mark on hovering it), the maps
inline SVG (:mod:`navstress.analysis.svgmap`); one small embedded script sorts and filters tables
and links runs with their lines; the page loads nothing from outside. Sections: summary (campaign, runs done/planned, outcome counts, what is missing),
difficulty table (per configuration: parameters, runs, success % with its 95 % interval,
median duration and tortuousness of successes, mean end distance to goal, level), level
ranges per class (fuzzy thresholds), per-class figures, verdicts (per configuration a table row and
per experiment, navigator and fault a strip of its worlds: pass probability, exact interval,
class; the worlds that do not pass listed), indeterminism, fault power,
descriptor correlations, and one section per configuration (every map with all its runs
colour-coded by outcome, one real-vs-perceived picture, the final perceived map, and a table of
its runs with seeds, reason and a link to each trace; a click on a run opens its own view: its
facts and, for a failing run, its trajectories and its final perceived map).

Runs on maps the world generator refused (:func:`navstress.run.record.ungenerated`) are in no
figure: the summary counts them apart (``refused-runs``, ``refused-maps``), the difficulty table
gives each configuration's refused maps (``refused-maps``), the verdicts table its refused worlds
and the configurations with none generated (``verdicts-refused``); the runs tables list them as
recorded.

Every figure and table says which navigator (and fault) it shows: per-configuration pictures
are drawn per map and per (navigator, fault), never mixing runs of two navigators, and their
titles and captions name both; figures carry ``data-navigator`` and ``data-fault``. With
``navigator`` given (``report --navigator X``), tables and figures show that navigator alone.

Every number a test may check carries stable attributes: summary values have ids
(``runs-done``, ``runs-planned``, ``outcome-<outcome>``); table rows carry
``data-experiment``, ``data-config``, ``data-navigator``, ``data-fault`` and cells
``data-field="<name>"`` with the exact value in ``data-value`` (empty when undefined).
Works on a partial or running campaign and on an empty one.

Layout: the page reads at a phone's width (390 px) and a laptop's (1,280 px) without sideways
scrolling; a wide table scrolls in its own box. Every table puts the columns a person came for
first (level, success, verdict, pass probability, ...: header cells ``th.key``); in a
``table.keyed`` the first cell says what the row is (its class, navigator and fault in small type
below) and stays in view while the table scrolls (docs/analysis.md, "On a phone or a laptop").
"""

from __future__ import annotations

import base64
import html
import math
import os
import re
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from navstress import _files
from navstress._percent import percent, setting
from navstress.analysis.analyze import Analysis, analyze, trace_path
from navstress.analysis.trajectories import TrajectoryCache
from navstress.analysis.difficulty import NO_DATA, NO_MAPS, DifficultyParams
from navstress.analysis import svgmap
from navstress.analysis import charts
from navstress.analysis.charts import (LEVEL_STYLE, VERDICT_COLOURS, chart_html, class_chart, fault_power_chart,
                                       indeterminism_chart, verdict_chart)
from navstress.analysis.stats import NOMINAL, ConfigStats, config_key, fault_name, params_text, reason_line
from navstress.analysis.verdicts import WorldVerdict
from navstress.run.figures import OUTCOME_COLOURS, OUTCOME_LABELS, RunTrack
from navstress.run.outcome import Outcome
from navstress.run.record import RunRecord, ungenerated
from navstress.run.trace import TOPIC_MAP, TOPIC_PERCEIVED, TOPIC_TRUTH, read_grid, read_movers
from navstress.sequential import FLAKY_BAND
from navstress.world.world import World

_CSS = """
body{font-family:system-ui,-apple-system,Segoe UI,Roboto,sans-serif;margin:0 auto;max-width:1200px;padding:1em 2em;
color:#222;line-height:1.4;overflow-wrap:break-word}
@media (max-width:640px){body{padding:.5em .75em}h1{font-size:1.6em}}@media (min-width:641px){.level{white-space:nowrap}}
h1{margin-bottom:.2em}h2{border-bottom:2px solid #ddd;padding-bottom:.2em;margin-top:2em}
table{border-collapse:collapse;margin:.6em 0;font-size:.9em}
th,td{border:1px solid #ccc;padding:.25em .55em;text-align:right}th{background:#f3f3f3}
td.l,th.l{text-align:left}td[data-field=reason]{min-width:16em}
.level{display:inline-block;font-weight:600;padding:.05em .4em;border-radius:3px;color:#fff}
.note{color:#555;font-size:.9em}.warn{background:#fff4d6;border:1px solid #e8c46b;padding:.5em 1em;border-radius:4px}
img.figure{max-width:100%;height:auto;border:1px solid #eee;margin:.3em 0}
.maps{display:flex;flex-wrap:wrap;gap:.6em}.maps figure{margin:0;flex:0 1 auto;max-width:100%}
figcaption{font-size:.85em;color:#444}
nav{display:flex;flex-wrap:wrap;gap:.2em 1em}
pre{overflow-x:auto;max-width:100%}
.scroll{overflow-x:auto;max-width:100%}
table.keyed{border-collapse:separate;border-spacing:0}table.keyed th,table.keyed td{border-width:1px 1px 0 0}
table.keyed tr:last-child>*{border-bottom-width:1px}
table.keyed tr>:first-child{position:sticky;left:0;z-index:1;background:#fff;border-left-width:1px}
table.keyed tr>th:first-child{background:#f3f3f3}table.keyed tr.hl>td:first-child{background:#fff3b0}
small.sub{display:block;color:#666;font-size:.8em;font-weight:normal;overflow-wrap:anywhere}
table.sortable th{cursor:pointer;user-select:none}
table.sortable th[aria-sort=ascending]::after{content:" \\25B2";font-size:.7em}
table.sortable th[aria-sort=descending]::after{content:" \\25BC";font-size:.7em}
input.filter{margin:.3em 0;padding:.2em .4em;width:20em;max-width:100%;box-sizing:border-box;font:inherit}
details.runs summary{cursor:pointer;margin:.4em 0}
.runview{border:1px solid #ccc;border-radius:4px;padding:.4em 1em;margin:.6em 0;background:#fafafa}
.runview h4{margin:.2em 0}.runview button.close{float:right;font:inherit}
.runview dl{display:grid;grid-template-columns:max-content 1fr;gap:.1em 1em;font-size:.9em;margin:.4em 0}
.runview dt{color:#555}.runview dd{margin:0;min-width:0;overflow-wrap:anywhere}
.runview .pair{display:flex;flex-wrap:wrap;gap:.6em}.runview .pair svg.map{width:380px;max-width:100%;cursor:default}
"""

#: The column of the runs on maps the world generator refused, beside the outcomes.
REFUSED = "refused"

#: Tables a reader sorts by clicking a column's header (then again for the other direction):
#: they are written with ``class="sortable"`` (as is every runs table).
SORTABLE = ("difficulty-table", "verdicts-configurations", "verdicts-worlds", "indeterminism-table",
            "fault-power-table", "descriptor-correlations")
#: Sorting and filtering, embedded (the report needs no network). A cell sorts by its
#: ``data-value`` when it has a number there, else by its text (as a number when it reads as one);
#: empty cells last. A ``table.filterable`` gets a text box that hides the rows not containing it.
_SCRIPT = r"""
(function(){
function key(td){
  if(!td) return null;
  var v=td.getAttribute('data-value');
  if(v!==null&&v!==''&&!isNaN(+v)) return +v;
  var t=td.textContent.trim();
  if(t===''||t==='\u2013') return null;
  var n=t.replace(/[%,\s]/g,'');
  return (/^[-+]?\d*\.?\d+(e[-+]?\d+)?$/i.test(n))?+n:t.toLowerCase();
}
function cmp(a,b){
  if(a===null) return b===null?0:1; if(b===null) return -1;
  if(typeof a===typeof b) return a<b?-1:a>b?1:0;
  return typeof a==='number'?-1:1;
}
document.querySelectorAll('table.sortable').forEach(function(t){
  var head=t.rows[0]; if(!head) return;
  Array.prototype.forEach.call(head.cells,function(th,i){
    th.title='sort by '+th.textContent.trim();
    th.addEventListener('click',function(){
      var dir=th.getAttribute('aria-sort')==='ascending'?-1:1;
      Array.prototype.forEach.call(head.cells,function(h){h.removeAttribute('aria-sort');});
      var rows=Array.prototype.slice.call(t.rows,1);
      rows.sort(function(a,b){
        var ka=key(a.cells[i]),kb=key(b.cells[i]);
        if(ka===null||kb===null) return cmp(ka,kb);
        return dir*cmp(ka,kb);
      });
      var body=rows.length?rows[0].parentNode:t;
      rows.forEach(function(r){body.appendChild(r);});
      th.setAttribute('aria-sort',dir===1?'ascending':'descending');
    });
  });
});
function select(id,toRow){
  var q='[data-run="'+CSS.escape(id)+'"]';
  document.querySelectorAll('.hl').forEach(function(e){e.classList.remove('hl');});
  document.querySelectorAll('svg.map.dim').forEach(function(e){e.classList.remove('dim');});
  var gs=document.querySelectorAll('svg.map g'+q);
  gs.forEach(function(g){g.classList.add('hl');g.ownerSVGElement.classList.add('dim');});
  var row=document.querySelector('table.runs tr'+q);
  if(row) row.classList.add('hl');
  var panel=showRun(id,row);
  if(toRow&&row){var d=row.closest('details');if(d) d.open=true;row.scrollIntoView({block:'center'});}
  else if(!toRow&&panel) panel.scrollIntoView({block:'nearest'});
  else if(!toRow&&gs.length) gs[0].ownerSVGElement.scrollIntoView({block:'center'});
}
// a run's own view, in its configuration's panel: its row's cells (outcome, reason, seeds, trace
// link) and, for a failing run, its embedded pictures (a <template>, inert until shown)
function showRun(id,row){
  if(!row) return null;
  var sec=row.closest('section'), panel=sec&&sec.querySelector('.runview');
  if(!panel) return null;
  var heads=Array.prototype.map.call(row.closest('table').rows[0].cells,function(th){return th.textContent.trim();});
  var dl=document.createElement('dl');
  Array.prototype.forEach.call(row.cells,function(td,i){
    var dt=document.createElement('dt'), dd=document.createElement('dd');
    dt.textContent=heads[i]; dd.innerHTML=td.innerHTML; dl.append(dt,dd);
  });
  var h=document.createElement('h4'); h.textContent='Run '+id;
  var close=document.createElement('button'); close.type='button'; close.className='close'; close.textContent='close';
  close.addEventListener('click',function(){panel.hidden=true;});
  panel.replaceChildren(close,h,dl);
  var t=sec.querySelector('template[data-run-view="'+CSS.escape(id)+'"]');
  if(t) panel.appendChild(t.content.cloneNode(true));
  else{
    var p=document.createElement('p'); p.className='note';
    p.textContent=row.dataset.outcome==='success'?'A successful run: its line is marked on the maps above; its '+
      'perceived map is in its trace.':'No picture embedded for this run: its trace holds it.';
    panel.appendChild(p);
  }
  panel.setAttribute('data-run',id); panel.hidden=false;
  return panel;
}
document.querySelectorAll('svg.map').forEach(function(svg){
  svg.addEventListener('click',function(ev){
    var g=ev.target.closest('g[data-run]');
    if(g){select(g.getAttribute('data-run'),true);return;}
    svg.classList.toggle('big');
  });
});
document.querySelectorAll('table.runs tr[data-run]').forEach(function(tr){
  tr.addEventListener('click',function(){select(tr.getAttribute('data-run'),false);});
});
document.querySelectorAll('table.filterable').forEach(function(t){
  var box=document.createElement('input');
  box.type='search'; box.className='filter'; box.placeholder='filter rows (any text: an outcome, a reason, a seed)';
  box.setAttribute('data-filter-for',t.id||'');
  var host=t.parentNode.classList.contains('scroll')?t.parentNode:t;
  host.parentNode.insertBefore(box,host);
  box.addEventListener('input',function(){
    var q=box.value.toLowerCase();
    Array.prototype.slice.call(t.rows,1).forEach(function(r){
      r.style.display=(!q||r.textContent.toLowerCase().indexOf(q)>=0)?'':'none';
    });
  });
});
})();
"""


def _e(x: Any) -> str:
    return html.escape(str(x), quote=True)


def _fmt(v: float | None, digits: int = 2) -> str:
    return "\u2013" if v is None or (isinstance(v, float) and not math.isfinite(v)) else f"{v:.{digits}f}"


def _pc(x: float | None) -> str:
    """A rate as a percentage (navstress._percent), the dash when there is none."""
    t = percent(x)
    return "\u2013" if t == "-" else t


def _dv(v: Any) -> str:
    """The exact value for a data-value attribute ('' when undefined)."""
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return ""
    return repr(float(v)) if isinstance(v, float) else str(v)


def _cell(field: str, value: Any, text: str | None = None, cls: str = "") -> str:
    c = f' class="{cls}"' if cls else ""
    return f'<td{c} data-field="{field}" data-value="{_e(_dv(value))}">{_e(text if text is not None else value)}</td>'


@dataclass(frozen=True)
class Section:
    """A section a higher layer adds to the report (the search's, ``navstress.search.report``):
    its anchor ``id``, its title in the navigation bar and its HTML (headings included), shown
    after the summary."""

    id: str
    title: str
    html: str


def figure_html(png: bytes, name: str, alt: str, navigator: str | None = None, fault: str | None = None) -> str:
    """An embedded figure as every figure of the report is written (``data-figure`` = ``name``)."""
    return _img(png, name, alt, navigator, fault)


def cell_html(field: str, value: Any, text: str | None = None, cls: str = "") -> str:
    """A table cell as every cell of the report is written (``data-field``, exact ``data-value``)."""
    return _cell(field, value, text, cls)


def _img(png: bytes, name: str, alt: str, navigator: str | None = None, fault: str | None = None) -> str:
    b64 = base64.b64encode(png).decode("ascii")
    who = "".join(f' data-{k}="{_e(v)}"' for k, v in (("navigator", navigator), ("fault", fault)) if v is not None)
    return f'<img class="figure" data-figure="{_e(name)}"{who} alt="{_e(alt)}" src="data:image/png;base64,{b64}">'


def _level_badge(level: str) -> str:
    col = LEVEL_STYLE.get(level, ("o", "#888"))[1]
    return f'<span class="level" style="background:{col}">{_e(level)}</span>'


def _slug(*parts: str) -> str:
    return "cfg-" + re.sub(r"[^A-Za-z0-9_-]+", "-", "--".join(parts)).strip("-")


def _row_attrs(s: ConfigStats) -> str:
    return (f'data-experiment="{_e(s.experiment)}" data-config="{_e(s.config_key)}" '
            f'data-navigator="{_e(s.navigator)}" data-fault="{_e(s.fault)}"')


def _sub(experiment: str, navigator: str | None = None, fault: str | None = None, who: bool = False) -> str:
    """The second line of a row's first cell: its experiment class and, where the table holds
    several (navigator, fault) pairs, its navigator and fault."""
    return " \u00b7 ".join([experiment] + ([f"{navigator}, {fault}"] if who else []))


def _first(main: str, sub: str = "") -> str:
    """A row's first cell in a ``table.keyed``: what the row is (``main``) and, in small type
    below it, where it belongs (``sub``); it stays in view while the table scrolls sideways."""
    small = f' <small class="sub">{_e(sub)}</small>' if sub else ""
    return f'<td class="l">{_e(main)}{small}</td>'


# ---- sections ---------------------------------------------------------------------------------

def _robots_line(a: Analysis) -> str:
    """Which robot the results are for: the one robot, or the robots, each result (table row,
    figure) then being one ``navigator@robot``'s."""
    items = ", ".join(f'<span class="robot" data-robot="{_e(n)}" data-digest="{_e(d)}">{_e(n)}</span>' for n, d in a.robots)
    if len(a.robots) <= 1:
        return f'robot <b id="robots">{items}</b>'
    return (f'robots <b id="robots">{items}</b>: every table row and figure is one navigator on one robot '
            '(<i>navigator@robot</i>), never two robots together')


def _summary(a: Analysis) -> str:
    out = [f'<h1>Campaign <span id="campaign-name">{_e(a.name)}</span></h1>',
           f'<p class="note">Directory <code>{_e(a.root)}</code>; report written {_e(time.strftime("%Y-%m-%d %H:%M"))}; '
           f'difficulty, indeterminism and correlations use the nominal runs of <b id="difficulty-navigator">'
           f'{_e(a.navigator)}</b>; runs shown: <span id="shown-navigators">{_e(", ".join(a.shown_navigators))}'
           f'</span>; {_robots_line(a)}.</p>',
           *([f'<p class="note" id="sources">World sources: ' + "; ".join(
               f'<span class="source" data-kind="{_e(k)}" data-sha256="{_e(h)}">{_e(k)} <code>{_e(p)}</code> '
               f'(sha256 {_e(h[:12])})</span>' for k, p, h in a.sources) + '</p>'] if a.sources else []),
           '<h2 id="summary">Summary</h2>',
           f'<p>Runs recorded: <b id="runs-done" data-value="{a.done}">{a.done}</b> of '
           f'<b id="runs-planned" data-value="{a.planned}">{a.planned}</b> planned.</p>']
    if a.done == 0:
        out.append('<p class="warn" id="empty-campaign">This campaign has no recorded run yet: there is nothing to '
                   'analyse. Run it with <code>navstress campaign run SPEC -o DIR</code> and rebuild the report.</p>')
    elif a.done < a.planned:
        miss = a.missing
        items = "".join(f'<li data-experiment="{_e(e)}" data-config="{_e(k)}">{_e(e)} / {_e(k)}: '
                        f'{d} of {p} runs</li>' for e, k, d, p in miss[:200])
        more = f"<li>... and {len(miss) - 200} more</li>" if len(miss) > 200 else ""
        out.append(f'<div class="warn" id="partial-campaign"><p>The campaign is not complete ({a.planned - a.done} '
                   f'runs missing); figures show what is recorded so far. Incomplete configurations:</p>'
                   f'<ul>{items}{more}</ul></div>')
    rows = "".join(f'<tr><td class="l"><span style="color:{OUTCOME_COLOURS.get(o, "#000")}">&#9632;</span> '
                   f'{_e(OUTCOME_LABELS.get(o, o))}</td><td id="outcome-{_e(o)}" data-value="{n}">{n}</td></tr>'
                   for o, n in a.outcome_counts.items())
    rows += (f'<tr><td class="l">on maps the world generator refused (never run)</td>'
             f'<td id="refused-runs" data-value="{a.refused_runs}">{a.refused_runs}</td></tr>')
    everyone = "all navigators and faults" if len(a.robots) <= 1 else "all navigators, robots and faults"
    out.append(f'<table id="outcome-counts"><tr><th class="l">outcome ({everyone})</th>'
               f'<th>runs</th></tr>{rows}</table>')
    if a.refused_runs:
        items = "".join(f'<li data-experiment="{_e(e)}" data-config="{_e(k)}" data-value="{len(r.maps)}">{_e(e)} / '
                        f'{_e(k)}: {len(r.maps)} of {a.maps_of((e, k))} maps ({_e(", ".join(f"m{m}" for m in r.maps))})'
                        f'; first reason: {_e(reason_line(r.reason))}</li>' for (e, k), r in list(a.refused.items())[:200])
        more = f"<li>... and {len(a.refused) - 200} more</li>" if len(a.refused) > 200 else ""
        out.append(f'<div class="warn" id="refused-maps" data-value="{a.refused_maps}"><p>The world generator refused '
                   f'{a.refused_maps} map{"s" if a.refused_maps != 1 else ""}: their {a.refused_runs} runs never ran, '
                   'so they measure the world spec, not the navigation, and every figure of this report leaves them '
                   'out (the runs tables list them as recorded). A configuration with no generated map has no level '
                   f'(<i>{_e(NO_MAPS)}</i>).</p><ul>{items}{more}</ul></div>')
    by_nav: dict[tuple[str, str], dict[str, int]] = {}
    for r in a.records:
        if a.shows(r.navigator):
            c = by_nav.setdefault((r.navigator, fault_name(r.fault)), dict.fromkeys([*a.outcome_counts, REFUSED], 0))
            o = REFUSED if ungenerated(r) else r.outcome
            c[o] = c.get(o, 0) + 1
    order = {n: i for i, n in enumerate(a.navigators)}
    nav_rows = "".join(
        f'<tr data-navigator="{_e(n)}" data-fault="{_e(f)}">{_first(n, f)}'
        + "".join(_cell(o, c.get(o, 0)) for o in [*a.outcome_counts, REFUSED]) + "</tr>"
        for (n, f), c in sorted(by_nav.items(), key=lambda kv: (order.get(kv[0][0], len(order)), kv[0][1] != NOMINAL,
                                                              kv[0][1])))
    key = ' class="key"'
    heads = "".join(f'<th{key if o == Outcome.SUCCESS.value else ""}>{_e(OUTCOME_LABELS.get(o, o))}</th>'
                    for o in a.outcome_counts) + "<th>on refused maps</th>"
    out.append(f'<table id="outcome-counts-by-navigator" class="keyed"><tr><th class="l">navigator and fault</th>'
               f'{heads}</tr>{nav_rows}</table>')
    gone = a.refused_by_experiment()
    exp_rows = "".join(
        f'<tr data-experiment="{_e(e)}"><td class="l">{_e(e)}</td><td data-field="done" data-value="{d}">{d}</td>'
        f'<td data-field="planned" data-value="{p}">{p}</td>'
        + "".join(f'<td data-field="{_e(o)}" data-value="{n}">{n}</td>' for o, n in c.items())
        + _cell(REFUSED, gone.get(e, 0)) + "</tr>"
        for e, d, p, c in a.per_experiment)
    out.append(f'<table id="per-experiment" class="keyed"><tr><th class="l">experiment class</th><th>done</th><th>planned</th>'
               f'{heads}</tr>{exp_rows}</table>')
    return "\n".join(out)


def _difficulty(a: Analysis) -> str:
    p = a.difficulty.params
    out = ['<h2 id="difficulty">Difficulty levels (Q1)</h2>',
           f'<p class="note">A configuration with a success rate below {setting(p.threshold)} is <i>very '
           f'difficult</i>; the others are clustered by k-means (k = {p.k}) on min-max normalised success rate, '
           f'median duration and median tortuousness of successful runs, weighted {", ".join(f"{w:g}" for w in p.weights)}. '
           'The cluster holding the flat, obstacle-free configuration is <i>easy</i>, the other <i>challenging</i>. '
           'Success intervals: 95% Wilson score. Tortuousness: mean absolute heading change between positions '
           'resampled every 0.5 m of travelled distance (moves under 0.1 m dropped), in radians per step. '
           '<i>Maps infeasible a priori</i>: maps on which the world generator found no traversable path for '
           'the nominal robot (slope limit 25 deg, obstacles inflated by its half-width) before any run. '
           '<i>Maps refused</i>: maps the world generator could not make (their runs never ran: left out of '
           f'every figure; the reason on hovering); a configuration with none generated is <i>{_e(NO_MAPS)}</i>.</p>']
    for n in a.difficulty.notes:
        out.append(f'<p class="note">Note: {_e(n)}</p>')
    rows = []
    shown = [s for s in a.stats if a.shows(s.navigator)]
    who = len({(s.navigator, s.fault) for s in shown}) > 1
    for s in shown:
        lev = a.level(s.experiment, s.config_key)
        rate = s.success_rate
        rows.append(
            f'<tr {_row_attrs(s)}>' + _config_cell(a, s, who)
            + f'<td class="l" data-field="level" data-value="{_e(lev)}">{_level_badge(lev)}</td>'
            + _cell("success-rate", rate, _pc(rate))
            + _cell("ci-low", s.ci_low if s.runs else None, _pc(s.ci_low if s.runs else None))
            + _cell("ci-high", s.ci_high if s.runs else None, _pc(s.ci_high if s.runs else None))
            + _cell("runs", s.runs, f"{s.runs}/{s.planned}" if s.planned else str(s.runs))
            + _cell("successes", s.successes)
            + _cell("median-duration", s.median_duration_s, _fmt(s.median_duration_s, 1))
            + _cell("median-tortuousness", s.median_tortuousness, _fmt(s.median_tortuousness, 4))
            + _cell("mean-goal-distance", s.mean_goal_distance_m, _fmt(s.mean_goal_distance_m, 2))
            + _cell("infeasible-maps", a.infeasible.get(s.key, (0, 0))[0],
                    "{}/{}".format(*a.infeasible.get(s.key, (0, 0))))
            + _refused_cell(a, s)
            + "".join(_cell(f"n-{o}", n) for o, n in s.outcomes.items())
            + f'<td class="l">{_e(s.experiment)}</td><td class="l">{_e(s.navigator)}</td><td class="l">{_e(s.fault)}</td>'
            + f'<td class="l"><a href="#{_slug(s.experiment, s.config_key)}">maps</a></td></tr>')
    heads = "".join(f"<th>{_e(OUTCOME_LABELS.get(o, o))}</th>" for o in (a.stats[0].outcomes if a.stats else {}))
    out.append('<table id="difficulty-table" class="sortable keyed"><tr><th class="l">parameters</th>'
               '<th class="l key">level</th><th class="key">success</th><th>CI low</th><th>CI high</th><th>runs</th>'
               '<th>successes</th><th>median duration [s]</th><th>median tortuousness</th><th>mean end distance [m]</th>'
               f'<th>maps infeasible a priori</th><th>maps refused</th>{heads}<th class="l">class</th><th class="l">navigator</th>'
               '<th class="l">fault</th><th></th></tr>'
               + "".join(rows) + "</table>")
    # level ranges and overlaps
    rr = "".join(f'<tr data-experiment="{_e(r.experiment)}" data-level="{_e(r.level)}"><td class="l">{_e(r.experiment)}'
                 f'</td><td class="l">{_level_badge(r.level)}</td><td class="l">{_e(", ".join(map(str, r.values)))}</td>'
                 f'<td>{_fmt(r.lo, 3)} \u2013 {_fmt(r.hi, 3)}</td></tr>' for r in a.ranges)
    out.append('<h3>Which parameter values got which level</h3>'
               '<table id="level-ranges"><tr><th class="l">class</th><th class="l">level</th>'
               f'<th class="l">values</th><th>range</th></tr>{rr}</table>')
    if a.overlaps:
        ov = "".join(f'<li data-experiment="{_e(o.experiment)}">{_e(o.experiment)}: {_e(o.a)} and {_e(o.b)} overlap '
                     f'over {o.lo:g} \u2013 {o.hi:g} (fuzzy threshold)</li>' for o in a.overlaps)
        out.append(f'<ul id="level-overlaps">{ov}</ul>')
    else:
        out.append('<p id="level-overlaps" class="note">No overlap between the levels\' ranges in any class.</p>')
    return "\n".join(out)


def _refused_cell(a: Analysis, s: ConfigStats) -> str:
    """A configuration's maps the world generator refused, of its maps (the first reason as the
    cell's title), and the runs on them (``data-runs``)."""
    n = len(s.refused.maps)
    title = f' title="{_e(reason_line(s.refused.reason))}"' if s.refused.runs else ""
    return (f'<td data-field="refused-maps" data-value="{n}" data-runs="{s.refused.runs}"{title}>'
            f'{n}/{a.maps_of(s.key)}</td>')


def _config_cell(a: Analysis, s: ConfigStats, who: bool) -> str:
    """A configuration's first cell: its parameters (an explicit world: its key, its overrides in
    the small line below with its class)."""
    if s.experiment in a.explicit:
        return _first(s.config_key, " \u00b7 ".join([_sub(s.experiment, s.navigator, s.fault, who),
                                                     params_text(s.params)]))
    return _first(params_text(s.params), _sub(s.experiment, s.navigator, s.fault, who))


def _class_figures(a: Analysis) -> str:
    out = ['<h2 id="classes">Per experiment class</h2>']
    exps = list(dict.fromkeys(s.experiment for s in a.nominal))
    levels = {s.key: a.level(*s.key) for s in a.nominal}
    for e in exps:
        if not any(s.runs for s in a.nominal if s.experiment == e):
            out.append(f'<p class="note">{_e(e)}: no run recorded yet.</p>')
            continue
        out.append(f"<h3>{_e(e)}: nominal runs of {_e(a.navigator)}</h3>"
                   + chart_html(class_chart(e, a.nominal, levels, navigator=a.navigator, by_key=e in a.explicit),
                                f"class-{e}",
                                f"success rate, duration and tortuousness of {e}, nominal runs of {a.navigator}",
                                a.navigator, NOMINAL))
    return "\n".join(out)


def _verdict_badge(v: str) -> str:
    return f'<span class="level" style="background:{VERDICT_COLOURS.get(v, "#888")}">{_e(v)}</span>'


def _verdict_cells(w: WorldVerdict) -> str:
    """The verdict first, then the pass probability and its interval, then the counts."""
    pp = w.pass_probability
    return (f'<td class="l" data-field="verdict" data-value="{_e(w.verdict)}">{_verdict_badge(w.verdict)}</td>'
            + _cell("pass_probability", pp, _pc(pp))
            + _cell("ci_low", w.ci[0], _pc(w.ci[0])) + _cell("ci_high", w.ci[1], _pc(w.ci[1]))
            + _cell("runs", w.runs) + _cell("successes", w.successes))


def _verdict_attrs(w: WorldVerdict) -> str:
    m = "" if w.map_index is None else f' data-map="{w.map_index}"'
    return (f'data-experiment="{_e(w.experiment)}" data-config="{_e(w.config_key)}"{m} '
            f'data-navigator="{_e(w.navigator)}" data-fault="{_e(w.fault)}"')


def _zone(indifference: float) -> str:
    """", indifference 25 %" for a rule with an indifference zone, "" without."""
    return f", indifference {setting(indifference)}" if indifference else ""


def _verdicts(a: Analysis, max_worlds: int = 2000) -> str:
    v = a.verdicts
    r = v.rule
    conf = setting(r.confidence)
    minus, plus = (" minus the indifference", " plus the indifference") if r.indifference else ("", "")
    out = ['<h2 id="verdicts">Verdicts per world and per configuration</h2>',
           f'<p class="note" id="verdict-rule" data-threshold="{r.threshold!r}" data-confidence="{r.confidence!r}">'
           f'A world is one map run by one navigator with one fault; a configuration pools its maps. Pass probability: '
           f'successes / runs with its exact (Clopper-Pearson) {conf} interval. Verdict ({_e(r.source)}, threshold '
           f'{setting(r.threshold)}, confidence {conf}{_zone(r.indifference)}), proven by an anytime-valid confidence '
           'sequence, so it holds however many runs were made: <i>passes</i> (pass probability at least the threshold'
           f'{minus}), <i>fails</i> (below it{plus}), <i>flaky</i> (both outcomes likely: proven between '
           f'{setting(FLAKY_BAND[0])} and {setting(FLAKY_BAND[1])}) or <i>undecided</i> (more runs needed). '
           'See docs/statistics.md.</p>']
    own = [(e, x) for e, x in v.rules.items() if x != r]
    if own:
        out.append('<p class="note" id="verdict-rules">Experiments with their own adaptive rule: ' + "; ".join(
            f'<span data-experiment="{_e(e)}" data-threshold="{x.threshold!r}" data-confidence="{x.confidence!r}">'
            f'{_e(e)}: threshold {setting(x.threshold)}, confidence {setting(x.confidence)}{_zone(x.indifference)}'
            '</span>'
            for e, x in own) + ".</p>")
    cfgs = [c for c in v.configurations if a.shows(c.navigator)]
    worlds = [w for w in v.worlds if a.shows(w.navigator)]
    gone = [g for g in v.refused if a.shows(g.navigator)]
    if gone:
        items = "".join(f'<li data-experiment="{_e(g.experiment)}" data-config="{_e(g.config_key)}" '
                        f'data-navigator="{_e(g.navigator)}" data-fault="{_e(g.fault)}" data-value="{g.worlds}">'
                        f'{_e(g.experiment)} / {_e(g.config_key)} ({_e(g.navigator)}, {_e(g.fault)}): {g.worlds} '
                        f'map{"s" if g.worlds != 1 else ""} refused, first: {_e(reason_line(g.reason))}</li>'
                        for g in gone)
        out.append('<div class="note" id="verdicts-refused"><p>No verdict (every recorded map refused by the world '
                   f'generator: nothing ran):</p><ul>{items}</ul></div>')
    if not cfgs:
        out.append('<p class="note">No run recorded yet.</p>' if not gone else '')
        return "\n".join(out)
    heads = ('<th class="l key">verdict</th><th class="key">pass probability</th><th>low</th><th>high</th>'
             '<th>runs</th><th>successes</th>')
    ids = '<th class="l">class</th><th class="l">navigator</th><th class="l">fault</th>'
    who = len({(c.navigator, c.fault) for c in cfgs}) > 1
    rows = "".join(
        f'<tr {_verdict_attrs(c)}>' + _first(c.config_key, _sub(c.experiment, c.navigator, c.fault, who))
        + _verdict_cells(c) + _cell("worlds", c.worlds) + "".join(_cell(f"worlds_{k}", n) for k, n in c.world_verdicts)
        + _cell("refused_worlds", c.refused_worlds)
        + f'<td class="l">{_e(c.experiment)}</td><td class="l">{_e(c.navigator)}</td><td class="l">{_e(c.fault)}</td>'
        + "</tr>" for c in cfgs)
    wheads = "".join(f"<th>worlds {k}</th>" for k, _ in cfgs[0].world_verdicts)
    out.append(f'<table id="verdicts-configurations" class="sortable keyed"><tr><th class="l">configuration</th>'
               f'{heads}<th>worlds</th>{wheads}<th>worlds refused</th>{ids}</tr>{rows}</table>')
    groups = list(dict.fromkeys((c.experiment, c.navigator, c.fault) for c in cfgs))
    for e, n, f in groups:
        cs = [c for c in cfgs if (c.experiment, c.navigator, c.fault) == (e, n, f)]
        ws = [w for w in worlds if (w.experiment, w.navigator, w.fault) == (e, n, f)]
        title = f"{e}: verdicts per world ({n}, {f} runs)"
        out.append(chart_html(verdict_chart(title, cs, ws, v.rule_for(e).threshold), f"verdicts-{e}-{n}-{f}",
                              f"pass probability and verdict of every world of {e}, {n}, {f}", n, f))
    shown = [w for w in worlds if w.verdict != "passes"][:max_worlds]
    wrows = "".join(
        f'<tr {_verdict_attrs(w)}>' + _first(f"{w.config_key} m{w.map_index}", _sub(w.experiment, w.navigator, w.fault, who))
        + _verdict_cells(w) + _cell("map", w.map_index)
        + f'<td class="l">{_e(w.experiment)}</td><td class="l">{_e(w.navigator)}</td><td class="l">{_e(w.fault)}</td>'
        + "</tr>" for w in shown)
    n_pass = sum(w.verdict == "passes" for w in worlds)
    more = (f'<p class="note">... and {len([w for w in worlds if w.verdict != "passes"]) - max_worlds} more '
            '(all in <code>analyze --json</code> and <code>campaign export --table verdicts</code>).</p>'
            if len([w for w in worlds if w.verdict != "passes"]) > max_worlds else "")
    out.append(f'<h3>Worlds that do not pass</h3><p class="note">{n_pass} of {len(worlds)} worlds pass; '
               'the others:</p>'
               f'<table id="verdicts-worlds" class="sortable keyed"><tr><th class="l">world (configuration, map)</th>'
               f'{heads}<th>map</th>{ids}</tr>{wrows}</table>{more}')
    return "\n".join(out)


def _barn(a: Analysis) -> str:
    """BARN's score (:mod:`navstress.analysis.barn`): per navigator and fault, overall and per world."""
    b = a.barn
    assert b is not None
    out = ['<h2 id="barn">BARN score</h2>',
           '<p class="note" id="barn-formula">The BARN benchmark\'s score of each run: <i>success</i> &times; '
           '<i>t</i><sub>opt</sub> / clip(<i>t</i>, 2 <i>t</i><sub>opt</sub>, 8 <i>t</i><sub>opt</sub>), with '
           '<i>t</i><sub>opt</sub> = <i>L</i> / 2 m/s, <i>L</i> the length of start &rarr; the world\'s path file '
           '&rarr; goal, and <i>t</i> BARN\'s clock (from the robot\'s first 0.1 m to its first time within 1 m of the '
           'goal, on the run\'s ground truth). 0 for a failed run, at most 0.5 (a success within twice the optimal '
           'time). A world\'s score is the mean of its runs, the overall score the mean over every run: BARN\'s own '
           'figure, beside navstress\'s outcomes, verdicts and indeterminism below. See docs/worlds.md, "The BARN '
           'benchmark".</p>']
    groups = [g for g in b.groups if a.shows(g.navigator)]
    if b.notes:
        out.append('<div class="note" id="barn-notes"><ul>' + "".join(f"<li>{_e(n)}</li>" for n in b.notes)
                   + "</ul></div>")
    if not groups:
        out.append('<p class="note">No run recorded on a BARN world yet.</p>')
        return "\n".join(out)
    rows = "".join(
        f'<tr data-navigator="{_e(g.navigator)}" data-fault="{_e(g.fault)}">{_first(g.navigator, g.fault)}'
        + _cell("barn_score", g.score, _fmt(g.score, 4), "key") + _cell("runs", g.runs) + _cell("successes", g.successes)
        + _cell("success_rate", g.successes / g.runs if g.runs else None, _pc(g.successes / g.runs if g.runs else None))
        + _cell("worlds", sum(1 for w in g.worlds if w.runs)) + "</tr>" for g in groups)
    out.append('<table id="barn-overall" class="keyed"><tr><th class="l">navigator and fault</th>'
               '<th class="key">BARN score (mean over runs)</th><th>runs</th><th>successes</th><th>success rate</th>'
               f'<th>worlds</th></tr>{rows}</table>')
    who = len(groups) > 1
    for g in groups:
        wrows = "".join(
            f'<tr data-experiment="{_e(w.world.experiment)}" data-config="{_e(w.world.key)}" '
            f'data-navigator="{_e(g.navigator)}" data-fault="{_e(g.fault)}" data-world="{w.world.index}">'
            + _first(w.world.key, _sub(w.world.experiment, g.navigator, g.fault, who))
            + _cell("barn_score", w.score, _fmt(w.score, 4), "key") + _cell("runs", len(w.runs))
            + _cell("successes", w.successes) + _cell("mean_t_s", w.mean_t_s, _fmt(w.mean_t_s))
            + _cell("t_opt_s", w.world.t_opt_s, _fmt(w.world.t_opt_s))
            + _cell("path_length_m", w.world.length_m, _fmt(w.world.length_m)) + "</tr>"
            for w in g.worlds)
        slug = "barn-" + _slug(g.navigator, g.fault)[4:]
        out.append(f'<h3>Per world: {_e(g.navigator)}, {_e(g.fault)}</h3>'
                   f'<table id="{slug}" class="sortable keyed barn-worlds"><tr><th class="l">world</th>'
                   '<th class="key">BARN score</th><th>runs</th><th>successes</th><th>mean t of successes (s)</th>'
                   f'<th>t<sub>opt</sub> (s)</th><th>path length (m)</th></tr>{wrows}</table>')
    return "\n".join(out)


def _indeterminism(a: Analysis) -> str:
    out = ['<h2 id="indeterminism">Indeterminism (Q2)</h2>',
           f'<p class="note">Nominal runs of <b>{_e(a.navigator)}</b>. For the repeated runs on one map, at each time t (step {a.dt:g} s) the maximum distance '
           'between their real positions (a run that has ended keeps its last position), averaged over the maps of '
           'a configuration, for all, successful and unsuccessful runs (a map counts with 2+ runs of the group).</p>']
    if not a.indeterminism:
        out.append('<p class="note" id="indeterminism-empty">No map has two or more recorded runs with a trace yet.</p>')
        return "\n".join(out)
    rows = []
    for (e, k), cs in a.indeterminism.items():
        for g, c in cs.items():
            rows.append(f'<tr data-experiment="{_e(e)}" data-config="{_e(k)}" data-group="{_e(g)}" '
                        f'data-navigator="{_e(a.navigator)}" data-fault="{NOMINAL}">'
                        + _first(k, e) + f'<td class="l">{_e(g)}</td>'
                        + _cell("peak", c.peak_m, _fmt(c.peak_m, 2)) + _cell("mean", c.mean_m, _fmt(c.mean_m, 2))
                        + _cell("final", c.final_m, _fmt(c.final_m, 2))
                        + _cell("n-maps", c.n_maps) + _cell("n-runs", c.n_runs)
                        + f'<td class="l">{_e(e)}</td><td class="l">{_e(a.navigator)}</td></tr>')
    out.append('<table id="indeterminism-table" class="sortable keyed"><tr><th class="l">configuration</th>'
               '<th class="l key">runs</th><th class="key">peak [m]</th><th class="key">time mean [m]</th>'
               '<th>final [m]</th><th>maps</th><th>runs</th><th class="l">class</th><th class="l">navigator</th></tr>'
               + "".join(rows) + "</table>")
    for e in dict.fromkeys(k[0] for k in a.indeterminism):
        curves = {k: cs for (ee, k), cs in a.indeterminism.items() if ee == e}
        out.append(chart_html(indeterminism_chart(f"{e} ({a.navigator}, nominal)", curves), f"indeterminism-{e}",
                              f"indeterminism curves of {e}, nominal runs of {a.navigator}", a.navigator, NOMINAL))
    return "\n".join(out)


def _fault_power(a: Analysis) -> str:
    out = ['<h2 id="fault-power">Fault-revealing power (Q3)</h2>',
           f'<p class="note">Faults injected into <b>{_e(a.navigator)}</b>. Runs of each faulty navigator with a collision, '
           'and failures of a kind the nominal '
           'navigator did not show on the same map ("new failures"), with the nominal figures beside them.</p>']
    if not a.power:
        out.append('<p class="note" id="fault-power-empty">No faulty run recorded.</p>')
        return "\n".join(out)
    who = len({p.navigator for p in a.power}) > 1
    rows = "".join(
        f'<tr data-experiment="{_e(p.experiment)}" data-config="{_e(p.config_key)}" data-fault="{_e(p.fault)}" '
        f'data-navigator="{_e(p.navigator)}">'
        + _first(p.config_key, " \u00b7 ".join([p.experiment] + ([p.navigator] if who else [])))
        + f'<td class="l">{_e(p.fault)}</td>'
        + _cell("collision-share", p.collision_share, _pc(p.collision_share))
        + _cell("new-failures", p.new_failures) + _cell("collisions", p.collisions) + _cell("runs", p.runs)
        + f'<td class="l">{_level_badge(p.level or NO_DATA)}</td>'
        + _cell("nominal-runs", p.nominal_runs) + _cell("nominal-collisions", p.nominal_collisions)
        + f'<td class="l">{_e(p.experiment)}</td><td class="l">{_e(p.navigator)}</td></tr>' for p in a.power)
    out.append('<table id="fault-power-table" class="sortable keyed"><tr><th class="l">configuration</th>'
               '<th class="l key">fault</th><th class="key">share with collision</th><th class="key">new failures</th>'
               '<th>with collision</th><th>runs</th><th class="l">level</th><th>nominal runs</th>'
               '<th>nominal with collision</th><th class="l">class</th><th class="l">navigator</th></tr>' + rows + "</table>")
    lrows = "".join(
        f'<tr data-level="{_e(p.level)}" data-fault="{_e(p.fault)}"><td class="l">{_level_badge(p.level or NO_DATA)}</td>'
        f'<td class="l">{_e(p.fault)}</td>' + _cell("collisions", p.collisions) + _cell("new-failures", p.new_failures)
        + _cell("runs", p.runs) + _cell("configs", p.configs)
        + _cell("nominal-runs", p.nominal_runs) + _cell("nominal-collisions", p.nominal_collisions) + "</tr>"
        for p in a.power_levels)
    out.append('<table id="fault-power-levels" class="keyed"><tr><th class="l">level</th><th class="l key">fault</th>'
               '<th class="key">with collision</th><th class="key">new failures</th><th>runs</th><th>configs</th>'
               '<th>nominal runs</th><th>nominal with collision</th></tr>' + lrows + "</table>")
    out.append(chart_html(fault_power_chart(a.power_levels, navigator=a.navigator), "fault-power",
                          f"collisions per difficulty level, faults of {a.navigator}", a.navigator))
    return "\n".join(out)


def _correlations(a: Analysis, top: int = 15) -> str:
    out = ['<h2 id="descriptors">Which a-priori descriptor predicts difficulty</h2>',
           f'<p class="note">Levels and failure rates of the nominal runs of <b>{_e(a.navigator)}</b>. '
           'Spearman rank correlation across configurations between each world descriptor (mean over '
           'the maps) and the level (easy 0, challenging 1, very difficult 2), and with the failure rate. Strongest '
           'first.</p>']
    cs = [c for c in a.correlations if c.rho_level is not None or c.rho_failure is not None][:top]
    if not cs:
        out.append('<p class="note" id="descriptors-empty">Too few configurations with a level (3 needed).</p>')
        return "\n".join(out)
    rows = "".join(f'<tr data-descriptor="{_e(c.descriptor)}"><td class="l">{_e(c.descriptor)}</td>'
                   + _cell("rho-level", c.rho_level, _fmt(c.rho_level, 2))
                   + _cell("rho-failure", c.rho_failure, _fmt(c.rho_failure, 2)) + _cell("n", c.n) + "</tr>" for c in cs)
    out.append('<table id="descriptor-correlations" class="sortable keyed"><tr><th class="l">descriptor</th>'
               '<th class="key">&rho; with level</th><th class="key">&rho; with failure rate</th><th>configs</th></tr>'
               + rows + "</table>")
    return "\n".join(out)


def _run_name(rec: RunRecord) -> str:
    """How a run is named in titles and captions: map, run, navigator and fault."""
    return f"m{rec.map_index} r{rec.run_index} {rec.navigator} {fault_name(rec.fault)}"


def _track(rec: RunRecord, root: Path, cache: TrajectoryCache, max_points: int, perceived: bool = False,
           world: World | None = None) -> RunTrack | None:
    """The run's track from its trace; with a ``world`` that has movers, the movers' poses too (drawn
    where they were at the run's first collision, and their paths in a one-run picture)."""
    tp = trace_path(root, rec)
    truth = cache.get(tp, TOPIC_TRUTH)
    if truth is None:
        return None
    per = cache.get(tp, TOPIC_PERCEIVED) if perceived else None
    movers = None
    if world is not None and world.movers and tp is not None:
        try:
            movers = read_movers(tp)
        except Exception:  # a trace still being written: the track without its movers
            movers = None
    return RunTrack(_run_name(rec), rec.outcome, cache.thin(truth, max_points),
                    None if per is None else cache.thin(per, max_points), None, movers, rec.first_collision_s)


def movers_note(world: World) -> str:
    """``", movers: 3 pedestrian (intercept), 1 vehicle (crossing)"`` ('' without movers): what a
    configuration picture's caption says of the world's movers (drawn in blue)."""
    if not world.movers:
        return ""
    kinds: dict[tuple[str, str], int] = {}
    for mv in world.movers:
        kinds[(mv.kind, mv.behaviour)] = kinds.get((mv.kind, mv.behaviour), 0) + 1
    return ", movers: " + ", ".join(f"{n} {k} ({b})" for (k, b), n in sorted(kinds.items()))


def _groups(recs: list[RunRecord], navigators: list[str]) -> list[tuple[str, str]]:
    """The (navigator, fault) pairs among ``recs``: navigators in spec order, nominal first."""
    pairs = {(r.navigator, fault_name(r.fault)) for r in recs}
    order = {n: i for i, n in enumerate(navigators)}
    return sorted(pairs, key=lambda p: (order.get(p[0], len(order)), p[1] != NOMINAL, p[1], p[0]))


#: Told how far a report is: (what is being done, steps done, steps in all); the steps are the
#: analysis, the page's first sections, then one per configuration drawn.
ProgressCallback = Callable[[str, int, int], None]


def _shown_by_config(a: Analysis) -> dict[tuple[str, str], list[RunRecord]]:
    by_cfg: dict[tuple[str, str], list[RunRecord]] = {}
    for r in a.records:
        if a.shows(r.navigator):
            by_cfg.setdefault((r.experiment, config_key(r)), []).append(r)
    return by_cfg


def _config_keys(a: Analysis) -> list[tuple[str, str]]:
    """The configurations drawn, in the report's order (one progress step each)."""
    return list(dict.fromkeys([s.key for s in a.stats]))


def _prefetch_shown(a: Analysis, cache: TrajectoryCache) -> None:
    """Every shown run is drawn: ask the cache's workers for the trajectories the analysis did not
    read (faults, other navigators) and for the beliefs of the failing runs that get a view of
    their own (a failing run's two trajectories read together: one pass over its trace); they read
    them while the page's first sections are written (:func:`_configs` waits for them)."""
    by_cfg = _shown_by_config(a)
    cache.prefetch([trace_path(a.root, r) for recs in by_cfg.values() for r in recs
                    if r.outcome != Outcome.SUCCESS.value][:MAX_RUN_VIEWS], (TOPIC_TRUTH, TOPIC_PERCEIVED), wait=False)
    cache.prefetch([trace_path(a.root, r) for recs in by_cfg.values() for r in recs], wait=False)


def _configs(a: Analysis, cache: TrajectoryCache, max_points: int, link_base: Path | None = None,
             progress: ProgressCallback | None = None) -> str:
    shown = ", ".join(a.shown_navigators)
    budget = _Budget(MAX_RUN_VIEWS)
    out = ['<h2 id="configurations">Configurations</h2>',
           f'<p class="note">Every map with its runs, one picture per navigator and fault (runs of {_e(shown)}), '
           'colour-coded by outcome; then, per navigator, one run in detail. Hover a run to name it, click it '
           'to find its row in the runs table (and a row to find its run) and to open its own view: outcome, '
           'reason, seeds, trace and, for a failing run, its real and perceived trajectories and its final '
           'perceived map; click a picture to enlarge it.</p>',
           svgmap.legend_html(OUTCOME_LABELS)]
    by_cfg = _shown_by_config(a)
    cache.wait()  # for what render_report asked for (_prefetch_shown); a trajectory not asked for is read on demand
    keys = _config_keys(a)
    for i, key in enumerate(keys):
        if progress is not None:
            progress("drawing the configurations", 2 + i, 2 + len(keys))
        e, k = key
        recs = by_cfg.get(key, [])
        lev = a.level(e, k)
        out.append(f'<section id="{_slug(e, k)}" data-experiment="{_e(e)}" data-config="{_e(k)}">'
                   f'<h3>{_e(e)} / {_e(k)} {_level_badge(lev)}</h3>')
        if not recs:
            out.append('<p class="note">No run recorded yet.</p></section>')
            continue
        worlds: dict[int, World] = {}
        gids: dict[int, str] = {}
        defs: list[str] = []
        figs = []
        groups = _groups(recs, a.navigators)
        for m, wdir in a.world_dirs.get(key, []):
            if not any(r.map_index == m for r in recs):
                continue
            told = next((r.reason for r in recs if r.map_index == m and ungenerated(r)), None)
            if told is not None:
                figs.append(f'<p class="note" data-refused-map="{m}">map m{m}: refused by the world generator, '
                            f'its runs never ran: {_e(reason_line(told))}</p>')
                continue
            try:
                worlds[m] = World.load(wdir)
            except Exception as err:  # a world still being written, or removed
                figs.append(f'<p class="note">map m{m}: world not readable ({_e(type(err).__name__)})</p>')
                continue
            gids[m] = f"w-{_slug(e, k)[4:]}-m{m}"
            defs.append(svgmap.world_defs(worlds[m], gids[m]))
            for nav, fault in groups:
                mrecs = [r for r in recs if r.map_index == m and r.navigator == nav and fault_name(r.fault) == fault]
                if not mrecs:
                    continue
                tracks = [(_e(r.run_id), t, _e(_tip(r))) for r in mrecs
                          if (t := _track(r, a.root, cache, max_points, world=worlds[m])) is not None]
                counts = ", ".join(f"{sum(r.outcome == o for r in mrecs)} {OUTCOME_LABELS[o]}"
                                   for o in OUTCOME_LABELS if any(r.outcome == o for r in mrecs))
                who = f"{nav}, {fault}"
                svg = svgmap.runs_svg(worlds[m], gids[m], tracks, label=_e(f"runs of {who} on map m{m}"),
                                      attrs=_fig_attrs(f"map-{e}-{k}-m{m}-{nav}-{fault}", nav, fault))
                figs.append(f'<figure data-navigator="{_e(nav)}" data-fault="{_e(fault)}" data-map="{m}">{svg}'
                            f'<figcaption>map m{m} (seed {mrecs[0].map_seed}, {_e(_size(worlds[m]))}){_e(movers_note(worlds[m]))}, '
                            f'<b>{_e(nav)}</b> ({_e(fault)}): {_e(counts)}</figcaption></figure>')
        # per navigator, one run in detail: its first nominal failure if any, else its first run with a trace
        for nav in dict.fromkeys(n for n, _f in groups):
            nrecs = [r for r in recs if r.navigator == nav]
            nominal = [r for r in nrecs if fault_name(r.fault) == NOMINAL]
            pick = next((r for r in nominal if r.outcome != Outcome.SUCCESS.value and r.map_index in worlds), None) or \
                next((r for r in nrecs if r.map_index in worlds and trace_path(a.root, r) is not None), None)
            if pick is None:
                continue
            fault = fault_name(pick.fault)
            w = worlds[pick.map_index]
            tr = _track(pick, a.root, cache, max_points, perceived=True, world=w)
            name = _run_name(pick)
            one = (_e(pick.run_id), tr, _e(_tip(pick))) if tr is not None else None
            if one is not None:
                svg = svgmap.runs_svg(w, gids[pick.map_index], [one], perceived=True,
                                      label=_e(f"real vs perceived trajectory of {name}"),
                                      attrs=_fig_attrs(f"perceived-{e}-{k}-{nav}", nav, fault))
                figs.append(f'<figure data-navigator="{_e(nav)}" data-fault="{_e(fault)}" data-map="{pick.map_index}">'
                            f'{svg}<figcaption>{_e(name)}: {_e(OUTCOME_LABELS.get(pick.outcome, pick.outcome))} '
                            f'\u2013 {_e(pick.reason)}; real (solid) and perceived (dashed)</figcaption></figure>')
            tp = trace_path(a.root, pick)
            try:
                grid = read_grid(tp, TOPIC_MAP) if tp is not None and tp.exists() else None
            except Exception:
                grid = None
            if grid is not None:
                svg, share = svgmap.perceived_svg(w, grid[0], grid[1], grid[2], one,
                                                  label=_e(f"final perceived map of {name}"),
                                                  attrs=_fig_attrs(f"navmap-{e}-{k}-{nav}", nav, fault))
                figs.append(f'<figure data-navigator="{_e(nav)}" data-fault="{_e(fault)}" data-map="{pick.map_index}">'
                            f'{svg}<figcaption>{_e(name)}: the navigator\'s map at the end, height from low '
                            f'(purple) to high (yellow); pink: never seen ({_e(percent(share))} of the map); '
                            'black outlines: the real obstacles</figcaption></figure>')
        views = []
        outlines: dict[int, str] = {}
        for r in sorted(recs, key=lambda r: (r.map_index, r.run_index, r.navigator, fault_name(r.fault))):
            if r.outcome == Outcome.SUCCESS.value or r.map_index not in worlds:
                continue
            if budget.left <= 0:
                budget.skipped += 1
                continue
            m = r.map_index
            if m not in outlines:
                od, outlines[m] = svgmap.outline_defs(worlds[m], f"{gids[m]}-outline")
                defs.append(od)
            view = _run_view(r, worlds[m], gids[m], a.root, cache, max_points, outlines[m])
            if view:
                views.append(view)
                budget.left -= 1
        out.append('<svg width="0" height="0" style="position:absolute" aria-hidden="true"><defs>'
                   + "".join(defs) + "</defs></svg>"
                   + '<div class="maps">' + "".join(figs) + "</div>"
                   + '<div class="runview" hidden></div>' + "".join(views)
                   + _runs_table(e, k, recs, a.root, link_base) + "</section>")
    if budget.skipped:
        out.append(f'<p class="note" id="run-views-skipped">{budget.skipped} failing runs have no embedded view '
                   f'(at most {MAX_RUN_VIEWS} per report, for its size): their trace links hold them.</p>')
    return "\n".join(out)


#: At most this many failing runs get their embedded per-run view (about 5 kB each).
MAX_RUN_VIEWS = 1000
#: A per-run perceived map is drawn with at most this many cells along its longer side.
RUN_VIEW_CELLS = 160


@dataclass
class _Budget:
    left: int
    skipped: int = 0


def coarse_grid(grid: np.ndarray, origin_xy: tuple[float, float], cell_m: float, max_cells: int
                ) -> tuple[np.ndarray, tuple[float, float], float]:
    """A grid with at most ``max_cells`` cells along its longer side: blocks of k x k cells, each
    the highest known height in it (unknown when none is known), the same origin, cells k times as
    large (the last block of a side may extend past the grid, as unknown cells)."""
    g = np.asarray(grid, dtype=np.float64)
    rows, cols = g.shape
    k = max(1, -(-max(rows, cols) // max_cells))
    if k == 1:
        return g, origin_xy, cell_m
    pad = np.full((-(-rows // k) * k, -(-cols // k) * k), -np.inf)
    pad[:rows, :cols] = np.where(np.isfinite(g), g, -np.inf)
    # block maxima, rows then columns (two contiguous reductions; the maximum of maxima is the maximum)
    top = pad.reshape(pad.shape[0] // k, k, pad.shape[1]).max(axis=1)
    top = top.reshape(top.shape[0], pad.shape[1] // k, k).max(axis=2)
    return np.where(np.isfinite(top), top, np.nan), origin_xy, cell_m * k


def _run_view(rec: RunRecord, world: World, gid: str, root: Path, cache: TrajectoryCache, max_points: int,
              outlines: str) -> str:
    """A failing run's own view, shown when its row or line is clicked (an inert ``<template>``
    until then): its real and perceived trajectories over its world, and its final perceived map
    (coarsened to :data:`RUN_VIEW_CELLS`, under the real obstacles' ``outlines``: a ``<use>`` of
    the map's outline); '' when its trace holds neither."""
    fault = fault_name(rec.fault)
    name = _run_name(rec)
    tr = _track(rec, root, cache, max_points, perceived=True, world=world)
    one = (_e(rec.run_id), tr, _e(_tip(rec))) if tr is not None else None
    parts = []
    if one is not None:
        parts.append(svgmap.runs_svg(world, gid, [one], perceived=True,
                                     label=_e(f"real vs perceived trajectory of {name}"),
                                     attrs=_fig_attrs(f"run-{rec.run_id}", rec.navigator, fault)))
    tp = trace_path(root, rec)
    try:
        grid = read_grid(tp, TOPIC_MAP) if tp is not None and tp.exists() else None
    except Exception:
        grid = None
    share = None
    if grid is not None:
        # (the trajectory is in the picture beside it)
        svg, share = svgmap.perceived_svg(world, *coarse_grid(grid[0], grid[1], grid[2], RUN_VIEW_CELLS), None,
                                          label=_e(f"final perceived map of {name}"),
                                          attrs=_fig_attrs(f"runmap-{rec.run_id}", rec.navigator, fault),
                                          outlines=outlines)
        parts.append(svg)
    if not parts:
        return ""
    seen = "" if share is None else f"; its map at the end: pink never seen ({percent(share)} of the map)"
    return (f'<template data-run-view="{_e(rec.run_id)}"><div class="pair">{"".join(parts)}</div>'
            f'<p class="note">real (solid) and perceived (dashed) trajectory{_e(seen)}, the real obstacles outlined'
            '</p></template>')


def _size(w: World) -> str:
    return f"{w.size_m[0]:g} \u00d7 {w.size_m[1]:g} m"


def _tip(r: RunRecord) -> str:
    """A run's tooltip: its name, outcome and reason."""
    return f"{_run_name(r)}: {OUTCOME_LABELS.get(r.outcome, r.outcome)} \u2013 {r.reason}"


def _fig_attrs(name: str, navigator: str, fault: str) -> str:
    return f'data-figure="{_e(name)}" data-navigator="{_e(navigator)}" data-fault="{_e(fault)}"'


def _trace_href(root: Path, rec: RunRecord, link_base: Path | None) -> str | None:
    """The link to a run's trace: relative to the report's folder when it is known, so that the
    report and the campaign can move together; None when the run has no trace file."""
    tp = trace_path(root, rec)
    if tp is None or not tp.exists():
        return None
    if link_base is not None:
        try:
            return Path(os.path.relpath(tp.resolve(), link_base.resolve())).as_posix()
        except ValueError:  # another drive
            pass
    return tp.resolve().as_uri()


def _runs_table(e: str, k: str, recs: list[RunRecord], root: Path, link_base: Path | None) -> str:
    """Every run of a configuration, one row each (sortable, filterable): map, run, outcome,
    reason, navigator, fault, duration, seeds and a link to its trace (open it in Foxglove)."""
    rows = []
    for r in sorted(recs, key=lambda r: (r.map_index, r.run_index, r.navigator, fault_name(r.fault))):
        href = _trace_href(root, r, link_base)
        link = f'<a href="{_e(href)}" data-trace>trace</a>' if href else "\u2013"
        rows.append(
            f'<tr data-run="{_e(r.run_id)}" data-outcome="{_e(r.outcome)}">'
            f'{_cell("map", r.map_index, f"m{r.map_index}")}{_cell("run", r.run_index, f"r{r.run_index}")}'
            f'<td class="l" data-field="outcome">{_e(OUTCOME_LABELS.get(r.outcome, r.outcome))}</td>'
            f'<td class="l" data-field="reason">{_e(r.reason)}</td>'
            f'<td class="l">{_e(r.navigator)}</td><td class="l">{_e(fault_name(r.fault))}</td>'
            f'{_cell("duration", r.duration_s, _fmt(r.duration_s, 1))}'
            f'{_cell("map-seed", r.map_seed, str(r.map_seed))}{_cell("run-seed", r.run_seed, str(r.run_seed))}'
            f'<td class="l">{link}</td></tr>')
    head = ('<tr><th>map</th><th>run</th><th class="l key">outcome</th><th class="l">reason</th>'
            '<th class="l">navigator</th><th class="l">fault</th><th>duration s</th><th>map seed</th><th>run seed</th><th class="l">trace</th></tr>')
    return (f'<details class="runs"><summary>{len(recs)} runs: outcome, reason, seeds and trace of each</summary>'
            f'<table id="runs-{_slug(e, k)[4:]}" class="sortable filterable runs">{head}{"".join(rows)}</table></details>')


def render_report(a: Analysis, *, cache: TrajectoryCache | None = None, max_points: int = 600,
                  sections: Sequence[Section] = (), link_base: Path | None = None,
                  progress: ProgressCallback | None = None) -> str:
    """The report's HTML text for an :class:`Analysis`; ``sections`` come after the summary;
    ``link_base``: the folder the report will be in (its links to traces are relative to it)."""
    if cache is None:
        with TrajectoryCache() as own:
            return render_report(a, cache=own, max_points=max_points, sections=sections, link_base=link_base,
                                 progress=progress)
    if a.done:
        _prefetch_shown(a, cache)
    if progress is not None:
        progress("writing the summary and the charts", 1, 2 + (len(_config_keys(a)) if a.done else 0))
    body = [_summary(a)] + [s.html for s in sections]
    barn = a.done > 0 and a.barn is not None
    if barn:
        body.append(_barn(a))
    if a.done:
        body += [_difficulty(a), _class_figures(a), _verdicts(a), _indeterminism(a), _fault_power(a), _correlations(a),
                 _configs(a, cache, max_points, link_base, progress)]
    links = [("summary", "Summary"), *((s.id, s.title) for s in sections)]
    if barn:
        links.append(("barn", "BARN score"))
    if a.done:
        links += [("difficulty", "Difficulty"), ("classes", "Classes"), ("verdicts", "Verdicts"),
                  ("indeterminism", "Indeterminism"), ("fault-power", "Fault power"), ("descriptors", "Descriptors"),
                  ("configurations", "Configurations")]
    nav = ("<nav>" + "".join(f'<a href="#{_e(i)}">{_e(t)}</a>' for i, t in links) + "</nav>") \
        if a.done or sections else ""
    text = "\n".join(body)
    # every table in a box of its own width: a wide table scrolls inside it, never the page
    text = text.replace("<table", '<div class="scroll"><table').replace("</table>", "</table></div>")
    return ("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
            "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">"
            f"<title>navstress report: {_e(a.name)}</title><style>{_CSS}{svgmap.CSS}{charts.CSS}</style></head>"
            f"<body data-campaign=\"{_e(a.name)}\">{nav}\n" + text + f"\n<script>{_SCRIPT}</script>\n"
            + (charts.page_script() + "\n" if '<div class="chart"' in text else "") + "</body></html>\n")


def build_report(directory: str | Path, out: str | Path, *, params: DifficultyParams | None = None,
                 navigator: str | None = None, dt: float = 1.0, max_points: int = 600,
                 sections: Sequence[Section] = (), progress: ProgressCallback | None = None) -> Path:
    """Analyse the campaign in ``directory`` and write the report to ``out`` atomically (with
    ``sections`` after the summary); returns ``out``. ``progress`` is told how far it is."""
    dest = Path(out)
    with TrajectoryCache() as cache:  # its reading processes, shared by the analysis and the pictures
        if progress is not None:
            progress("analysing the campaign", 0, 2)
        a = analyze(directory, params=params, navigator=navigator, dt=dt, cache=cache)
        text = render_report(a, cache=cache, max_points=max_points, sections=sections, link_base=dest.parent,
                             progress=progress)
    _files.write_atomic(dest, text)  # nothing partial left behind (a full disk, an interrupt)
    if progress is not None:
        n = 2 + (len(_config_keys(a)) if a.done else 0)
        progress("written", n, n)
    return dest


__all__ = ["ProgressCallback", "Section", "build_report", "cell_html", "figure_html", "render_report"]
