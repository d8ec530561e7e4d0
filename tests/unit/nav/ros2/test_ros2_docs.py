"""docs/ros2.md against the code it describes: its Configuration table names every key of
``Ros2Config`` (nested ones dotted, ``topics.clock``) with its default, and no key the code does
not have; every navigator configuration shown in the document (and in the README) is accepted by
``parse_config``. The document drifts from the code the moment a key is added, renamed or given
another default: these tests say which."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import pytest
import yaml
from pydantic import BaseModel

from navstress.nav.ros2.config import FramesConfig, LaunchConfig, QosConfig, Ros2Config, TopicsConfig, parse_config

ROOT = Path(__file__).resolve().parents[4]
DOC = ROOT / "docs" / "ros2.md"
#: nested models whose keys the table spells dotted (``topics.clock``); the others (``qos``'s
#: profile, ``launch``) have their keys named in their row's text
DOTTED: dict[str, type[BaseModel]] = {"topics": TopicsConfig, "frames": FramesConfig}
IN_ROW: dict[str, type[BaseModel]] = {"qos": QosConfig, "launch": LaunchConfig}


def _section(text: str, title: str) -> str:
    m = re.search(rf"^## {re.escape(title)}\n(.*?)(?=^## |\Z)", text, re.S | re.M)
    assert m is not None, f"docs/ros2.md has no section '## {title}'"
    return m.group(1)


def _rows(text: str) -> list[list[str]]:
    """The Configuration table's rows (header and rule left out), cells split on unescaped '|'."""
    rows = []
    for line in _section(text, "Configuration").splitlines():
        if not line.startswith("| ") or line.startswith("| key ") or line.startswith("|---"):
            continue
        cells = [c.strip() for c in re.split(r"(?<!\\)\|", line.strip().strip("|"))]
        rows.append(cells)
    return rows


def _names(cell: str) -> list[str]:
    """``topics.clock``, ``.tf`` -> topics.clock, topics.tf (a leading dot takes the prefix of the
    dotted name before it in the cell)."""
    out: list[str] = []
    prefix = ""
    for tok in re.findall(r"`([^`]+)`", cell):
        if tok.startswith(".") and prefix:
            tok = prefix + tok
        if "." in tok:
            prefix = tok.rsplit(".", 1)[0]
        out.append(tok)
    return out


def _defaults(cell: str) -> list[str]:
    return re.findall(r"`([^`]+)`", cell)


def documented(text: str) -> dict[str, tuple[str, str]]:
    """Each documented key -> (its default cell's value for that key, its row's meaning)."""
    out: dict[str, tuple[str, str]] = {}
    for cells in _rows(text):
        assert len(cells) == 3, cells
        names, defaults = _names(cells[0]), _defaults(cells[1])
        for i, n in enumerate(names):
            d = defaults[i] if len(defaults) == len(names) else (defaults[0] if defaults else cells[1])
            out[n] = (d, cells[2])
    return out


def expected_keys() -> dict[str, Any]:
    keys: dict[str, Any] = {}
    for name, field in Ros2Config.model_fields.items():
        if name in DOTTED:
            for sub, f in DOTTED[name].model_fields.items():
                keys[f"{name}.{sub}"] = f.get_default(call_default_factory=True)
        else:
            keys[name] = field.get_default(call_default_factory=True)
    return keys


def _same(default: Any, written: str) -> bool:
    if default is None:
        return written in ("none", "None")
    if isinstance(default, bool):
        return written == str(default).lower()
    if isinstance(default, (int, float)):
        try:
            return float(written) == float(default)
        except ValueError:
            return False
    if isinstance(default, str):
        return written == default
    if isinstance(default, dict) and not default:
        return written == "{}"
    return True  # a nested model: its keys are checked one by one


def test_every_key_is_documented_and_only_those() -> None:
    doc = documented(DOC.read_text())
    want = expected_keys()
    missing = sorted(set(want) - set(doc))
    extra = sorted(set(doc) - set(want))
    assert not missing, f"keys of Ros2Config missing from docs/ros2.md's Configuration table: {missing}"
    assert not extra, f"docs/ros2.md documents keys Ros2Config does not have: {extra}"


def test_every_documented_default_is_the_code_s() -> None:
    doc = documented(DOC.read_text())
    wrong = {k: (doc[k][0], v) for k, v in expected_keys().items() if k in doc and not _same(v, doc[k][0])}
    assert not wrong, f"documented default != code's (documented, code): {wrong}"


@pytest.mark.parametrize("parent", sorted(IN_ROW))
def test_nested_keys_named_in_their_row(parent: str) -> None:
    doc = documented(DOC.read_text())
    row = doc[parent][1]
    missing = [k for k in IN_ROW[parent].model_fields if f"`{k}" not in row and f"{k}:" not in row]
    assert not missing, f"docs/ros2.md's row for {parent} does not name {missing}"


def _ros2_configs(path: Path) -> list[dict[str, Any]]:
    out = []
    for block in re.findall(r"```yaml\n(.*?)```", path.read_text(), re.S):
        data = yaml.safe_load(block)
        for nav in (data or {}).get("navigators", []) if isinstance(data, dict) else []:
            if isinstance(nav, dict) and nav.get("name") in ("ros2", "ros2-v1"):
                out.append(nav.get("config") or {})
    return out


@pytest.mark.parametrize("path", [DOC, ROOT / "README.md"], ids=lambda p: p.name)
def test_every_shown_configuration_is_accepted(path: Path) -> None:
    configs = _ros2_configs(path)
    assert configs, f"{path.name} shows no ros2 navigator configuration"
    for c in configs:
        parse_config(c)  # raises SpecError naming the key if the document is wrong
