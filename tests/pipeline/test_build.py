"""End to end on the real stack: SAPIEN on lavapipe, Mosquitto, writer and worker processes.

Two builds of the same small dataset (2 workers, then 1 worker) are shared by the tests.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from datagen.assets.tabletop_layout import TABLE_TOP, TRAY_CENTRE, TRAY_FLOOR
from datagen.config import BuildConfig
from datagen.config.sections import RenderConfig
from datagen.dataset.loader import load, verify
from datagen.families.grasp_tabletop.world import CLASS_ID
from datagen.pipeline.run import run_build

pytestmark = [pytest.mark.sim, pytest.mark.mqtt, pytest.mark.slow]  # real builds

NUM_SAMPLES = 20
CONFIG = BuildConfig(
    num_samples=NUM_SAMPLES, seed=7, render=RenderConfig(width=192, height=144, wrist_camera=False)
)


@pytest.fixture(scope="module")
def two_worker_build(tmp_path_factory):
    out = tmp_path_factory.mktemp("build2")
    progress = []
    result = run_build(
        CONFIG, out, workers=2, on_progress=lambda done, total: progress.append(done)
    )
    return out, result, progress


@pytest.fixture(scope="module")
def one_worker_build(tmp_path_factory):
    out = tmp_path_factory.mktemp("build1")
    run_build(CONFIG, out, workers=1)
    return out


def test_exact_count_unique_keys_and_checksums(two_worker_build):
    out, result, progress = two_worker_build
    manifest = verify(out)
    dataset = load(out)
    assert result.samples == manifest["samples"] == len(dataset) == NUM_SAMPLES
    assert [dataset[i]["key"] for i in range(len(dataset))] == [
        f"{i:09d}" for i in range(NUM_SAMPLES)
    ]
    assert manifest["config"] == CONFIG.to_dict()
    assert manifest["seed"] == CONFIG.seed and manifest["versions"]["sapien"]
    assert progress[-1] == NUM_SAMPLES and progress == sorted(progress)


def test_arrays_have_the_documented_types(two_worker_build):
    item = load(two_worker_build[0])[0]
    h, w = CONFIG.render.height, CONFIG.render.width
    assert item["rgb"].shape == (h, w, 3) and item["rgb"].dtype == np.uint8
    assert item["depth"].shape == (h, w) and item["depth"].dtype == np.uint16
    assert item["seg"].shape == (h, w) and item["seg"].dtype == np.uint16
    assert item["semantic"].shape == (h, w) and item["semantic"].dtype == np.uint8
    assert item["meta"]["views"]["workspace"]["camera"]["convention"] == "opencv"


def test_2d_boxes_and_visibility_agree_with_the_masks(two_worker_build):
    dataset = load(two_worker_build[0])
    seen_visible = 0
    for i in range(len(dataset)):
        item = dataset[i]
        records = item["meta"]["views"]["workspace"]["objects"]
        targets = {r["instance_id"] for r in records if r["role"] == "target"}
        assert targets == set(range(1, len(item["meta"]["objects"]) + 1))
        others = sorted(r["instance_id"] for r in records if r["role"] != "target")
        assert others == list(range(len(targets) + 1, len(records) + 1))  # distractors after
        parts = item["meta"]["views"]["workspace"]["robot_parts"]  # the arm and the gripper
        labelled = {r["instance_id"] for r in records} | {p["instance_id"] for p in parts}
        assert set(np.unique(item["seg"])) - {0} <= labelled
        for record in records:
            ys, xs = np.nonzero(item["seg"] == record["instance_id"])
            assert record["visible_pixels"] == len(xs)
            if len(xs) == 0:
                assert record["bbox_xyxy"] is None and not record["visible"]
                continue
            seen_visible += 1
            assert record["bbox_xyxy"] == [xs.min(), ys.min(), xs.max(), ys.max()]
            assert 0.0 < record["visible_fraction"] <= 1.0
            class_ids = np.unique(item["semantic"][ys, xs])
            assert class_ids.tolist() == [CLASS_ID[record["class"]]]
    assert seen_visible > NUM_SAMPLES  # several visible objects per scene on average


def _world_heights(depth_mm, mask, camera):
    """Back-projects the masked depth pixels to world z (metres) with K and the extrinsics."""
    K = np.asarray(camera["intrinsics"])
    E = np.asarray(camera["extrinsics_world_to_camera"])
    ys, xs = np.nonzero(mask & (depth_mm > 0))
    z = depth_mm[ys, xs] * camera["depth_scale"]
    # pixel centres are at integer + 0.5 in K's image plane
    cam = np.stack(
        [(xs + 0.5 - K[0, 2]) * z / K[0, 0], (ys + 0.5 - K[1, 2]) * z / K[1, 1], z], axis=1
    )
    world = (cam - E[:3, 3]) @ E[:3, :3]
    return world[:, 2]


def test_depth_agrees_with_the_known_table_and_tray_heights(two_worker_build):
    dataset = load(two_worker_build[0])
    for i in range(0, len(dataset), 4):
        item = dataset[i]
        camera = item["meta"]["views"]["workspace"]["camera"]
        table = _world_heights(item["depth"], item["semantic"] == CLASS_ID["table"], camera)
        assert len(table) > 50
        # table top pixels sit at TABLE_TOP; depth is quantised to 1 mm and edges are mixed
        assert abs(np.median(table) - TABLE_TOP) < 0.003
        assert np.mean(np.abs(table - TABLE_TOP) < 0.01) > 0.9
        tray = _world_heights(item["depth"], item["semantic"] == CLASS_ID["tray"], camera)
        tray_floor = TRAY_CENTRE[2] + TRAY_FLOOR
        assert abs(np.median(tray) - tray_floor) < 0.005


def test_same_seed_gives_the_same_samples_whatever_the_worker_count(
    two_worker_build, one_worker_build
):
    two, one = load(two_worker_build[0]), load(one_worker_build)
    assert len(two) == len(one) == NUM_SAMPLES
    for i in range(NUM_SAMPLES):
        a, b = two[i], one[i]
        assert a["key"] == b["key"]
        assert json.dumps(a["meta"], sort_keys=True) == json.dumps(b["meta"], sort_keys=True)
        for part in ("rgb", "depth", "seg", "semantic"):
            assert np.array_equal(a[part], b[part]), (a["key"], part)


def test_different_samples_differ(two_worker_build):
    dataset = load(two_worker_build[0])
    first, second = dataset[0], dataset[1]
    assert first["meta"]["randomisation"] != second["meta"]["randomisation"]
    assert not np.array_equal(first["rgb"], second["rgb"])


def test_rebuilding_a_complete_build_does_nothing(two_worker_build):
    out, _, _ = two_worker_build
    before = {p.name: p.stat().st_mtime_ns for p in out.iterdir()}
    result = run_build(CONFIG, out, workers=2)
    assert result.already_complete
    assert {p.name: p.stat().st_mtime_ns for p in out.iterdir()} == before
