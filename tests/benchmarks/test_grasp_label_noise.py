"""benchmarks/grasp_label_noise.py: a campaign's executed grasp made again, unchanged and
perturbed, in rebuilds of its settled scene."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from printed_commands import run_printed  # tests/printed_commands.py

REPO = Path(__file__).resolve().parents[2]
DOC = REPO / "docs" / "campaigns.md"


@pytest.fixture
def grasp_label_noise(benchmark_module):
    return benchmark_module("grasp_label_noise")


def test_each_perturbation_moves_or_turns_the_hand_in_its_own_frame(grasp_label_noise):
    moves = grasp_label_noise.perturbations(0.002, 3.0)
    axes = ("side", "closing", "approach", "turn")
    assert set(moves) == {"none"} | {f"{axis}{sign}" for axis in axes for sign in "+-"}
    assert np.array_equal(moves["none"], np.eye(4))
    pose = np.eye(4)
    pose[:3, :3] = [[0, 1, 0], [0, 0, -1], [-1, 0, 0]]  # closing along -z, approach along -x
    moved = pose @ moves["closing+"]
    assert np.allclose(moved[:3, 3], 0.002 * pose[:3, 1]) and np.allclose(
        moved[:3, :3], pose[:3, :3]
    )
    assert np.allclose((pose @ moves["approach-"])[:3, 3], -0.002 * pose[:3, 2])
    turned = pose @ moves["turn+"]
    assert np.allclose(turned[:3, 3], 0) and np.allclose(turned[:3, 2], pose[:3, 2])
    angle = np.degrees(np.arccos(np.clip(turned[:3, 1] @ pose[:3, 1], -1, 1)))
    assert angle == pytest.approx(3.0)


@pytest.mark.sim
@pytest.mark.slow
def test_an_unchanged_grasp_in_a_rebuilt_scene_gets_the_attempts_label():
    done = run_printed(DOC, "grasp_label_noise.py --quick", timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    out = done.stdout
    reached = int(re.search(r"2 scene indices, (\d) with a reached grasp", out).group(1))
    assert reached >= 1, out
    assert f"rebuilt scenes matching the first build: {reached} of {reached}" in out, out
    assert f"none     : label equal to the attempt's {reached} of {reached} executed" in out, out
    assert len(re.findall(r"label equal to the attempt's \d+ of \d+ executed", out)) == 9, out
    assert "ROC AUC of the perturbed copies' share" in out, out
