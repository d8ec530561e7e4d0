"""What every spec model shares (world, campaign and search specs, navigator configs, the robot):
one strict configuration and one translation of pydantic's errors into a one-line
:class:`~navstress.errors.SpecError` that names the field as the user wrote it.

**Strict.** A spec's values are taken as written, never converted: an integer field refuses
``true`` and ``"10"`` and ``10.5``, a number field refuses ``true`` and ``"0.5"`` (an integer is
a number), a boolean refuses ``1`` and ``"yes"``, and NaN and infinities are refused everywhere
(a field that means infinity says so with its own ``Field(allow_inf_nan=True)``). Lists stand for
tuples (YAML and JSON have no tuples): a tuple field is declared with :data:`LIST`, its items
stay strict.

    >>> from pydantic import BaseModel, Field
    >>> class Demo(BaseModel):
    ...     model_config = SPEC_CONFIG
    ...     n: int = 1
    ...     at: tuple[float, float] = Field((0.0, 0.0), strict=LIST)
    >>> parse(Demo, {"n": 3, "at": [1, 2.5]})
    Demo(n=3, at=(1.0, 2.5))
    >>> parse(Demo, {"n": "3"})
    Traceback (most recent call last):
    ...
    navstress.errors.SpecError: n='3' is invalid: expected an integer; write it without quotes

**Field paths.** An error names the path of the field in the mapping the user gave, with list
items as ``[i]`` (``experiments[0].worlds[1].map_seed``): the keys of pydantic's error location
that are not in the user's mapping (the tags of union members and validators) are left out. A
required field that is missing reads ``PATH is missing: expected ...`` and never shows the
mapping that lacks it.

    >>> parse(Demo, {"at": [1]})
    Traceback (most recent call last):
    ...
    navstress.errors.SpecError: at=[1] is invalid: expected a list with an item at index 1 (the list is too short)
"""

from __future__ import annotations

import math
import re
import types
import typing
from typing import Any, Literal, TypeVar

from pydantic import BaseModel, ConfigDict, ValidationError

from navstress.errors import MISSING, SpecError

__all__ = ["LIST", "SPEC_CONFIG", "describe", "parse", "path_text", "spec_error", "unoptional"]

#: The configuration of every spec model: frozen, no unknown key, strict types, finite numbers.
SPEC_CONFIG = ConfigDict(frozen=True, extra="forbid", strict=True, allow_inf_nan=False)
#: ``Field(strict=LIST)`` on a tuple field: a YAML/JSON list is taken for it (its items stay strict).
LIST = False

M = TypeVar("M", bound=BaseModel)


def parse(model: type[M], data: Any, *, prefix: str = "") -> M:
    """``model`` validated from ``data``; a :class:`SpecError` (see :func:`spec_error`) otherwise."""
    try:
        return model.model_validate(data)
    except SpecError:
        raise
    except ValidationError as err:
        raise spec_error(err, data, model=model, prefix=prefix) from None


def path_text(parts: typing.Sequence[str | int]) -> str:
    """``["experiments", 0, "name"]`` -> ``"experiments[0].name"``."""
    out = ""
    for p in parts:
        if isinstance(p, int):
            out += f"[{p}]"
        else:
            out += f".{p}" if out else str(p)
    return out


def _first_part(field: str) -> str:
    return re.split(r"[.\[]", field, maxsplit=1)[0]


def _user_loc(loc: tuple[Any, ...], data: Any, missing: bool) -> list[str | int]:
    """The parts of pydantic's ``loc`` that are keys and indices of ``data`` (the user's mapping):
    the tags pydantic adds for union members (``int``, ``AdaptiveRuns``) and validators
    (``function-after[...]``) are dropped. A missing field's own name (the last part) is kept."""
    out: list[str | int] = []
    node = data
    for i, part in enumerate(loc):
        last = i == len(loc) - 1
        if isinstance(node, dict) and not isinstance(part, int) and part in node:
            out.append(part)
            node = node[part]
        elif isinstance(node, (list, tuple)) and isinstance(part, int) and 0 <= part < len(node):
            out.append(part)
            node = node[part]
        elif isinstance(node, dict) and isinstance(part, int) and part in node:  # an int key of a mapping
            out.append(str(part))
            node = node[part]
        elif missing and last:
            out.append(part if isinstance(part, int) else str(part))
    return out


_SYM = {"ge": ">=", "gt": ">", "le": "<=", "lt": "<"}
_EXPECTED = {
    "float_parsing": "a number", "float_type": "a number", "finite_number": "a finite number",
    "int_parsing": "an integer", "int_type": "an integer", "int_from_float": "an integer (no fractional part)",
    "bool_parsing": "true or false", "bool_type": "true or false",
    "tuple_type": "a list", "list_type": "a list", "too_long": "a shorter list", "too_short": "a longer list",
    "dict_type": "a mapping of fields", "model_type": "a mapping of fields", "model_attributes_type": "a mapping of fields",
    "string_type": "a string", "none_required": "null",
}


