"""Navigation episodes on the real stack: plans on every family, Fetch rendered in SAPIEN, and a
build through workers, Mosquitto and the writer, loaded as episodes and as frames."""

from __future__ import annotations

import itertools
import json
import pickle
from pathlib import Path

import cv2
import h5py
import numpy as np
import pytest
from pycocotools.coco import COCO

from datagen.config import BuildConfig, load_config
from datagen.config.sections import NavigationConfig, OutputConfig, RenderConfig
from datagen.dataset.frame_dataset import load_frames
from datagen.dataset.loader import load, verify
from datagen.families.navigation.episode import plan_episode
from datagen.families.navigation.one_robot import planar_pose, produce
from datagen.families.navigation.planning import footprint_collides
from datagen.families.navigation.world import NAV_CLASS_ID
from datagen.floorplans.grid import inflate
from datagen.pipeline.run import run_build
from datagen.tools.inspection import inspect_dataset
from datagen.tools.preview import write_preview

REPO = Path(__file__).resolve().parents[2]
FAMILIES = ("rooms", "corridor", "maze")
RENDER = RenderConfig(width=96, height=72, far=20.0)


def nav_config(family: str, **navigation) -> BuildConfig:
    return BuildConfig(
        scene="navigation",
        seed=3,
        render=RENDER,
        navigation=NavigationConfig(family=family, **navigation),
    )


@pytest.mark.parametrize("family", FAMILIES)
def test_every_episode_has_a_path_and_never_crosses_a_wall(family):
    cfg = nav_config(family).navigation
    for index in range(15):
        episode = plan_episode(cfg, 3, index)
        layout, res = episode.layout, episode.layout.resolution
        inflated = inflate(layout.grid, episode.inflation, res)
        cells = np.array(episode.grid_path)
        assert tuple(cells[0]) == episode.start_cell and tuple(cells[-1]) == episode.goal_cell
        assert not inflated[cells[:, 0], cells[:, 1]].any()
        assert (np.abs(np.diff(cells, axis=0)).max(axis=1) == 1).all()  # 8-connected steps
        traj = episode.trajectory
        assert traj.success, f"{family} episode {index} did not reach its goal"
        # every 1 cm along the driven polyline, the footprint stays clear of walls and obstacles
        poses = traj.poses[:, :2]
        for a, b in itertools.pairwise(poses):
            for t in np.linspace(0, 1, max(2, int(np.hypot(*(b - a)) / 0.01) + 1)):
                x, y = a + t * (b - a)
                assert not footprint_collides(layout.grid, res, x, y, cfg.robot_radius), (
                    f"{family} episode {index} touches a wall at ({x:.3f}, {y:.3f})"
                )
        assert not traj.collision.any()
        assert episode.shortest_path_m <= episode.astar_length_m + 1e-9
        # SPL's shortest path is a true lower bound: no episode drives a shorter one
        assert episode.travelled_m >= episode.shortest_path_m, (family, index)


def _decode(data: bytes) -> np.ndarray:
    return cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED)


def _distance_to_rects(points: np.ndarray, rects: list) -> np.ndarray:
    """(N,) distance in the floor plane from each point to the nearest rectangle."""
    r = np.asarray(rects, float)[None]  # (1, R, 4): x0, y0, x1, y1
    x, y = points[:, None, 0], points[:, None, 1]
    dx = np.maximum(np.maximum(r[..., 0] - x, x - r[..., 2]), 0.0)
    dy = np.maximum(np.maximum(r[..., 1] - y, y - r[..., 3]), 0.0)
    return np.hypot(dx, dy).min(axis=1)


@pytest.fixture(scope="module")
def rendered():
    return {family: produce(nav_config(family), 3, 1) for family in FAMILIES}


