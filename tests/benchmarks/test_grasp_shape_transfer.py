"""benchmarks/grasp_shape_transfer.py on a real campaign: held-out families and another object
set scored at each training size, and a folder that is no campaign refused in one line."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import build_dataset  # tests/conftest.py: the datagen command, one worker

REPO = Path(__file__).resolve().parents[2]
SCRIPT = REPO / "benchmarks" / "grasp_shape_transfer.py"
CAMPAIGN = {  # 16 attempts, 4 grasps in each of 4 scenes, small wrist camera
    "version": 2, "scene": "grasp_attempts", "num_samples": 16, "seed": 3,
    "render": {"width": 96, "height": 72, "wrist_camera": True},
    "campaign": {"hold_time": 0.3, "post_grasp_frame": False, "record_hz": 0, "grasps_per_scene": 4},
}  # fmt: skip


def benchmark(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, str(SCRIPT), *args],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
    )


@pytest.mark.sim
def test_quick_mode_scores_held_out_families_and_other_objects_at_each_size(tmp_path):
    campaign = build_dataset(tmp_path, "campaign", CAMPAIGN, ["campaign", "grasp"])
    out = tmp_path / "transfer"
    done = benchmark(
        "--quick", "--campaign", str(campaign), "--other", str(campaign), "--out", str(out)
    )
    assert done.returncode == 0, done.stderr[-3000:]
    sizes = re.findall(r"^ *(\d+) attempts \(\d+ examples\): held-out families", done.stdout, re.M)
    assert sizes == ["8", "16"]
    assert "held-out family ROC AUC by training attempts" in done.stdout
    result = json.loads((out / "results.json").read_text())
    assert [row["attempts"] for row in result["sizes"]] == [8, 16]
    for row in result["sizes"]:
        assert len(row["splits"]) == 2  # --quick: two splits of one family held out
        assert all(len(split["held"]) == 1 for split in row["splits"])
        assert all(split["held"][0] in result["families"] for split in row["splits"])
    assert (out / "shape_transfer.png").stat().st_size > 0


def test_a_folder_that_is_no_campaign_is_refused_in_one_line(tmp_path):
    done = benchmark("--quick", "--campaign", str(tmp_path))
    assert done.returncode == 2
    assert done.stderr.count("\n") == 1 and str(tmp_path) in done.stderr
