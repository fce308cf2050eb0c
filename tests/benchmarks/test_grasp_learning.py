"""benchmarks/grasp_learning.py: what its table says bounds the learned sampler (it chooses
among the antipodal sampler's candidates), from recorded outcomes."""

from __future__ import annotations

import pytest


@pytest.fixture
def grasp_learning(benchmark_module):
    return benchmark_module("grasp_learning")


def test_the_learned_sampler_is_bounded_by_the_attempts_with_a_candidate(grasp_learning):
    # 10 attempts: the antipodal sampler found a candidate in the first 6 and held 3 of them
    antipodal = {
        "success": [True, True, True, False, False, False, False, False, False, False],
        "found": [True] * 6 + [False] * 4,
    }
    learned = {"success": [True] * 5 + [False] * 5, "found": [True] * 6 + [False] * 4}
    lines = grasp_learning.coverage_lines(
        "panda", "objects", {"antipodal": antipodal, "l": learned}
    )
    # at most 6 of 10 held: 60 % against antipodal's 30 %
    assert lines[0] == (
        "panda objects: a candidate in 6 of 10 attempts, so learned - antipodal is at most "
        "+30.0; on those 6:"
    )
    assert lines[1].split() == ["antipodal", "50.0", "±", "20.4"]
    assert lines[2].split() == ["l", "83.3", "±", "15.2"]


def test_runs_kept_before_coverage_was_recorded_print_no_bound(grasp_learning):
    runs = {"antipodal": {"success": [True, False]}, "l": {"success": [True, True]}}
    assert grasp_learning.coverage_lines("panda", "scenes", runs) == []


def test_the_reach_line_counts_unreachable_attempts_and_how_far_their_targets_were(grasp_learning):
    run = {
        "success": [True, True, False, False, False],
        "modes": [None, None, "unreachable", "unreachable", "slipped"],
        "reach_m": [0.6, 0.7, 0.8, 0.9, 0.5],
        "ik_failed": [False, False, True, False, False],
    }
    lines = grasp_learning.reach_lines("panda", "objects", {"antipodal": run})
    assert lines == [
        "panda objects antipodal: unreachable 2 (IK failed 1), targets a median 0.85 m from "
        "the base; successes 0.65 m"
    ]
    assert grasp_learning.reach_lines("panda", "scenes", {"antipodal": {"success": []}}) == []
