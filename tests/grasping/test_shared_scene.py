"""Several grasps a scene (``campaign.grasps_per_scene``), in real scenes (SAPIEN, in process):
attempts k*s .. k*s+k-1 share scene s (its settled objects, pictures and target), each executes
its own of the antipodal sampler's first k candidates there and keeps its own record, the first
being a one-grasp campaign's attempt s; and an attempt is reproduced from (seed, index)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from datagen.config import config_from_dict
from datagen.families.grasp_attempts.produce import produce
from datagen.sample import sample_key

pytestmark = [pytest.mark.sim]

SEED, K, SCENE = 7, 3, 1  # scene 1 of seed 7: a capsule with two candidates in 200 tries
BASE = {
    "scene": "grasp_attempts",
    "seed": SEED,
    "num_samples": 2 * K,
    "render": {"width": 160, "height": 120, "wrist_camera": True},
    "campaign": {"hold_time": 0.3, "post_grasp_frame": False, "record_hz": 0},
}


def metadata(sample) -> dict:
    return json.loads(sample.parts["json"])


@pytest.fixture(scope="module")
def shared():
    config = config_from_dict(BASE | {"campaign": BASE["campaign"] | {"grasps_per_scene": K}})
    return config, [produce(config, SEED, K * SCENE + j) for j in range(K)]


def test_the_attempts_of_a_scene_share_its_pictures_and_target_with_a_key_each(shared):
    _, samples = shared
    metas = [metadata(s) for s in samples]
    for part in ("rgb.png", "depth.png", "wrist.depth.png"):
        assert len({s.parts[part] for s in samples}) == 1, part
    assert [m["key"] for m in metas] == [sample_key(K * SCENE + j) for j in range(K)]
    assert [m["attempt"]["attempt_id"] for m in metas] == [m["key"] for m in metas]
    assert [m["attempt"]["shared_scene"] for m in metas] == [
        {"scene_index": SCENE, "candidate": j, "grasps_per_scene": K} for j in range(K)
    ]
    assert len({json.dumps(m["attempt"]["target"]) for m in metas}) == 1


def test_each_attempt_executes_its_own_candidate_and_the_first_is_a_one_grasp_attempts(shared):
    config, samples = shared
    attempts = [metadata(s)["attempt"] for s in samples]
    grasps = [a["grasp"] for a in attempts if a["grasp"] is not None]
    assert len(grasps) >= 2  # the scene has candidates to rank
    poses = [np.asarray(g["pose_world"]) for g in grasps]
    assert all(not np.allclose(a, b) for i, a in enumerate(poses) for b in poses[i + 1 :])
    for a in attempts[len(grasps) :]:  # fewer candidates than attempts: the rest find none
        assert a["outcome"]["failure_mode"] == "no_candidate"
        assert "candidates for the scene's 3 attempts" in a["outcome"]["details"]["reason"]
    one = metadata(produce(config_from_dict(BASE), SEED, SCENE))["attempt"]
    assert one["target"] == attempts[0]["target"]
    assert one["grasp"]["pose_world"] == attempts[0]["grasp"]["pose_world"]
    assert one["outcome"] == attempts[0]["outcome"]
    again = produce(config, SEED, K * SCENE + 1)
    assert again.parts == samples[1].parts
