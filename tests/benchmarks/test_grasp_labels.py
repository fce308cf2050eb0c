"""benchmarks/grasp_labels.py run as docs/campaigns.md prints it: a scene rebuilt from its
(seed, index) is the settled scene again, its first candidate is the campaign's own attempt, and
the labels per CPU-second of both ways are printed with their ratio."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from printed_commands import run_printed  # tests/printed_commands.py

REPO = Path(__file__).resolve().parents[2]
DOC = REPO / "docs" / "campaigns.md"

pytestmark = [pytest.mark.sim, pytest.mark.slow]


def test_several_candidates_of_one_scene_against_fresh_scenes():
    done = run_printed(DOC, "grasp_labels.py --quick", timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    out = done.stdout
    assert "rebuilt scenes matching the first build: 2 of 2" in out, out
    assert "first candidate's label equal to the fresh attempt's: 2 of 2" in out, out
    rates = re.findall(r"(fresh|rebuilt)\s*: (\d+) labels in [\d.]+ CPU-s: ([\d.]+) labels", out)
    assert [way for way, _, _ in rates] == ["fresh", "rebuilt"], out
    assert all(float(rate) > 0 for _, _, rate in rates), out
    assert re.search(r"rebuilt ÷ fresh: \d+\.\d\d", out), out
