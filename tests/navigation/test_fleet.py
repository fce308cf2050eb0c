"""Several ground robots per episode (``navigation.robots``; datagen/families/navigation/fleet.py,
scenes/navigation_fleet.py): they never come closer than two radii and the margin, each reaches
its goal never shorter than SPL's bound, each is an instance in the others' cameras, and a build
is the same whatever the number of workers, loaded, inspected, previewed and exported."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest
import yaml

from datagen.config import config_from_dict
from datagen.dataset.frame_dataset import load_frames
from datagen.dataset.loader import load, verify
from datagen.exports.runner import run_exports
from datagen.families.navigation.fleet import closest_approach, plan_fleet_episode
from datagen.tools.inspection import inspect_dataset
from datagen.tools.preview import write_preview

REPO = Path(__file__).resolve().parents[2]
FLEET = {
    "version": 1, "scene": "navigation", "num_samples": 2, "seed": 6,
    "render": {"width": 96, "height": 72, "far": 20.0},
    "navigation": {"family": "rooms", "robots": 2, "frame_rate_hz": 2},
}  # fmt: skip


def _nav(family: str, robots: int, robot: str = "fetch"):
    extra = {"robot_radius": 0.25, "lookahead": 0.7} if robot == "car" else {}
    return config_from_dict({"scene": "navigation", "navigation": {"family": family, "robots": robots, "robot": robot, **extra}}).navigation  # fmt: skip


@pytest.mark.parametrize(("family", "robots", "robot"), [("rooms", 3, "fetch"), ("corridor", 2, "fetch"), ("plus_maze", 2, "car")])  # fmt: skip
def test_robots_never_touch_and_each_reaches_its_goal(family, robots, robot):
    cfg = _nav(family, robots, robot)
    apart = 2 * cfg.robot_radius + cfg.planning_margin
    for index in range(4):
        fleet = plan_fleet_episode(cfg, 1, index)
        assert len(fleet.agents) == robots
        for i, a in enumerate(fleet.agents):
            traj = a.episode.trajectory
            assert traj.success and not traj.collision.any()
            assert a.episode.travelled_m >= a.episode.shortest_path_m
            for b in fleet.agents[:i]:
                assert closest_approach(a, b, fleet.steps) >= apart - 1e-9
                assert np.hypot(*np.subtract(a.episode.goal, b.episode.goal)) >= apart


def test_the_same_fleet_from_the_same_seed_and_index():
    cfg = _nav("rooms", 2)
    a, b = plan_fleet_episode(cfg, 2, 3), plan_fleet_episode(cfg, 2, 3)
    assert [x.delay for x in a.agents] == [x.delay for x in b.agents]
    assert all(
        np.array_equal(x.episode.path, y.episode.path)
        for x, y in zip(a.agents, b.agents, strict=True)
    )


@pytest.fixture(scope="module")
def fleet_builds(tmp_path_factory) -> Path:
    tmp = tmp_path_factory.mktemp("fleet")
    path = tmp / "fleet.yaml"
    path.write_text(yaml.safe_dump(FLEET))
    for workers in ("1", "2"):
        done = subprocess.run(
            [sys.executable, "-m", "datagen.cli", "build", str(path), "--out", str(tmp / workers), "--workers", workers],
            capture_output=True, text=True, cwd=REPO, timeout=900, check=False,
        )  # fmt: skip
        assert done.returncode == 0, done.stderr[-3000:]
    return tmp


@pytest.mark.sim
@pytest.mark.mqtt
@pytest.mark.slow
def test_a_fleet_build_is_exact_and_the_same_whatever_the_workers(fleet_builds):
    assert verify(fleet_builds / "2")["samples"] == FLEET["num_samples"]
    one, two = load(fleet_builds / "1"), load(fleet_builds / "2")
    assert one.keys == two.keys and all(one.raw(i) == two.raw(i) for i in range(len(one)))


@pytest.mark.sim
@pytest.mark.mqtt
@pytest.mark.slow
def test_robots_are_instances_in_each_others_cameras(fleet_builds):
    seen_other = 0
    for item in load(fleet_builds / "1"):
        meta = item["meta"]
        robots = [t["instance_id"] for t in meta["things"] if t["class"] == "robot"]
        assert len(robots) == 2 and meta["format"] == "datagen.nav_fleet/1"
        for frame, record in zip(item["frames"], meta["frames"], strict=True):
            for k, name in enumerate(("r0", "r1")):
                seg = frame["cameras"][name]["seg"]
                other = robots[1 - k]
                listed = {t["instance_id"] for t in record["cameras"][name]["things"]}
                assert robots[k] not in listed  # a robot is not a thing its own camera sees
                if (seg == other).any():
                    assert other in listed
                    seen_other += 1
    assert seen_other > 0


@pytest.mark.sim
@pytest.mark.mqtt
@pytest.mark.slow
def test_a_fleet_is_inspected_previewed_and_exported(fleet_builds, tmp_path):
    root = tmp_path / "copy"
    shutil.copytree(fleet_builds / "1", root)
    summary, files = inspect_dataset(root)
    assert all(p.is_file() and p.stat().st_size > 0 for p in files)
    assert summary["episodes"] == 2 and summary["robots"] == 4 and summary["success_rate"] == 1.0
    assert write_preview(root, root / "preview.png").is_file()
    frames = load_frames(root)
    assert len(frames) == sum(
        m["episode"]["frames"] * 2 for m in (load(root).metadata(i) for i in range(2))
    )
    run_exports(root, ["hdf5", "robomimic", "coco"])
    episodes = load(root)
    with h5py.File(root / "episodes.h5", "r") as f:
        group = f[f"samples/{episodes.keys[0]}"]
        poses = [fr["meta"]["agents"][1]["pose"] for fr in episodes[0]["frames"]]
        np.testing.assert_allclose(group["agents/1/pose"][()], poses)
        assert group["r1/rgb"].shape[0] == len(poses)
    with h5py.File(root / "robomimic" / "demo.hdf5", "r") as f:
        keys = sorted(f[f"data/{d}"].attrs["datagen_key"] for d in f["data"])
        assert keys == sorted(f"{k}.r{j}" for k in episodes.keys for j in (0, 1))
