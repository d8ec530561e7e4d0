"""The live view sends every event of a run exactly once, although the run sorts its events by
time at the end after adding the ones it found afterwards (collisions)."""

from __future__ import annotations

from collections import Counter

from hypothesis import given
from hypothesis import strategies as st

from navstress.run.live import unsent

event = st.tuples(st.sampled_from([0.0, 0.5, 1.0, 2.0, 3.5]), st.sampled_from(["info", "warning", "error"]),
                  st.sampled_from(["a", "b", "hit"]))


@given(st.lists(event, max_size=12), st.integers(0, 12), st.lists(event, max_size=5))
def test_every_event_is_sent_once_whatever_the_final_sort_does(during: list[tuple[float, str, str]], k: int,
                                                               after: list[tuple[float, str, str]]) -> None:
    sent: Counter[tuple[float, str, str]] = Counter()
    for e in unsent(during[:k], sent):  # sent while the run goes: the list only grows
        sent[e] += 1
    final = sorted(during + after, key=lambda e: e[0]) + [(9.0, "info", "end of run")]
    rest = unsent(final, sent)
    assert sent + Counter(rest) == Counter(final)
    it = iter(final)
    assert all(e in it for e in rest)  # in the run's (sorted) order
