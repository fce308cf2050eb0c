"""benchmarks/object_transfer.py: how it decides that a target instance was found, and its
quick mode end to end (real builds, trainings and scores) on two of its training sets."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]
DOMAINS = ("photos", "meshes", "lighting", "textures")  # the quick mode builds no path-traced one
TABLES = (
    "IoU of object (%)",
    "object vs rest IoU (%)",
    "instance recall at IoU 0.5 (%)",
    "IoU of other (%)",
    "IoU of table (%)",
    "IoU of tray (%)",
)
SCORES = ("object", "object_vs_rest", "instance_recall", "other", "table", "tray")
MEAN_SE = r"\d+\.\d ± \d+\.\d"


@pytest.fixture
def object_scores(monkeypatch):
    monkeypatch.syspath_prepend(str(REPO / "benchmarks"))
    from dr_transfer import object_scores

    return object_scores


def test_an_instance_is_found_only_by_one_region_overlapping_it_at_iou_one_half(object_scores):
    targets = np.zeros((1, 12, 12), np.int32)
    targets[0, 0:3, 0:3] = 1  # predicted exactly: found
    targets[0, 0:4, 6:10] = 2  # a quarter of it predicted: IoU 0.25, not found
    targets[0, 8:11, 0:3], targets[0, 8:11, 3:6] = 3, 4  # touching, predicted as one region
    predicted = np.zeros((1, 12, 12), bool)
    predicted[0, 0:3, 0:3] = True
    predicted[0, 0:1, 6:10] = True
    predicted[0, 8:11, 0:6] = True  # IoU 0.5 with each of 3 and 4: found
    assert object_scores.found_instances(predicted, targets) == (3, 4)
    predicted[0, 8:11, 6] = True  # the merged region grows: IoU 9/21 with each
    assert object_scores.found_instances(predicted, targets) == (1, 4)


def test_object_versus_rest_is_the_mean_of_the_two_classes_iou(object_scores):
    import torch

    classes = torch.zeros(1, 4, 4, dtype=torch.long)
    classes[0, :2, :2] = object_scores.OBJECT  # 4 object pixels
    predicted = torch.zeros_like(classes)
    predicted[0, :2, :1] = object_scores.OBJECT  # 2 of them found, nothing else called object
    scores = object_scores.object_scores(
        predicted, classes, torch.zeros(1, 4, 4, dtype=torch.int32)
    )
    assert scores["object"] == 50.0
    assert scores["object_vs_rest"] == round((50.0 + 100 * 12 / 14) / 2, 2)


@pytest.mark.sim
@pytest.mark.slow
def test_quick_mode_prints_every_score_with_its_standard_error_and_writes_its_results(tmp_path):
    command = [sys.executable, "benchmarks/object_transfer.py", "--quick"]
    command += ["--only", "a_flat", "c_default", "--out", str(tmp_path)]
    command += ["--frames", "16", "--test-frames", "8"]  # the quick mode's 24 and 16, smaller
    run = subprocess.run(command, cwd=REPO, capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-3000:]
    lines = run.stdout.splitlines()
    for heading in ("command: ", "commit:  ", "machine: "):
        assert any(line.startswith(heading) for line in lines), heading
    for title in TABLES:
        start = next(i for i, line in enumerate(lines) if line.startswith(title))
        assert lines[start].split()[-5:] == [*DOMAINS, "raytraced"]
        rows = lines[start + 1 : start + 4]
        assert [row[:32].strip() for row in rows] == ["image-blind (prior)", "flat", "default"]
        for row in rows:
            assert re.fullmatch(rf".{{32}}(\s+{MEAN_SE}){{4}}\s+—", row), row
    results = json.loads((tmp_path / "results.json").read_text())
    assert results["seeds"] == [0, 1]
    assert results["precision"]["precision"] in ("fp32", "bf16")
    assert set(results["domains"]) == set(DOMAINS)
    assert all(results["domains"][d]["instances"] > 0 for d in DOMAINS)
    for name, row in [("blind", {"scores": results["blind"]}), *results["sets"].items()]:
        for domain in DOMAINS:
            runs = row["scores"][domain]
            assert len(runs) == 2, (name, domain)
            assert set(SCORES) <= set(runs[0]), (name, domain)
    assert results["sets"]["a_flat"]["train_s_per_epoch"] > 0
    assert results["sets"]["c_default"]["frames"] == 16


def test_a_run_of_hours_keeps_the_sets_an_earlier_run_of_its_recipe_trained(tmp_path, monkeypatch):
    monkeypatch.syspath_prepend(str(REPO / "benchmarks"))
    import object_transfer

    recipe = {"cpu": {"line": "x"}, "device": "cpu", "net": {"name": "unet"}, "size": [160, 120]}
    recipe |= {"epochs": 20, "seeds": [0, 1, 2], "precision": {"precision": "fp32"}}
    domains = {"photos": {"frames": 300}, "meshes": {"frames": 300}}
    trained = {"frames": 2000, "scores": {"photos": []}, "commit": "abc1234"}
    earlier = recipe | {"commit": "abc1234", "domains": domains}
    earlier["sets"] = {"a_flat": trained, "c_default": {"frames": 2000}}  # default: cut short
    (tmp_path / "results.json").write_text(json.dumps(earlier))
    now = recipe | {
        "commit": "def5678",
        "domains": domains,
        "sets": {"a_flat": {}, "c_default": {}},
    }
    # the precision probe measures other speeds each run: the precision chosen is what counts
    now["precision"] = {"precision": "fp32", "why": "bf16 1.10 vs fp32 1.30 steps/s"}
    assert object_transfer.earlier_sets(tmp_path, now, 2000) == {"a_flat": trained}
    assert object_transfer.earlier_sets(tmp_path, now, 500) == {}
    bf16 = now | {"precision": {"precision": "bf16", "why": "bf16 1.40 vs fp32 1.30 steps/s"}}
    assert object_transfer.earlier_sets(tmp_path, bf16, 2000) == {}
    for key, other in (("epochs", 40), ("seeds", [0]), ("size", [320, 240])):
        assert object_transfer.earlier_sets(tmp_path, now | {key: other}, 2000) == {}
    fewer = now | {"domains": {"photos": {"frames": 300}, "meshes": {"frames": 100}}}
    assert object_transfer.earlier_sets(tmp_path, fewer, 2000) == {}
    (tmp_path / "results.json").write_text("{cut sh")
    assert object_transfer.earlier_sets(tmp_path, now, 2000) == {}


def test_every_training_set_is_a_valid_config_differing_from_the_default_in_its_recipe(
    monkeypatch,
):
    monkeypatch.syspath_prepend(str(REPO / "benchmarks"))
    from dr_transfer.object_domains import OBJECT_SETS, SET_LABELS, wrist_training_sets

    from datagen.config import config_from_dict

    sets = wrist_training_sets(160, 120, 10)
    assert tuple(sets) == OBJECT_SETS and set(SET_LABELS) == set(OBJECT_SETS)
    configs = {name: config_from_dict(data, source=name) for name, data in sets.items()}
    default = configs["c_default"]
    assert all(c.render.wrist_camera and c.num_samples == 10 for c in configs.values())
    assert configs["c_no_clutter"].objects.count == (1, 3) != default.objects.count
    assert "mug" not in configs["c_no_household_shapes"].objects.families
    assert configs["c_no_look_variety"].robot.look.tilt_deg == (0.0, 0.0)
    assert configs["c_with_raytraced_share"].render.shader == "raytraced"
    assert default.render.shader == "rasterized"


def test_a_run_stopped_between_seeds_keeps_each_net_it_trained(tmp_path, monkeypatch):
    monkeypatch.syspath_prepend(str(REPO / "benchmarks"))
    import object_transfer

    run = {"cpu": {"line": "x"}, "device": "cpu", "net": {"name": "unet"}, "size": [160, 120]}
    run |= {"epochs": 20, "seeds": [0, 1, 2], "precision": {"precision": "fp32"}}
    run |= {"commit": "abc1234", "domains": {"photos": {"frames": 300}}}
    net = {"train_s": 61.0, "losses": [1.0, 0.5], "scores": {"photos": {"object": 40.0}}}
    object_transfer.keep_net(tmp_path, run, "a_flat", 2000, 1, net)
    assert object_transfer.earlier_net(tmp_path, run, "a_flat", 2000, 1)["scores"] == net["scores"]
    # another list of seeds trains the same net; anything else of the recipe does not
    assert object_transfer.earlier_net(tmp_path, run | {"seeds": [1]}, "a_flat", 2000, 1)
    assert object_transfer.earlier_net(tmp_path, run, "a_flat", 2000, 0) is None
    assert object_transfer.earlier_net(tmp_path, run, "b_plain", 2000, 1) is None
    assert object_transfer.earlier_net(tmp_path, run, "a_flat", 500, 1) is None
    assert object_transfer.earlier_net(tmp_path, run | {"epochs": 40}, "a_flat", 2000, 1) is None
    more = run | {"domains": {"photos": {"frames": 300}, "meshes": {"frames": 300}}}
    assert object_transfer.earlier_net(tmp_path, more, "a_flat", 2000, 1) is None
    (tmp_path / "nets" / "a_flat-seed1.json").write_text("{cut sh")
    assert object_transfer.earlier_net(tmp_path, run, "a_flat", 2000, 1) is None