@pytest.mark.parametrize("family", FAMILIES)
@pytest.mark.sim
def test_frames_agree_with_the_robot_pose_and_the_layout(rendered, family):
    sample = rendered[family]
    meta = json.loads(sample.parts["json"])
    camera, layout = meta["camera"], meta["episode"]["layout"]
    K = np.asarray(camera["intrinsics"])
    mount = np.asarray(camera["camera_in_robot"])
    assert 1.0 <= camera["height_m"] <= 1.45
    assert camera["pitch_down_deg"] == pytest.approx(meta["randomisation"]["camera"]["pitch_deg"], abs=0.05)  # fmt: skip
    assert camera["fovy_deg"] == pytest.approx(meta["randomisation"]["camera"]["fovy_deg"], abs=1e-3)  # fmt: skip
    assert len(meta["frames"]) == meta["episode"]["frames"] >= 2
    seen = set()
    for k, frame in enumerate(meta["frames"]):
        # the camera pose in the metadata is the robot pose composed with the fixed mount
        E = np.asarray(frame["extrinsics_world_to_camera"])
        np.testing.assert_allclose(np.linalg.inv(E), planar_pose(*frame["pose"]) @ mount, atol=2e-4)
        # the footprint's gap to the nearest wall or obstacle: negative exactly when it collides
        assert (frame["obstacle_gap"] < 0) == frame["collision"]
        assert (
            frame["obstacle_gap"]
            <= _distance_to_rects(np.array([frame["pose"][:2]]), layout["walls"])[0] - 0.3 + 1e-6
        )
        # and the rendered depth puts floor pixels on z = 0 and wall pixels on a wall's faces
        depth = _decode(sample.parts[f"f{k:04d}.depth.png"]).astype(float) * camera["depth_scale"]
        semantic = _decode(sample.parts[f"f{k:04d}.semantic.png"])
        v, u = np.nonzero(depth > 0)
        rays = np.linalg.inv(K) @ np.stack([u + 0.5, v + 0.5, np.ones_like(u)])
        cam = np.vstack([rays * depth[v, u], np.ones_like(u)])
        world = (np.linalg.inv(E) @ cam)[:3].T
        classes = semantic[v, u]
        seen |= set(np.unique(classes).tolist())
        floor = classes == NAV_CLASS_ID["floor"]
        assert np.abs(world[floor, 2]).max(initial=0.0) < 0.01
        wall = classes == NAV_CLASS_ID["wall"]
        if wall.any():
            assert np.percentile(_distance_to_rects(world[wall], layout["walls"]), 99) < 0.01
        goal = classes == NAV_CLASS_ID["goal_marker"]
        if goal.any():
            offset = np.hypot(*(world[goal, :2] - meta["episode"]["goal"]).T)
            assert offset.max() < 0.25  # the marker's disk radius is 0.22 m
    assert {NAV_CLASS_ID["floor"], NAV_CLASS_ID["wall"]} <= seen


@pytest.mark.sim
def test_same_seed_same_episode(rendered):
    again = produce(nav_config("maze"), 3, 1)
    assert again.parts == rendered["maze"].parts
    other = plan_episode(nav_config("maze").navigation, 3, 2)
    assert not np.array_equal(other.trajectory.poses[:5], plan_episode(nav_config("maze").navigation, 3, 1).trajectory.poses[:5])  # fmt: skip


EPISODES = 4


@pytest.fixture(scope="module")
def nav_build(tmp_path_factory):
    base = load_config(REPO / "configs" / "nav_maze.yaml")
    config = base.replace(
        num_samples=EPISODES,
        render=RENDER,
        navigation=NavigationConfig(family="maze", clutter=(1, 4), frame_rate_hz=1.0),
        output=OutputConfig(formats=("webdataset", "coco", "hdf5")),
    )
    out = tmp_path_factory.mktemp("nav")
    run_build(config, out / "two", workers=2)
    run_build(config, out / "one", workers=1)
    return out


