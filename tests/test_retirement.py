"""When worlds leave a batch's lockstep motion (harness.engines.mjwarp.retirement): every world is
stepped through its whole span, worlds leave shortest first, a segment ends when the set share
of its worlds has ended, and nothing retires below the floor of worlds."""

from __future__ import annotations

import itertools

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from harness.engines.mjwarp.retirement import segments


def test_a_quarter_of_the_worlds_leave_at_each_segment_end() -> None:
    spans = np.array([10, 4, 7, 12, 4, 9, 30, 11])
    plan = segments(spans, retire=0.25, min_worlds=1)
    # 8 worlds: the 2nd shortest span (4) ends segment 1, both 4s leave; 6 left: the
    # ceil(1.5) = 2nd shortest of them (9) ends segment 2, 7 and 9 leave; 4 left: ceil(1) = the
    # shortest (10) ends segment 3, then 11, then 12; the last runs to the end alone
    assert [s.end for s in plan] == [4, 9, 10, 11, 12, 30]
    assert [sorted(s.worlds.tolist()) for s in plan] == [
        list(range(8)),
        [0, 2, 3, 5, 6, 7],
        [0, 3, 6, 7],
        [3, 6, 7],
        [3, 6],
        [6],
    ]
    assert plan[0].worlds.tolist() == [1, 4, 2, 5, 0, 7, 3, 6]  # by span, stable


def test_retire_zero_or_the_floor_keeps_the_lockstep_batch() -> None:
    spans = np.array([10, 4, 7])
    for plan in (segments(spans, retire=0.0, min_worlds=1), segments(spans, 0.25, 3)):
        assert len(plan) == 1 and plan[0].end == 10
        assert sorted(plan[0].worlds.tolist()) == [0, 1, 2]


@settings(max_examples=200, deadline=None)
@given(
    spans=st.lists(st.integers(1, 60), min_size=1, max_size=40),
    retire=st.floats(0.01, 1.0),
    min_worlds=st.integers(1, 8),
)
def test_every_world_steps_its_whole_span_and_leaves_once(
    spans: list[int], retire: float, min_worlds: int
) -> None:
    array = np.array(spans)
    plan = segments(array, retire, min_worlds)
    ends = [s.end for s in plan]
    assert ends == sorted(set(ends)) and ends[-1] == max(spans)
    for w, span in enumerate(spans):
        inside = [i for i, s in enumerate(plan) if w in s.worlds.tolist()]
        assert inside == list(range(len(inside)))  # from the first segment, without a gap
        assert plan[inside[-1]].end >= span  # stepped at least to its span's end
        if inside[-1] > 0:
            assert plan[inside[-1] - 1].end < span  # and left at the first end past it
    for before, after in itertools.pairwise(plan):
        assert len(before.worlds) > min_worlds and len(after.worlds) < len(before.worlds)
