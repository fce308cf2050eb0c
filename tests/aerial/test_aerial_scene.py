"""Aerial episodes rendered in SAPIEN: cameras where the drones carry them, depth on the volume's
surfaces, optical flow that warps a frame onto the next, drones labelled in each other's cameras
and never in their own, the labels per frame consistent with the trajectories."""

from __future__ import annotations

import numpy as np
import pytest

from datagen.aerial.flatness import GRAVITY
from datagen.aerial.volumes import box_distance
from datagen.config import config_from_dict
from datagen.dataset.loader import decode_parts
from datagen.scenes.aerial_episodes import produce

pytestmark = [pytest.mark.sim]
WIDTH, HEIGHT = 160, 120


def _config(family: str, drones: int, **aerial):
    return config_from_dict({
        "scene": "aerial", "seed": 5, "render": {"width": WIDTH, "height": HEIGHT, "far": 20.0},
        "aerial": {"family": family, "drones": drones, "frame_rate_hz": 4.0, **aerial},
    })  # fmt: skip


@pytest.fixture(scope="module", params=[("corridor", 2, 0), ("rooms", 1, 1), ("maze", 1, 2)],
                ids=lambda p: f"{p[0]}-{p[1]}")  # fmt: skip
def episode(request):
    family, drones, index = request.param
    config = _config(family, drones, down_camera=family == "maze")
    sample = produce(config, config.seed, index)
    return config, sample, decode_parts(sample.parts)


def _pose(position, quaternion_xyzw) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    matrix = np.eye(4)
    matrix[:3, :3] = Rotation.from_quat(quaternion_xyzw).as_matrix()
    matrix[:3, 3] = position
    return matrix


def test_every_camera_is_its_drones_pose_times_its_mount(episode):
    _, _, item = episode
    meta = item["meta"]
    for record in meta["frames"]:
        for name, seen in record["cameras"].items():
            camera = meta["cameras"][name]
            agent = record["agents"][camera["drone"]]
            expected = np.linalg.inv(
                _pose(agent["position"], agent["quaternion_xyzw"])
                @ np.asarray(camera["camera_in_body"])
            )
            np.testing.assert_allclose(seen["extrinsics_world_to_camera"], expected, atol=1e-4)
            poses = item["poses"][name][record["frame"]]
            camera_to_world = np.linalg.inv(np.asarray(seen["extrinsics_world_to_camera"]))
            np.testing.assert_allclose(poses[:3], camera_to_world[:3, 3], atol=1e-4)


def test_depth_back_projects_onto_the_volumes_surfaces(episode):
    _, _, item = episode
    meta = item["meta"]
    boxes = np.asarray([s["box"] for s in meta["episode"]["volume"]["solids"]], float)
    classes = meta["classes"]
    errors = []
    for frame in item["frames"][:: max(1, len(item["frames"]) // 6)]:
        for name, images in frame["cameras"].items():
            camera = meta["cameras"][name]
            depth = images["depth"].astype(float) / 1000.0
            stuff = np.isin(
                images["semantic"],
                [classes.index(c) for c in ("floor", "wall", "ceiling", "obstacle")],
            )
            rows, cols = np.nonzero((depth > 0) & stuff)
            rays = (
                np.stack([cols + 0.5, rows + 0.5, np.ones(len(rows))], 1)
                @ np.linalg.inv(camera["intrinsics"]).T
            )
            points = rays * depth[rows, cols, None]
            to_world = np.linalg.inv(frame["meta"]["cameras"][name]["extrinsics_world_to_camera"])
            world = points @ to_world[:3, :3].T + to_world[:3, 3]
            floor = np.abs(world[:, 2])  # the floor's top is z = 0
            errors.append(np.minimum(box_distance(world, boxes), floor))
    assert np.percentile(np.concatenate(errors), 99) < 0.01  # metres


def test_optical_flow_warps_each_frame_onto_the_next(episode):
    import cv2

    _, _, item = episode
    medians = []
    for before, after in zip(item["frames"], item["frames"][1:], strict=False):
        for name, images in before["cameras"].items():
            flow, valid = images["flow"], images["flow_valid"]
            if valid.mean() < 0.2:
                continue
            rows, cols = np.mgrid[0:HEIGHT, 0:WIDTH].astype(np.float32)
            warped = cv2.remap(
                after["cameras"][name]["rgb"],
                cols + flow[..., 0],
                rows + flow[..., 1],
                cv2.INTER_LINEAR,
            )
            error = np.abs(warped.astype(int) - images["rgb"].astype(int)).max(axis=2)
            medians.append(np.median(error[valid]))
            assert "flow" not in item["frames"][-1]["cameras"][name]  # none after the last frame
    assert medians and np.median(medians) <= 6  # levels of 255
    assert np.max(medians) <= 20


def test_drones_are_labelled_in_each_others_cameras_and_never_in_their_own(episode):
    _, _, item = episode
    meta = item["meta"]
    drone_ids = [t["instance_id"] for t in meta["things"] if t["class"] == "drone"]
    drone_class = meta["classes"].index("drone")
    seen_other = 0
    for frame in item["frames"]:
        for name, images in frame["cameras"].items():
            own = drone_ids[meta["cameras"][name]["drone"]]
            assert not (images["seg"] == own).any(), name
            drones = np.isin(images["seg"], drone_ids)
            assert np.array_equal(drones, images["semantic"] == drone_class)
            seen_other += int(drones.any())
            listed = {t["instance_id"] for t in frame["meta"]["cameras"][name]["things"]}
            assert set(np.unique(images["seg"][drones])) <= listed
    if len(drone_ids) > 1:
        assert seen_other > 0  # the corridor's two drones meet in some camera


def test_per_frame_states_are_consistent(episode):
    config, _, item = episode
    meta = item["meta"]
    for k, agent in enumerate(meta["episode"]["agents"]):
        states = [f["agents"][k] for f in meta["frames"]]
        positions = np.array([s["position"] for s in states])
        for s in states:
            assert np.allclose(s["imu"]["accelerometer"][:2], 0.0, atol=1e-5)
            assert s["imu"]["accelerometer"][2] == pytest.approx(s["thrust"], abs=1e-5)
            assert s["obstacle_gap"] >= config.aerial.margin / 2 - 1e-6 and not s["collision"]
        assert np.allclose(positions[0], agent["start"], atol=1e-5) and np.allclose(
            positions[-1], agent["goal"], atol=1e-5
        )
        assert (
            agent["success"]
            and 0 < agent["spl"] <= 1
            and agent["path_length_m"] >= agent["shortest_path_m"]
        )
        hover = [s for s in states if np.linalg.norm(s["velocity"]) < 1e-9]
        assert all(s["thrust"] == pytest.approx(GRAVITY, abs=1e-6) for s in hover)
    assert item["occupancy"].shape == tuple(meta["episode"]["volume"]["shape"])
    assert item["map"].ndim == 3 and item["side"].ndim == 3


def test_the_same_episode_gives_the_same_bytes():
    config = _config("corridor", 1)
    assert produce(config, config.seed, 3).parts == produce(config, config.seed, 3).parts