@pytest.mark.sim
@pytest.mark.mqtt
@pytest.mark.slow
def test_build_loads_as_episodes_and_as_frames(nav_build):
    root = nav_build / "two"
    manifest = verify(root)
    episodes = load(root)
    assert manifest["samples"] == len(episodes) == EPISODES
    total = 0
    for item in episodes:
        meta = item["meta"]
        assert len(item["frames"]) == meta["episode"]["frames"]
        times = [f["meta"]["time_s"] for f in item["frames"]]
        assert times == sorted(times) and times[0] == 0
        assert item["frames"][0]["rgb"].shape == (RENDER.height, RENDER.width, 3)
        assert item["occupancy"].shape == tuple(meta["episode"]["layout"]["grid_shape"])
        assert item["map"].shape[:2] == tuple(3 * np.asarray(item["occupancy"].shape))
        # the TartanAir-style pose file: each frame's camera-to-world position, to its 7 decimals
        assert item["poses"]["head"].shape == (len(item["frames"]), 7)
        for pose, frame in zip(item["poses"]["head"], item["frames"], strict=True):
            to_world = np.linalg.inv(frame["meta"]["extrinsics_world_to_camera"])
            np.testing.assert_allclose(pose[:3], to_world[:3, 3], atol=1e-5)
        total += len(item["frames"])
    frames = pickle.loads(pickle.dumps(load_frames(root)))  # picklable for DataLoader workers
    assert len(frames) == total
    keys = [frames[j]["key"] for j in range(len(frames))]
    assert len(set(keys)) == total
    item = frames[len(frames) - 1]
    last = episodes[EPISODES - 1]
    assert item["episode"] == last["key"] and item["frame"] == len(last["frames"]) - 1
    np.testing.assert_array_equal(item["depth"], last["frames"][-1]["depth"])
    assert item["meta"] == last["frames"][-1]["meta"]


@pytest.mark.sim
@pytest.mark.mqtt
@pytest.mark.slow
def test_build_is_the_same_whatever_the_number_of_workers(nav_build):
    two, one = load(nav_build / "two"), load(nav_build / "one")
    assert two.keys == one.keys
    for i in range(EPISODES):
        assert two.raw(i) == one.raw(i)


@pytest.mark.sim
@pytest.mark.mqtt
@pytest.mark.slow
def test_inspect_summarises_episodes(nav_build):
    summary, files = inspect_dataset(nav_build / "two")
    assert summary["episodes"] == EPISODES and summary["families"] == {"maze": EPISODES}
    assert summary["frames"] == len(load_frames(nav_build / "two"))
    assert summary["success_rate"] == 1.0 and summary["frames_with_collision"] == 0
    assert all(p.is_file() and p.stat().st_size > 0 for p in files)
    preview = cv2.imread(str(write_preview(nav_build / "two", nav_build / "preview.png")))
    assert preview.shape[1] == 4 * RENDER.width  # one column per episode: frame above map


@pytest.mark.sim
@pytest.mark.mqtt
@pytest.mark.slow
def test_episodes_export_to_hdf5_and_coco(nav_build):
    root = nav_build / "one"
    episodes = load(root)
    with h5py.File(root / "episodes.h5", "r") as f:
        assert list(f["index/frames"][:]) == [episodes.metadata(i)["episode"]["frames"] for i in range(EPISODES)]  # fmt: skip
        for i in range(EPISODES):
            item, group = episodes[i], f[f"samples/{episodes.keys[i]}"]
            np.testing.assert_array_equal(group["depth"][()], np.stack([fr["depth"] for fr in item["frames"]]))  # fmt: skip
            np.testing.assert_allclose(group["pose"][()], [fr["meta"]["pose"] for fr in item["frames"]])  # fmt: skip
            np.testing.assert_array_equal(group["occupancy"][()], item["occupancy"])
            assert len(group["trajectory/poses"]) == item["meta"]["episode"]["steps"] + 1
    coco = COCO(str(root / "coco" / "annotations.json"))
    frames = load_frames(root)
    assert len(coco.getImgIds()) == len(frames)
    by_name = {img["file_name"]: img for img in coco.dataset["images"]}
    for j in range(len(frames)):
        frame = frames[j]
        image = by_name[f"{frame['episode']}.f{frame['frame']:04d}.png"]
        anns = coco.loadAnns(coco.getAnnIds(imgIds=[image["id"]]))
        assert sorted(a["instance_id"] for a in anns) == sorted(t["instance_id"] for t in frame["meta"]["things"])  # fmt: skip
        for ann in anns:
            np.testing.assert_array_equal(coco.annToMask(ann).astype(bool), frame["seg"] == ann["instance_id"])  # fmt: skip


@pytest.mark.parametrize("family", FAMILIES)
def test_shipped_configs_load(family):
    config = load_config(REPO / "configs" / f"nav_{family}.yaml")
    assert config.scene == "navigation" and config.navigation.family == family
