"""The learned sampler in real scenes (SAPIEN, in process): it executes the candidate its model
prefers, stores every candidate's score and the one chosen, and an attempt is reproduced from
(seed, index, the model's sha256)."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest
from grasp_model_files import prefers_feature  # tests/grasp_model_files.py

from datagen.config import config_from_dict
from datagen.families.grasp_attempts.produce import produce

pytestmark = [pytest.mark.sim]

SEED, ATTEMPTS, CANDIDATES = 7, 3, 6
BASE = {
    "scene": "grasp_attempts",
    "seed": SEED,
    "num_samples": ATTEMPTS,
    "render": {"width": 160, "height": 120, "wrist_camera": True},
    "campaign": {"hold_time": 0.3, "post_grasp_frame": False, "record_hz": 0},
}


def attempt(sample) -> dict:
    return json.loads(sample.parts["json"])


def approach_seen_from_the_wrist(meta: dict) -> float:
    """The chosen grasp's approach along the wrist camera's x axis (image right)."""
    extrinsics = np.asarray(meta["views"]["wrist"]["camera"]["extrinsics_world_to_camera"])
    return float((extrinsics[:3, :3] @ np.asarray(meta["attempt"]["grasp"]["approach"]))[0])


@pytest.fixture(scope="module")
def configs(tmp_path_factory):
    # the model prefers grasps that approach towards the wrist camera's right (feature 2)
    model = prefers_feature(tmp_path_factory.mktemp("model") / "right.onnx", column=2)
    learned = BASE | {
        "campaign": BASE["campaign"]
        | {"sampler": "learned", "model": str(model), "candidates": CANDIDATES}
    }
    return config_from_dict(BASE), config_from_dict(learned)


def test_the_model_moves_the_chosen_grasps_where_it_prefers(configs):
    antipodal, learned = configs
    moved = 0
    for index in range(ATTEMPTS):
        a, b = attempt(produce(antipodal, SEED, index)), attempt(produce(learned, SEED, index))
        assert a["attempt"]["target"] == b["attempt"]["target"]  # the same scene and target
        assert b["attempt"]["model"]["sha256"] == learned.campaign.model_sha256
        if a["attempt"]["grasp"] is None:
            assert b["attempt"]["grasp"] is None  # the first candidate is the antipodal one
            continue
        info = b["attempt"]["grasp"]["info"]
        scores = info["scores"]
        assert info["candidates"] == len(scores) <= CANDIDATES
        assert info["chosen"] == int(np.argmax(scores))
        assert set(info) == {
            "candidates",
            "scores",
            "chosen",
            "tries",
            "friction",
            "clearance",
            "depth",
        }
        assert b["attempt"]["grasp"]["sampler"] == "learned"
        x_antipodal, x_learned = approach_seen_from_the_wrist(a), approach_seen_from_the_wrist(b)
        assert scores[0] == pytest.approx(x_antipodal, abs=1e-4)  # the antipodal sampler's own
        assert scores[info["chosen"]] == pytest.approx(x_learned, abs=1e-4)
        assert x_learned >= x_antipodal - 1e-6
        moved += x_learned > x_antipodal + 0.05
    assert moved >= 1


def test_an_attempt_is_reproduced_from_seed_index_and_model(configs):
    _, learned = configs
    first, again = produce(learned, SEED, 1), produce(learned, SEED, 1)
    assert first.parts.keys() == again.parts.keys()
    for name in first.parts:
        assert first.parts[name] == again.parts[name], name


def test_with_reach_checked_the_best_scored_candidate_the_arm_reaches_is_executed(configs):
    _, learned = configs
    checked = dataclasses.replace(
        learned, campaign=dataclasses.replace(learned.campaign, check_reach=True)
    )
    for index in range(ATTEMPTS):
        b = attempt(produce(checked, SEED, index))["attempt"]
        if b["grasp"] is None:
            continue
        info = b["grasp"]["info"]
        if info["reach_rounds"] > 1:
            continue  # each round ranked on its own: test_grasp_samplers.py
        ranked = sorted(range(len(info["scores"])), key=lambda i: -info["scores"][i])
        assert 1 <= info["reach_checked"] <= info["candidates"]
        expected = ranked[info["reach_checked"] - 1] if info["reached"] else ranked[0]
        assert info["chosen"] == expected
