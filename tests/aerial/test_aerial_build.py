"""Aerial builds through the real pipeline (workers, Mosquitto, the writer): exact counts, the same
bytes whatever the number of workers, loaded as episodes and as frames, inspected, previewed and
exported to HDF5, COCO and robomimic (one episode per drone; LeRobot: tests/exports/test_lerobot.py)."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import cv2
import h5py
import numpy as np
import pytest
import yaml
from conftest import AERIAL, REPO  # tests/conftest.py
from pycocotools.coco import COCO

from datagen.dataset.frame_dataset import load_frames
from datagen.dataset.loader import load, verify
from datagen.exports.runner import run_exports
from datagen.tools.inspection import inspect_dataset
from datagen.tools.preview import write_preview

pytestmark = [pytest.mark.sim, pytest.mark.mqtt, pytest.mark.slow]


@pytest.fixture(scope="module")
def two_workers(tmp_path_factory) -> Path:
    tmp = tmp_path_factory.mktemp("aerial2")
    path = tmp / "aerial.yaml"
    path.write_text(yaml.safe_dump(AERIAL))
    done = subprocess.run(
        [sys.executable, "-m", "datagen.cli", "build", str(path), "--out", str(tmp / "two"), "--workers", "2"],
        capture_output=True, text=True, cwd=REPO, timeout=900, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr[-3000:]
    return tmp / "two"


def test_exact_counts_and_the_same_bytes_whatever_the_number_of_workers(
    aerial_dataset, two_workers
):
    manifest = verify(two_workers)
    assert manifest["samples"] == AERIAL["num_samples"]
    one, two = load(aerial_dataset), load(two_workers)
    assert one.keys == two.keys and len(set(one.keys)) == AERIAL["num_samples"]
    for i in range(len(one)):
        assert one.raw(i) == two.raw(i)


def test_loads_as_episodes_and_as_frames(aerial_dataset):
    episodes = load(aerial_dataset)
    total = 0
    for item in episodes:
        meta = item["meta"]
        assert len(item["frames"]) == meta["episode"]["frames"]
        assert sorted(item["frames"][0]["cameras"]) == ["d0", "d0_down", "d1", "d1_down"]
        assert sorted(item["poses"]) == sorted(meta["cameras"])
        assert all(len(p) == len(item["frames"]) for p in item["poses"].values())
        assert item["occupancy"].shape == tuple(meta["episode"]["volume"]["shape"])
        assert sorted(item["poses_ned"]) == sorted(meta["cameras"])
        assert sorted(item["imu"]) == ["d0", "d1"] and meta["imu"]["rate_hz"] == 200.0
        total += len(item["frames"]) * len(meta["cameras"])
    frames = load_frames(aerial_dataset)
    assert len(frames) == total and len({frames[j]["key"] for j in range(len(frames))}) == total
    # a frame's IMU samples are its drone's since the previous frame: together, the whole stream
    first = f"{episodes.keys[0]}/"
    d1 = [f for f in frames if f["key"].startswith(first) and f["view"] == "d1"]
    stream = episodes[0]["imu"]["d1"]
    joined = np.concatenate([f["imu"]["time_s"] for f in d1])
    np.testing.assert_array_equal(joined, stream["time_s"])
    np.testing.assert_array_equal(
        np.concatenate([f["imu"]["gyroscope"] for f in d1]), stream["gyroscope"]
    )
    last = frames[len(frames) - 1]
    assert last["view"] == "d1_down" and "flow" not in last  # the last frame has no next one
    first = frames[0]
    assert first["view"] == "d0" and first["flow"].shape == (72, 96, 2)


def test_the_monitors_thumbnail_is_the_episodes_map(aerial_dataset):
    from datagen.pipeline.live_preview import sample_outcome, thumbnail
    from datagen.sample import Sample

    dataset = load(aerial_dataset)
    sample = Sample(0, dataset.raw(0))
    image = thumbnail(sample, width=200)
    assert image is not None and image.shape[1] == 200
    outcome = sample_outcome(sample)
    assert outcome["kind"] == "navigation" and outcome["success"] and 0 < outcome["spl"] <= 1


def test_inspect_and_preview(aerial_dataset, tmp_path):
    root = tmp_path / "copy"
    shutil.copytree(aerial_dataset, root)
    summary, files = inspect_dataset(root)
    assert summary["episodes"] == 2 and summary["drones"] == 4 and summary["success_rate"] == 1.0
    assert summary["frames_with_collision"] == 0 and summary["altitude_m"][0] > 0
    assert all(p.is_file() and p.stat().st_size > 0 for p in files)
    preview = cv2.imread(str(write_preview(root, root / "preview.png")))
    assert preview is not None and preview.shape[1] >= 2 * 3 * 96


def test_exports_to_hdf5_coco_and_robomimic(aerial_dataset, tmp_path):
    root = tmp_path / "copy"
    shutil.copytree(aerial_dataset, root)
    run_exports(root, ["hdf5", "coco", "robomimic", "pointcloud"])
    episodes = load(root)
    with h5py.File(root / "episodes.h5", "r") as f:
        for i in range(len(episodes)):
            item, group = episodes[i], f[f"samples/{episodes.keys[i]}"]
            depth = np.stack([fr["cameras"]["d1"]["depth"] for fr in item["frames"]])
            np.testing.assert_array_equal(group["d1/depth"][()], depth)
            position = [fr["meta"]["agents"][1]["position"] for fr in item["frames"]]
            np.testing.assert_allclose(group["agents/1/position"][()], position)
            np.testing.assert_array_equal(group["occupancy"][()], item["occupancy"])
            np.testing.assert_allclose(group["poses/d0"][()], item["poses"]["d0"])
    coco = COCO(str(root / "coco" / "annotations.json"))
    frames = load_frames(root)
    assert len(coco.getImgIds()) == len(frames)
    drones = [c["id"] for c in coco.dataset["categories"] if c["name"] == "drone"]
    assert drones and coco.getAnnIds(catIds=drones)  # the drones see each other
    import open3d as o3d

    for key in episodes.keys:  # every camera's frames, fused in the world: inside the volume
        cloud = o3d.t.io.read_point_cloud(str(root / "pointclouds" / f"{key}.ply"))
        points = cloud.point.positions.numpy()
        shape = episodes.metadata(episodes.keys.index(key))["episode"]["volume"]["shape"]
        assert len(points) > 0 and points[:, 2].min() > -0.01
        assert points[:, 2].max() < shape[0] * 0.1 + 0.11  # below the ceiling slab's top
    with h5py.File(root / "robomimic" / "demo.hdf5", "r") as f:
        demos = sorted(f["data"])
        assert len(demos) == 4  # one per drone and episode
        keys = sorted(f[f"data/{d}"].attrs["datagen_key"] for d in demos)
        assert keys == sorted(f"{k}.d{j}" for k in episodes.keys for j in (0, 1))
        assert json.loads(f["data"].attrs["action_names"])[0] == "thrust_m_s2"