def _fix(kind: str, value: Any) -> str | None:
    """Why a value of the right look is refused: the quotes, or a boolean for a number."""
    if kind in ("int_type", "float_type") and isinstance(value, str):
        return "write it without quotes"
    if kind in ("int_type", "float_type") and isinstance(value, bool):
        return "true and false are not numbers"
    if kind == "int_type" and isinstance(value, float) and value.is_integer():
        return f"write {int(value)}"
    return None


def describe(annotation: Any) -> str:
    """What a value of ``annotation`` is, in words (``int`` -> "an integer")."""
    ann = unoptional(annotation)
    origin = typing.get_origin(ann)
    if ann is bool:
        return "true or false"
    if ann is int:
        return "an integer"
    if ann is float:
        return "a number"
    if ann is str:
        return "a string"
    if origin is Literal:
        return f"one of {list(typing.get_args(ann))}"
    if origin in (list, tuple):
        args = [a for a in typing.get_args(ann) if a is not Ellipsis]
        if origin is tuple and args and Ellipsis not in typing.get_args(ann):
            return f"a list of {len(args)} values"
        return "a list"
    if origin is dict or (isinstance(ann, type) and issubclass(ann, BaseModel)):
        return "a mapping of fields"
    if origin is typing.Annotated:
        return describe(typing.get_args(ann)[0])
    return "a value"


def unoptional(ann: Any) -> Any:
    """``X`` for an annotation ``X | None`` (the annotation itself otherwise)."""
    if typing.get_origin(ann) in (typing.Union, types.UnionType):
        args = [a for a in typing.get_args(ann) if a is not type(None)]
        if len(args) == 1:
            return args[0]
    return ann


def _annotation_at(model: type[BaseModel] | None, parts: list[str | int]) -> Any:
    """The annotation of the field ``parts`` names under ``model`` (None when unknown)."""
    ann: Any = model
    for p in parts:
        ann = unoptional(ann)
        if typing.get_origin(ann) is typing.Annotated:
            ann = typing.get_args(ann)[0]
        origin = typing.get_origin(ann)
        if isinstance(ann, type) and issubclass(ann, BaseModel):
            f = ann.model_fields.get(str(p))
            if f is None:
                return None
            ann = f.annotation
        elif origin is dict:
            ann = typing.get_args(ann)[1]
        elif origin is list and isinstance(p, int):
            ann = typing.get_args(ann)[0]
        elif origin is tuple and isinstance(p, int):
            args = typing.get_args(ann)
            ann = args[0] if len(args) == 2 and args[1] is Ellipsis else (args[p] if p < len(args) else None)
        else:
            return None
    return ann


def spec_error(err: ValidationError, data: Any, *, model: type[BaseModel] | None = None,
               prefix: str = "") -> SpecError:
    """The first error of ``err`` as one :class:`SpecError` naming the field's path in ``data``.

    A validator's own SpecError names its field relative to the model that raised it, or from the
    root of the spec when its path starts with that model's own field (the world spec's
    validators): either way the result names it from the root of ``data``."""
    e = err.errors(include_url=False)[0]
    kind = str(e["type"])
    loc = tuple(e["loc"])
    ctx = e.get("ctx") or {}
    inner = ctx.get("error")
    pre = f"{prefix}." if prefix else ""
    if isinstance(inner, SpecError):
        where = _user_loc(loc, data, missing=False)
        if where and str(where[-1]) == _first_part(inner.field):
            where = where[:-1]
        head = path_text(where)
        field = f"{head}.{inner.field}" if head and not inner.field.startswith("[") else head + inner.field
        return SpecError(pre + (field or "spec"), inner.value, inner.expected, inner.fix)
    missing = kind == "missing"
    parts = _user_loc(loc, data, missing=missing)
    value: Any = e.get("input")
    fix: str | None = None
    if missing and parts and isinstance(parts[-1], int):  # a tuple's item: the list is too short
        value = _value_at(data, parts[:-1])
        expected = f"a list with an item at index {parts[-1]} (the list is too short)"
        parts = parts[:-1]
    elif missing:
        value = MISSING
        expected = f"{describe(_annotation_at(model, parts))} (this field is required)"
    else:
        bounds = {k: ctx[k] for k in ("ge", "gt", "le", "lt") if k in ctx}
        expected = str(e["msg"]).removeprefix("Input should be ").removeprefix("Value error, ")
        if isinstance(value, float) and math.isnan(value):
            expected = "a number (not NaN)"
        elif kind == "finite_number":
            expected = "a finite number"
        elif bounds:
            expected = "a value " + " and ".join(f"{_SYM[k]} {v}" for k, v in bounds.items())
        elif kind == "extra_forbidden":
            expected = "a known field (this one is not part of the spec; check its spelling)"
        elif kind in _EXPECTED:
            expected = _EXPECTED[kind]
            fix = _fix(kind, value)
        elif kind == "literal_error":
            expected = f"one of {ctx.get('expected', '')}"
    field = path_text(parts)
    return SpecError(pre + field if field else (prefix or "spec"), value, expected, fix)


def _value_at(data: Any, parts: list[str | int]) -> Any:
    node = data
    for p in parts:
        try:
            node = node[p]
        except (KeyError, IndexError, TypeError):
            return None
    return node
