"""Ros2Config: families of topic names, domain ids and routers (issue 38, faults)."""
from __future__ import annotations

import re

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from navstress.errors import SpecError
from navstress.nav.ros2.config import DOMAIN_ID_MAX, check_topic_name, parse_config

_OK = re.compile(r"^(/[A-Za-z_][A-Za-z0-9_]*)+$")


@settings(max_examples=300, deadline=None)
@given(st.text(max_size=40))
def test_check_topic_name_any_text_is_a_reason_or_none_never_a_crash(name: str) -> None:
    why = check_topic_name(name)
    assert (why is None) == (bool(_OK.match(name)) and len(name) <= 255)
    if why is not None:
        assert isinstance(why, str) and "\n" not in why


@settings(max_examples=100, deadline=None)
@given(st.text(alphabet=st.characters(min_codepoint=128), min_size=1, max_size=5))
def test_non_ascii_tokens_are_refused_with_a_reason(tok: str) -> None:
    why = check_topic_name("/a" + tok)
    assert why is not None and "\n" not in why


@pytest.mark.parametrize("name", ["scan", "/2d/scan", "/a//b", "/a/", "/sc an", "/é", "/~/x",
                                  "/{ns}/x", "/" + "a" * 255, ""])
def test_forbidden_topic_names_are_one_line_spec_errors(name: str) -> None:
    with pytest.raises(SpecError) as e:
        parse_config({"topics": {"cmd_vel": name}})
    assert "\n" not in str(e.value) and "cmd_vel" in str(e.value)


@settings(max_examples=100, deadline=None)
@given(st.integers())
def test_domain_id_range(i: int) -> None:
    if 0 <= i <= DOMAIN_ID_MAX:
        assert parse_config({"domain_id": i}).domain_pool == (i,)
    else:
        with pytest.raises(SpecError) as e:
            parse_config({"domain_id": i})
        assert "domain_id" in str(e.value) and "\n" not in str(e.value)


@settings(max_examples=100, deadline=None)
@given(st.lists(st.integers(-5, DOMAIN_ID_MAX + 5), max_size=6))
def test_domain_pool_family(ids: list[int]) -> None:
    ok = bool(ids) and len(set(ids)) == len(ids) and all(0 <= i <= DOMAIN_ID_MAX for i in ids)
    if ok:
        assert parse_config({"domain_id": ids}).domain_pool == tuple(ids)
    else:
        with pytest.raises(SpecError):
            parse_config({"domain_id": ids})


@pytest.mark.parametrize("router", ["tcp/127.0.0.1:0", "tcp/127.0.0.1:65536", "127.0.0.1:7447",
                                    "tcp/:7447", "http/127.0.0.1:7447", "tcp/127.0.0.1"])
def test_bad_router_endpoints_are_one_line(router: str) -> None:
    with pytest.raises(SpecError) as e:
        parse_config({"router": router})
    assert "router" in str(e.value) and "\n" not in str(e.value)


@settings(max_examples=200, deadline=None)
@given(st.one_of(st.sampled_from(["auto", "none", "Auto", "", "yes"]),
                 st.lists(st.one_of(st.text(max_size=12), st.sampled_from(["/bt_navigator", "/ns/amcl"])),
                          max_size=3)))
def test_wait_active_family(v: str | list[str]) -> None:
    """'auto', 'none' or a non-empty list of fully qualified node names; anything else is one
    line naming the key."""
    ok = v in ("auto", "none") or (isinstance(v, list) and bool(v) and all(check_topic_name(n) is None for n in v))
    if ok:
        assert parse_config({"wait_active": v}).wait_active == v
    else:
        with pytest.raises(SpecError) as e:
            parse_config({"wait_active": v})
        assert "wait_active" in str(e.value) and "\n" not in str(e.value)
