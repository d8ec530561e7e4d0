"""The one safe reader of spec files (world specs, campaign specs, navigator configs).

Specs are small. Every YAML/JSON text a user hands to navstress goes through :func:`parse_text`
(or :func:`read_text` + :func:`parse_text`, or :func:`load_file`), which refuses, with a one-line
:class:`~navstress.errors.SpecError` and before building anything large:

- a file over :data:`MAX_BYTES` bytes, or one that is not UTF-8 text (binary data);
- nesting deeper than :data:`MAX_DEPTH` levels (no ``RecursionError``);
- more than :data:`MAX_NODES` values once YAML aliases are expanded (a "billion laughs" bomb is
  refused in milliseconds, whatever the multiplication its anchors hide), and recursive aliases.

    >>> parse_text("a: [1, 2]", field="spec")
    {'a': [1, 2]}
    >>> parse_text("a: &x [1]\\nb: [*x, *x]", field="spec")
    {'a': [1], 'b': [[1], [1]]}
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Literal

import yaml

from navstress.errors import SpecError

#: Largest spec file read, in bytes (1 MiB; the paper's campaign spec is about 2 KB).
MAX_BYTES = 1 << 20
#: Deepest nesting of mappings and lists in a spec.
MAX_DEPTH = 64
#: Most values (scalars, lists, mappings) a spec may hold after YAML aliases are expanded.
MAX_NODES = 100_000

Format = Literal["yaml", "json"]
_Loader: Any = getattr(yaml, "CSafeLoader", yaml.SafeLoader)  # libyaml when built with it: same results, faster


def read_text(path: str | Path, *, field: str, what: str = "a readable YAML or JSON file") -> str:
    """The UTF-8 text of a spec file, at most :data:`MAX_BYTES` bytes (SpecError otherwise)."""
    p = Path(path)
    try:
        with open(p, "rb") as f:
            raw = f.read(MAX_BYTES + 1)
    except IsADirectoryError:
        raise SpecError(field, str(p), what, "this is a directory") from None
    except OSError as err:
        raise SpecError(field, str(p), what, str(err.strerror or err)) from None
    if len(raw) > MAX_BYTES:
        raise SpecError(field, str(p), f"a spec file of at most {MAX_BYTES} bytes",
                        "specs are small: is this the right file?")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as err:
        raise SpecError(field, str(p), "a UTF-8 text file (YAML or JSON)",
                        f"byte {err.start} is not UTF-8: is this a binary file?") from None
    if "\x00" in text:
        raise SpecError(field, str(p), "a UTF-8 text file (YAML or JSON)", "it holds NUL bytes: is this a binary file?")
    return text


def parse_text(text: str, *, field: str, name: str | None = None, fmt: Format = "yaml") -> Any:
    """Parse spec text (YAML, or JSON when ``fmt="json"``) within the bounds of this module.

    ``name`` (a file name, default the text itself, shortened) is the value an error names."""
    shown = name if name is not None else (text if len(text) <= 80 else text[:77] + "...")
    if len(text.encode("utf-8", "surrogatepass")) > MAX_BYTES:
        raise SpecError(field, shown, f"a spec of at most {MAX_BYTES} bytes", "specs are small")
    if fmt == "json":
        return _parse_json(text, field, shown)
    return _parse_yaml(text, field, shown)


def load_file(path: str | Path, *, field: str, fmt: Format | None = None) -> Any:
    """Read and parse a spec file; ``fmt`` None: JSON for ``*.json``, YAML otherwise."""
    p = Path(path)
    text = read_text(p, field=field)
    return parse_text(text, field=field, name=str(p), fmt=fmt or ("json" if p.suffix.lower() == ".json" else "yaml"))


# ---- JSON -----------------------------------------------------------------------------


def _parse_json(text: str, field: str, shown: str) -> Any:
    depth = _bracket_depth(text)
    if depth > MAX_DEPTH:
        raise _too_deep(field, shown, depth)
    try:
        data = json.loads(text)
    except json.JSONDecodeError as err:
        raise SpecError(field, shown, "valid JSON", f"{err.msg} at line {err.lineno} column {err.colno}") from None
    except (RecursionError, ValueError) as err:  # ValueError: e.g. an integer of too many digits
        raise SpecError(field, shown, "valid JSON", f"{type(err).__name__}: {err}".splitlines()[0]) from None
    _check_count(data, field, shown)
    return data


def _bracket_depth(text: str) -> int:
    """Upper bound of the JSON nesting depth (brackets inside strings counted too: conservative
    only where a string holds many unbalanced brackets, which JSON specs do not)."""
    depth = best = 0
    in_str = esc = False
    for ch in text:
        if in_str:
            if esc:
                esc = False
            elif ch == "\\":
                esc = True
            elif ch == '"':
                in_str = False
        elif ch == '"':
            in_str = True
        elif ch in "[{":
            depth += 1
            if depth > best:
                best = depth
                if best > MAX_DEPTH:
                    return best
        elif ch in "]}":
            depth -= 1
    return best


def _check_count(data: Any, field: str, shown: str) -> None:
    """Iteratively count the values of parsed JSON (no aliases: the text bounds it, but say so)."""
    stack = [data]
    n = 0
    while stack:
        v = stack.pop()
        n += 1
        if n > MAX_NODES:
            raise _too_many(field, shown)
        if isinstance(v, dict):
            stack.extend(v.values())
            n += len(v)  # the keys
        elif isinstance(v, list):
            stack.extend(v)


# ---- YAML -----------------------------------------------------------------------------


def _parse_yaml(text: str, field: str, shown: str) -> Any:
    loader = _Loader(text)
    try:
        _check_events(text, field, shown)
        node = loader.get_single_node()
        if node is None:
            return None
        _check_graph(node, field, shown)
        return loader.construct_document(node)
    except SpecError:
        raise
    except yaml.YAMLError as err:
        raise SpecError(field, shown, "valid YAML/JSON", " ".join(str(err).split())[:300]) from None
    except RecursionError:  # bounded above; kept as a last guard
        raise _too_deep(field, shown, MAX_DEPTH + 1) from None
    except (ValueError, OverflowError, TypeError) as err:  # a scalar the constructor cannot take
        raise SpecError(field, shown, "valid YAML/JSON", f"{type(err).__name__}: {err}".splitlines()[0]) from None
    finally:
        loader.dispose()


def _check_events(text: str, field: str, shown: str) -> None:
    """Refuse deep nesting from the event stream, before any node tree is built (no recursion)."""
    depth = 0
    for ev in yaml.parse(text, Loader=_Loader):
        if isinstance(ev, (yaml.SequenceStartEvent, yaml.MappingStartEvent)):
            depth += 1
            if depth > MAX_DEPTH:
                raise _too_deep(field, shown, depth)
        elif isinstance(ev, (yaml.SequenceEndEvent, yaml.MappingEndEvent)):
            depth -= 1


def _check_graph(root: yaml.Node, field: str, shown: str) -> None:
    """Count the values of the node graph with aliases expanded (each shared node's expanded size
    computed once), and refuse recursive aliases and graphs deeper than MAX_DEPTH."""
    size: dict[int, int] = {}
    depth: dict[int, int] = {}
    on_path: set[int] = set()
    stack: list[tuple[yaml.Node, bool]] = [(root, False)]
    while stack:
        node, done = stack.pop()
        k = id(node)
        kids = _children(node)
        if done:
            on_path.discard(k)
            size[k] = 1 + sum(size[id(c)] for c in kids)
            depth[k] = 1 + max((depth[id(c)] for c in kids), default=0)
            if size[k] > MAX_NODES:
                raise _too_many(field, shown)
            if depth[k] > MAX_DEPTH:
                raise _too_deep(field, shown, depth[k])
            continue
        if k in size:
            continue
        if k in on_path:
            raise SpecError(field, shown, "a spec without recursive aliases", "an alias refers to its own anchor")
        on_path.add(k)
        stack.append((node, True))
        for c in kids:
            ck = id(c)
            if ck in on_path:
                raise SpecError(field, shown, "a spec without recursive aliases", "an alias refers to its own anchor")
            if ck not in size:
                stack.append((c, False))


def _children(node: yaml.Node) -> list[yaml.Node]:
    if isinstance(node, yaml.SequenceNode):
        return list(node.value)
    if isinstance(node, yaml.MappingNode):
        return [x for kv in node.value for x in kv]
    return []


def _too_deep(field: str, shown: str, depth: int) -> SpecError:
    return SpecError(field, shown, f"a spec nested at most {MAX_DEPTH} levels deep",
                     f"it nests more than {min(depth, MAX_DEPTH + 1) - 1} levels")


def _too_many(field: str, shown: str) -> SpecError:
    return SpecError(field, shown, f"a spec of at most {MAX_NODES:,} values once YAML aliases are expanded",
                     "specs are small: remove the nested aliases (&anchor / *alias)")
