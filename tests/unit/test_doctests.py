"""Every example in navstress's docstrings runs and prints what it says (a stale example is a
wrong document). ``navstress._facade`` (a whole mission) runs in test_facade."""

from __future__ import annotations

import doctest
import importlib
import pkgutil

import pytest

import navstress

#: Run elsewhere (test_facade: the run_mission example runs a mission of 60 s).
ELSEWHERE = {"navstress._facade"}
MODULES = sorted(m.name for m in pkgutil.walk_packages(navstress.__path__, "navstress.")
                 if m.name not in ELSEWHERE and not m.name.startswith("navstress.cli.__main__"))


@pytest.mark.parametrize("name", MODULES)
def test_module_doctests(name: str) -> None:
    module = importlib.import_module(name)
    result = doctest.testmod(module, verbose=False, report=True, optionflags=doctest.ELLIPSIS)
    assert result.failed == 0, f"{result.failed} of {result.attempted} doctest examples of {name} failed"
