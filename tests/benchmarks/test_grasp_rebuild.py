"""benchmarks/grasp_rebuild.py: a kept campaign made again by the checkout's code."""

from __future__ import annotations

import pytest


@pytest.fixture
def grasp_rebuild(benchmark_module):
    return benchmark_module("grasp_rebuild")


def test_differences_name_each_attempt_and_key_that_changed(grasp_rebuild):
    kept = [{"grasp": {"width": 0.05}, "outcome": "held"}, {"grasp": None, "outcome": "missed"}]
    made = [{"grasp": {"width": 0.05}, "outcome": "held"}, {"grasp": None, "outcome": "slipped"}]
    assert grasp_rebuild.differences(kept, kept) == []
    assert grasp_rebuild.differences(kept, made) == [(1, ["outcome"])]
    assert grasp_rebuild.differences(kept, [kept[0], {"grasp": None}]) == [(1, ["outcome"])]


@pytest.mark.sim
def test_a_campaign_made_again_by_the_same_code_is_the_same_attempt_for_attempt(
    grasp_rebuild, campaign_dataset
):
    """Reproducible from (seed, index): another build, one worker where the first had its own
    scheduling, gives every attempt record again."""
    count, differ = grasp_rebuild.rebuild(campaign_dataset, None, 1)
    assert count == 3 and differ == []
