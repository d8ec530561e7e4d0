"""Every navstress error crosses process boundaries intact (worker processes, Ray tasks):
a bad-input error raised in a worker must reach the CLI as the same one-line error."""

from __future__ import annotations

import inspect
import pickle

from hypothesis import given
from hypothesis import strategies as st

import navstress.errors as errors
from navstress.campaign import store
from navstress.errors import NavstressError, SpecError


def _error_classes() -> list[type[NavstressError]]:
    found: set[type[NavstressError]] = set()
    for mod in (errors, store):
        for _, obj in inspect.getmembers(mod, inspect.isclass):
            if issubclass(obj, NavstressError):
                found.add(obj)
    return sorted(found, key=lambda c: c.__name__)


def test_every_error_class_pickles_with_its_message() -> None:
    classes = _error_classes()
    assert SpecError in classes and len(classes) >= 7
    for cls in classes:
        err = SpecError("a.b", 3, "x", "fix") if cls is SpecError else cls("one line")
        back = pickle.loads(pickle.dumps(err))
        assert type(back) is cls and str(back) == str(err)


@given(field=st.text(max_size=20), value=st.one_of(st.integers(), st.floats(allow_nan=False), st.text(max_size=20)),
       expected=st.text(max_size=20), fix=st.one_of(st.none(), st.text(max_size=20)))
def test_spec_error_keeps_its_fields_through_pickle(field: str, value: object, expected: str, fix: str | None) -> None:
    err = SpecError(field, value, expected, fix)
    back = pickle.loads(pickle.dumps(err))
    assert (back.field, back.value, back.expected, back.fix, str(back)) == (field, value, expected, fix, str(err))


def test_a_missing_field_stays_missing_through_pickle() -> None:
    from navstress.campaign.store import DiskFullError
    from navstress.errors import MISSING

    err = SpecError("experiments[0].name", MISSING, "a string (this field is required)")
    back = pickle.loads(pickle.dumps(err))
    assert back.value is MISSING and str(back) == str(err) == \
        "experiments[0].name is missing: expected a string (this field is required)"
    full = DiskFullError("/x/out", "while creating the store").resumed_with("navstress search s.yaml -o /x/out")
    again = pickle.loads(pickle.dumps(full))
    assert str(again) == str(full) and again.command == full.command and "resume with: navstress search" in str(again)
