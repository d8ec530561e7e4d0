"""Charts drawn by the real Vega renderer: vl-convert runs the same Vega and Vega-Lite libraries
that the report embeds and gives the scenegraph, every drawn mark with its pixel geometry, its
colour and its accessible description (the values of its fields), so a test checks what a reader
sees, not the specification's text."""

from __future__ import annotations

import re
from typing import Any

import vl_convert as vlc

from navstress.analysis.charts import VL_VERSION


def scene(spec: dict[str, Any]) -> dict[str, Any]:
    sg: dict[str, Any] = vlc.vegalite_to_scenegraph(spec, vl_version=VL_VERSION)
    return sg


def _groups(node: Any, out: list[dict[str, Any]]) -> list[dict[str, Any]]:
    if isinstance(node, dict):
        if node.get("marktype") and node.get("role") == "mark":
            out.append(node)
        for v in node.values():
            _groups(v, out)
    elif isinstance(node, list):
        for v in node:
            _groups(v, out)
    return out


def marks(spec: dict[str, Any], name: str) -> list[dict[str, Any]]:
    """The drawn items of the unit named ``name`` (in a concatenation Altair suffixes it ``_<i>``)."""
    pat = re.compile(rf"^{re.escape(name)}(_\d+)?_marks$")
    groups = [g for g in _groups(scene(spec)["scenegraph"], []) if pat.match(str(g.get("name", "")))]
    assert groups, f"no mark named {name}"
    return [it for g in groups for it in g.get("items", [])]


def all_marks(spec: dict[str, Any]) -> dict[str, list[dict[str, Any]]]:
    """Every data mark's items by mark name."""
    out: dict[str, list[dict[str, Any]]] = {}
    for g in _groups(scene(spec)["scenegraph"], []):
        out.setdefault(str(g.get("name")), []).extend(g.get("items", []))
    return out


def fields(item: dict[str, Any]) -> dict[str, str]:
    """An item's description (``"a: 1; b: x"``) as a dict."""
    out = {}
    for part in str(item.get("description", "")).split("; "):
        k, _, v = part.partition(": ")
        out[k] = v
    return out


def rgb(colour: str) -> tuple[int, int, int]:
    """``rgb(1, 2, 3)`` or ``#rrggbb`` as a triple."""
    m = re.match(r"rgb\((\d+), (\d+), (\d+)\)", colour)
    if m:
        return int(m[1]), int(m[2]), int(m[3])
    c = colour.lstrip("#")
    return int(c[0:2], 16), int(c[2:4], 16), int(c[4:6], 16)
