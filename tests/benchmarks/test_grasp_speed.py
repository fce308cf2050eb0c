"""benchmarks/grasp_speed.py: each sampler's ratio to the antipodal sampler is taken within a
repeat, so a machine that slows between repeats slows both sides of it alike."""

from __future__ import annotations

import math

import pytest


@pytest.fixture
def grasp_speed(benchmark_module):
    return benchmark_module("grasp_speed")


def test_ratios_are_taken_within_each_repeat(grasp_speed):
    # the machine runs at half speed in the second repeat: the ratio stays 0.8
    rates = {"antipodal": [1.0, 0.5], "learned": [0.8, 0.4]}
    lines = grasp_speed.summary(rates)
    assert lines[0].split()[:6] == ["antipodal", "0.750", "±", "0.250", "attempts/s", "÷"]
    assert lines[1].split()[1:4] == ["0.600", "±", "0.200"]
    assert lines[1].split()[6:10] == ["antipodal", "0.80", "±", "0.00"]
    assert "(repeats: 0.800, 0.400)" in lines[1]


def test_one_repeat_has_no_standard_error(grasp_speed):
    mean, se = grasp_speed.mean_se([0.7])
    assert mean == 0.7 and math.isnan(se)
