"""benchmarks/grasp_reach.py on a small real campaign: it rebuilds each chosen attempt's scene
from the campaign's own config, plans every candidate as execution would, and sums up."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]

pytestmark = [pytest.mark.sim, pytest.mark.slow]


def test_every_candidate_of_the_chosen_attempts_is_planned(campaign_dataset):
    modes = ["success", "missed", "slipped", "collision", "unreachable", "no_candidate"]
    script = "benchmarks/grasp_reach.py"
    command = [sys.executable, script, str(campaign_dataset), "--tries", "10", "--modes", *modes]
    done = subprocess.run(
        command, cwd=REPO, capture_output=True, text=True, timeout=600, check=False
    )
    assert done.returncode == 0, done.stderr[-3000:]
    attempts = re.findall(
        r"attempt (\d+): \w+ \(([\d.]+) x ([\d.]+) x ([\d.]+) m\) [\d.]+ m from the base, "
        r"(\d+) candidates .* (\d+) reached",
        done.stdout,
    )
    assert [int(index) for index, *_ in attempts] == [0, 1, 2], done.stdout
    for _, *extents, found, reached in attempts:
        assert 0 < float(extents[0]) <= float(extents[1]) <= float(extents[2]) < 0.5
        assert int(reached) <= int(found), done.stdout
    attempts = [(index, found, reached) for index, *_, found, reached in attempts]
    summary = re.search(
        r": (\d+) of 3 attempts \(.*\) have no candidate the arm reaches", done.stdout
    )
    assert summary, done.stdout
    assert int(summary[1]) == sum(int(reached) == 0 for _, _, reached in attempts)
