"""The report's charts (PNG bytes): difficulty per class, verdicts per world, indeterminism, fault
power. The maps with their runs and a navigator's perceived map are SVG (:mod:`navstress.analysis.svgmap`),
in the outcome colours of :mod:`navstress.run.figures` used everywhere in navstress.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from navstress.run.figures import legend, png_bytes
from navstress.run.figures import new_figure as _figure

# ---- analysis pictures (PNG bytes, for the HTML report) --------------------------------------

LEVEL_STYLE: dict[str, tuple[str, str]] = {  # level -> (marker, colour)
    "easy": ("o", "#1a9641"),
    "challenging": ("s", "#f08a24"),
    "very difficult": ("X", "#d7191c"),
    "no data": ("o", "#bbbbbb"),
}



def _xs(values: list[Any]) -> tuple[list[float], list[str] | None]:
    """Numeric x positions of parameter values (categorical positions when not all numeric)."""
    try:
        return [float(v) for v in values], None
    except (TypeError, ValueError):
        return [float(i) for i in range(len(values))], [str(v) for v in values]


def class_figure(experiment: str, stats: list[Any], levels: dict[tuple[str, str], str], *, dpi: int = 90,
                 navigator: str | None = None, fault: str = "nominal", by_key: bool = False) -> bytes:
    """The paper's Fig. 7-9 layout for one experiment class: success rate (95 % CI bars, the
    level marked per point), median duration and median tortuousness of successful runs,
    against the swept parameter (``by_key``: against the configuration keys, for explicit
    worlds). ``stats``: ConfigStats (one navigator's nominal runs); with ``navigator``, only
    its rows are drawn and the title names it and ``fault``."""
    items = [s for s in stats if s.experiment == experiment
             and (navigator is None or (s.navigator == navigator and s.fault == fault))]
    param = "world" if by_key else next(iter(items[0].params), "configuration") if items else "configuration"
    xs, ticks = ([float(i) for i in range(len(items))], [s.config_key for s in items]) if by_key \
        else _xs([s.params.get(param, s.config_key) for s in items])
    fig = _figure(11.0, 3.4, dpi)
    axes = fig.subplots(1, 3, sharex=True)
    seen: set[str] = set()
    for x, s in zip(xs, items):
        lev = levels.get(s.key, "no data")
        mk, col = LEVEL_STYLE.get(lev, ("o", "#000000"))
        if s.runs:
            r = s.successes / s.runs
            axes[0].errorbar([x], [100 * r], yerr=[[100 * (r - s.ci_low)], [100 * (s.ci_high - r)]], fmt=mk,
                             color=col, ms=8, capsize=3, label=None if lev in seen else lev)
            seen.add(lev)
        if s.median_duration_s is not None:
            axes[1].plot([x], [s.median_duration_s], mk, color=col, ms=8)
        if s.median_tortuousness is not None:
            axes[2].plot([x], [s.median_tortuousness], mk, color=col, ms=8)
    for ax, lab in zip(axes, ("success rate [%]", "median duration of successes [s]",
                              "median tortuousness of successes [rad/step]")):
        ax.set_ylabel(lab)
        ax.set_xlabel(param.rsplit(".", 1)[-1])
        ax.grid(True, alpha=0.3)
        if ticks is not None:
            ax.set_xticks(xs, ticks, rotation=30)
    axes[0].set_ylim(-5, 105)
    axes[0].axhline(25, color="#d7191c", lw=0.8, ls=":")
    if seen:
        legend(axes[0], fontsize=8, loc="best")
    who = f" ({navigator}, {fault} runs)" if navigator is not None else ""
    fig.suptitle(f"{experiment}: difficulty against {param}{who}", fontsize=11)
    return png_bytes(fig)


def indeterminism_figure(title: str, curves: dict[str, dict[str, Any]], *, dpi: int = 90) -> bytes:
    """Fig. 10-11: mean max distance between repeated runs over time, one line per
    configuration; panels for successful and unsuccessful runs. ``curves[config][group]``."""
    fig = _figure(11.0, 3.6, dpi)
    axes = fig.subplots(1, 2, sharey=True)
    for ax, group, name in zip(axes, ("success", "failure"), ("successful runs", "unsuccessful runs")):
        n = 0
        for cfg, cs in curves.items():
            c = cs.get(group)
            if c is None:
                continue
            ax.plot(c.t, c.d, lw=1.5, label=f"{cfg} ({c.n_maps} map{'s' if c.n_maps != 1 else ''})")
            n += 1
        ax.set_title(f"{title}: {name}", fontsize=10)
        ax.set_xlabel("time t [s]")
        ax.grid(True, alpha=0.3)
        if n:
            legend(ax, fontsize=7)
        else:
            ax.text(0.5, 0.5, "no map with 2+ such runs", ha="center", va="center", transform=ax.transAxes,
                    color="#777777")
    axes[0].set_ylabel("max distance between runs [m]")
    return png_bytes(fig)


def fault_power_figure(level_powers: list[Any], *, dpi: int = 90, navigator: str | None = None) -> bytes:
    """Fig. 12: runs with collisions per difficulty level, faulty navigator beside nominal
    (the title names ``navigator``, whose faults and nominal runs these are)."""
    fig = _figure(7.5, 3.6, dpi)
    ax = fig.subplots()
    labels = [f"{p.level or 'no level'}\n{p.fault}" for p in level_powers]
    x = np.arange(len(level_powers), dtype=float)
    who = f"{navigator} " if navigator else ""
    ax.bar(x - 0.2, [p.collisions for p in level_powers], 0.4, color="#d7191c",
           label=f"{who}faulty: runs with collision")
    ax.bar(x + 0.2, [p.nominal_collisions for p in level_powers], 0.4, color="#1a9641",
           label=f"{who}nominal: runs with collision")
    for xi, p in zip(x, level_powers):
        ax.text(xi - 0.2, p.collisions, f"{p.collisions}/{p.runs}", ha="center", va="bottom", fontsize=8)
        ax.text(xi + 0.2, p.nominal_collisions, f"{p.nominal_collisions}/{p.nominal_runs}", ha="center",
                va="bottom", fontsize=8)
    ax.set_xticks(x, labels)
    ax.set_ylabel("runs with a collision")
    ax.set_title(f"Fault-revealing power per difficulty level{': ' + navigator if navigator else ''}", fontsize=10)
    legend(ax, fontsize=8)
    ax.grid(True, axis="y", alpha=0.3)
    return png_bytes(fig)


VERDICT_COLOURS: dict[str, str] = {
    "passes": "#1a9641", "fails": "#d7191c", "flaky": "#7b3294", "undecided": "#999999",
}


def verdict_figure(title: str, configs: list[Any], worlds: list[Any], threshold: float, *, dpi: int = 90) -> bytes:
    """Per configuration (x), a strip of its worlds: pass probability with its exact interval,
    coloured by verdict, beside the pooled configuration (black diamond); the threshold dashed.
    ``configs`` and ``worlds``: :class:`~navstress.analysis.verdicts.WorldVerdict` of one
    experiment, navigator and fault."""
    fig = _figure(max(6.0, min(15.0, 2.7 + 0.9 * len(configs))), 3.4, dpi)
    ax = fig.subplots()
    seen: set[str] = set()
    for i, c in enumerate(configs):
        ws = [w for w in worlds if w.config_key == c.config_key and w.runs]
        for j, w in enumerate(ws):
            x = i - 0.3 + 0.5 * (j + 0.5) / max(len(ws), 1)
            p = w.successes / w.runs
            col = VERDICT_COLOURS.get(w.verdict, "#000000")
            ax.errorbar([x], [p], yerr=[[p - w.ci[0]], [w.ci[1] - p]], fmt="o", color=col, ms=5, capsize=2,
                        label=None if w.verdict in seen else f"world {w.verdict}")
            seen.add(w.verdict)
        if c.runs:
            p = c.successes / c.runs
            ax.errorbar([i + 0.32], [p], yerr=[[p - c.ci[0]], [c.ci[1] - p]], fmt="D", color="#000000", ms=6,
                        capsize=3, label=None if "pooled" in seen else "configuration (pooled)")
            seen.add("pooled")
            ax.text(i + 0.32, 1.06, c.verdict, ha="center", va="bottom", fontsize=7,
                    color=VERDICT_COLOURS.get(c.verdict, "#000000"))
    ax.axhline(threshold, color="#555555", lw=0.8, ls="--")
    ax.set_xticks(list(range(len(configs))), [c.config_key for c in configs], rotation=20, fontsize=8)
    ax.set_xlim(-0.6, len(configs) - 0.4)
    ax.set_ylim(-0.05, 1.15)
    ax.set_ylabel("pass probability (exact interval)")
    ax.grid(True, axis="y", alpha=0.3)
    if seen:
        legend(ax, fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    ax.set_title(title, fontsize=10)
    return png_bytes(fig)
