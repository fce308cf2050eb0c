"""Training a grasp-quality net and scoring it: the metrics against their definitions, a net
that learns a rule planted in the examples, and the same seed giving the same model."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from datagen.grasp_model.inputs import GRASP_FEATURES
from datagen.grasp_model.model_file import load_model
from datagen.learning.examples import GraspExamples, scene_of
from datagen.learning.fit import fit, onnx_bytes, split, write_model
from datagen.learning.metrics import (
    auc_by_class,
    calibration,
    roc_auc,
    roc_curve,
    within_scene_auc,
)
from datagen.seeding import sample_rng


def test_roc_auc_is_the_share_of_success_failure_pairs_in_order():
    rng = np.random.default_rng(0)
    scores = rng.integers(0, 5, 60).astype(float)  # many ties
    labels = rng.random(60) < 0.4
    pairs = [
        1.0 if s > f else 0.5 if s == f else 0.0
        for s, f in itertools.product(scores[labels], scores[~labels])
    ]
    assert roc_auc(scores, labels) == pytest.approx(np.mean(pairs))
    assert roc_auc(scores, np.ones(60, bool)) is None
    fpr, tpr = roc_curve(scores, labels)
    assert (fpr[0], tpr[0], fpr[-1], tpr[-1]) == (0, 0, 1, 1)


def test_calibration_of_honest_and_of_overconfident_predictions():
    rng = np.random.default_rng(1)
    p = rng.random(20000)
    honest = calibration(p, rng.random(20000) < p)
    assert honest["ece"] < 0.02
    overconfident = calibration(np.where(p > 0.5, 1.0, 0.0), rng.random(20000) < p)
    assert overconfident["ece"] > 0.2
    assert sum(b["count"] for b in honest["bins"]) == 20000


def test_the_auc_of_each_class_shows_what_the_auc_over_all_hides():
    # cans (8 examples) ranked right, the 2 lemons ranked the wrong way round
    scores = np.array([0.9, 0.8, 0.7, 0.6, 0.4, 0.3, 0.2, 0.1, 0.2, 0.9])
    held = np.array([True] * 4 + [False] * 4 + [True, False])
    classes = ["can"] * 8 + ["lemon"] * 2
    assert roc_auc(scores, held) == 0.72  # 18 of the 25 held-failed pairs in order
    assert auc_by_class(scores, held, classes) == {
        "can": {"n": 8, "successes": 4, "roc_auc": 1.0},
        "lemon": {"n": 2, "successes": 1, "roc_auc": 0.0},
    }
    assert auc_by_class(scores[:4], held[:4], classes[:4])["can"]["roc_auc"] is None


def planted(count: int, seed: int = 0) -> GraspExamples:
    """Examples whose success is whether the crop's left half is higher than the grasp and the
    approach points away from the camera's x: a rule of both inputs."""
    rng = np.random.default_rng(seed)
    crops = rng.normal(0.0, 0.01, (count, 1, 16, 16)).astype(np.float32)
    lifted = rng.random(count) < 0.5
    crops[lifted, 0, :, :8] -= 0.05
    features = rng.normal(0.0, 1.0, (count, GRASP_FEATURES)).astype(np.float32)
    success = lifted & (features[:, 2] > -0.5)
    return GraspExamples(
        crops, features, success, [f"a/{i}" for i in range(count)], ["box"] * count
    )


def test_a_net_learns_a_planted_rule_and_scores_attempts_it_never_saw():
    fitted = fit(planted(400), epochs=20, seed=0)
    assert fitted.scores["examples"] == 80  # the held-out fifth
    assert fitted.scores["classes"]["box"]["n"] == 80  # every planted example is a box
    assert fitted.scores["roc_auc"] > 0.85 and fitted.scores["accuracy"] > 0.75
    assert len(fitted.losses) == 20 and fitted.losses[-1] < fitted.losses[0]


def test_the_same_seed_gives_the_same_model_and_the_file_scores_as_the_net(tmp_path):
    examples = planted(200)
    one, two = fit(examples, epochs=3, seed=4), fit(examples, epochs=3, seed=4)
    assert onnx_bytes(one.net) == onnx_bytes(two.net)
    write_model(one.net, tmp_path / "m.onnx")
    model = load_model(tmp_path / "m.onnx")
    held = one.held_out
    assert model.score(held.crops, held.features) == pytest.approx(one.probabilities, abs=1e-5)
    train, test = split([str(i) for i in range(200)], 0.2, 4)
    assert len(test) == 40 and not set(train) & set(test)


def test_the_held_out_share_is_of_scenes_and_keeps_each_scene_whole():
    scenes = [f"c/7/{i // 4}/0" for i in range(200)]  # 50 scenes of 4 grasps each
    train, test = split(scenes, 0.2, 4)
    assert len(test) == 40  # 10 scenes
    assert {scenes[i] for i in train}.isdisjoint({scenes[i] for i in test})
    # one example a scene: the rows a split of the examples themselves draws
    order = sample_rng(4, 0, "grasp_model.split").permutation(200)
    assert split([str(i) for i in range(200)], 0.2, 4)[1].tolist() == sorted(order[:40])


def test_within_one_scene_only_pairs_of_the_same_scene_count():
    scores = np.array([0.9, 0.1, 0.2, 0.8, 0.5, 0.6, 0.3])
    success = np.array([True, False, True, False, True, True, False])
    scenes = ["a", "a", "b", "b", "c", "c", "d"]
    # a: the held grasp above the failed one; b: below it; c and d have one outcome only
    assert within_scene_auc(scores, success, scenes) == {"scenes": 2, "pairs": 2, "roc_auc": 0.5}
    assert roc_auc(scores, success) == pytest.approx(8 / 12)  # over all: other pairs too
    assert within_scene_auc(scores[4:], success[4:], scenes[4:])["roc_auc"] is None


def test_one_class_only_is_refused():
    examples = planted(50)
    examples.success[:] = True
    with pytest.raises(ValueError, match="both successes and failures"):
        fit(examples, epochs=1)


def test_an_attempts_scene_is_its_shared_scene_or_its_own_index_and_build():
    one = {"attempt": {"scene_seed": 7, "index": 5}}
    assert scene_of(one) == "7/5/0"
    shared = {"scene_index": 1, "candidate": 2, "grasps_per_scene": 3}
    assert scene_of({"attempt": {"scene_seed": 7, "index": 5, "shared_scene": shared}}) == "7/1/0"
    retried = one | {"production": {"attempt": 1, "failures": ["..."]}}
    assert scene_of(retried) == "7/5/1"  # a retried build drew its scene anew


def test_the_within_scene_line_is_printed_only_where_a_scene_has_a_pair():
    from datagen.cli.train_commands import within_scene_lines

    assert within_scene_lines({"scenes": 0, "pairs": 0, "roc_auc": None}) == []
    assert within_scene_lines({"scenes": 3, "pairs": 5, "roc_auc": 0.6}, "held-out ") == [
        "datagen: within one scene (3 held-out scenes with held and failed grasps, 5 pairs): "
        "ROC AUC 0.600"
    ]
