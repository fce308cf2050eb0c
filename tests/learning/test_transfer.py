"""A model's ROC AUC on another campaign's grasps, over all of them, over those reached and per
target class; and ``datagen evaluate grasp``, which prints them."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import PIL.Image
import pytest
from grasp_model_files import prefers_feature

from datagen.learning.examples import campaign_examples
from datagen.learning.metrics import roc_auc
from datagen.learning.transfer import auc_by_reach, campaign_auc

REPO = Path(__file__).resolve().parents[2]


def datagen(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "datagen.cli", *args],
        capture_output=True, text=True, cwd=REPO, timeout=300, check=False,
    )  # fmt: skip


def test_unreachable_attempts_are_left_out_of_the_reached_score():
    # the model ranks reach perfectly (unreachable attempts score lowest) and holds at random
    scores = np.array([0.1, 0.2, 0.9, 0.8, 0.7, 0.6])
    success = np.array([False, False, True, False, True, False])
    modes = ["unreachable", "unreachable", None, "slipped", None, "missed"]
    auc = auc_by_reach(scores, success, modes)
    assert auc["all"] == {"n": 6, "successes": 2, "roc_auc": roc_auc(scores, success)}
    assert auc["all"]["roc_auc"] == 0.875  # 7 of the 8 success-failure pairs in order
    assert auc["reached"] == {"n": 4, "successes": 2, "roc_auc": 0.75}
    none_held = auc_by_reach(scores[:2], success[:2], modes[:2])
    assert none_held["all"]["roc_auc"] is None and none_held["reached"]["n"] == 0


@pytest.mark.sim
def test_a_model_file_is_scored_on_a_campaign_it_never_saw(campaign_dataset, tmp_path):
    model = prefers_feature(tmp_path / "width.onnx", column=1)  # the wider grasp first
    examples = campaign_examples([campaign_dataset], "wrist")
    auc = campaign_auc(model, campaign_dataset)
    assert auc == auc_by_reach(examples.features[:, 1], examples.success, examples.modes)
    assert auc["all"]["n"] == len(examples) > 0
    assert len(examples.modes) == len(examples)
    assert all(
        (mode is None) == held for mode, held in zip(examples.modes, examples.success, strict=True)
    )


@pytest.mark.sim
def test_datagen_evaluate_grasp_prints_and_writes_every_score(campaign_dataset, tmp_path):
    model = prefers_feature(tmp_path / "width.onnx", column=1)  # scores in [0, 0.1]: probabilities
    out = tmp_path / "figures" / "width.json"
    done = datagen(
        "evaluate", "grasp", "--model", str(model), str(campaign_dataset), "--out", str(out)
    )
    assert done.returncode == 0, done.stderr
    examples = campaign_examples([campaign_dataset], "wrist")
    report = json.loads(out.read_text())
    expected = auc_by_reach(examples.features[:, 1], examples.success, examples.modes)
    assert {k: report[k] for k in ("all", "reached")} == json.loads(json.dumps(expected))
    assert sum(c["n"] for c in report["classes"].values()) == len(examples)
    assert sorted(report["classes"]) == sorted(set(examples.families))
    assert "calibration" in report and "the scores are probabilities" in done.stdout
    assert f"{len(examples)} executed grasps" in done.stdout
    for name in report["classes"]:
        assert f"datagen:   {name}: " in done.stdout
    with PIL.Image.open(out.with_suffix(".png")) as picture:
        assert picture.size[0] > picture.size[1]
    raw = prefers_feature(
        tmp_path / "far.onnx", column=0, sign=-10.0
    )  # negative: not probabilities
    done = datagen("evaluate", "grasp", "--model", str(raw), str(campaign_dataset))
    assert done.returncode == 0 and "calibration" not in done.stdout, done.stderr


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["--model", "{garbage}", "{empty}"], "--model: "),
        (["--model", "{model}", "{empty}"], "{empty}"),
        (["--model", "{model}", "{empty}", "--out", "figures.txt"], "--out figures.txt: expected"),
    ],
)
def test_datagen_evaluate_grasp_refuses_bad_input_in_one_line(tmp_path, args, needle):
    paths = {
        "garbage": tmp_path / "garbage.onnx",
        "model": prefers_feature(tmp_path / "width.onnx", column=1),
        "empty": tmp_path / "not-a-campaign",
    }
    paths["garbage"].write_bytes(b"not a model")
    paths["empty"].mkdir()
    done = datagen("evaluate", "grasp", *(a.format(**paths) for a in args))
    assert done.returncode != 0 and "Traceback" not in done.stderr
    (line,) = done.stderr.strip().splitlines()
    assert line.startswith("datagen") and needle.format(**paths) in line, line
