"""Aerial episodes rendered in SAPIEN: cameras where the drones carry them, depth on the volume's
surfaces, optical flow that warps a frame onto the next, drones labelled in each other's cameras
and never in their own, the labels per frame consistent with the trajectories; a stereo pair
rectified (a left pixel's point seen on the same row of the right image, its disparity f b / Z);
the stored IMU streams integrated back to every flight; both pose files the same camera motion."""

from __future__ import annotations

import numpy as np
import pytest
from aerial_strapdown import angle_between, integrate

from datagen.config import config_from_dict
from datagen.dataset.parts import decode_parts
from datagen.families.aerial.flatness import GRAVITY
from datagen.families.aerial.produce import produce
from datagen.families.aerial.volumes import box_distance

pytestmark = [pytest.mark.sim]
WIDTH, HEIGHT = 160, 120
BASELINE = 0.12  # metres


def _config(family: str, drones: int, **aerial):
    return config_from_dict({
        "scene": "aerial", "seed": 5, "render": {"width": WIDTH, "height": HEIGHT, "far": 20.0},
        "aerial": {"family": family, "drones": drones, "frame_rate_hz": 4.0, **aerial},
    })  # fmt: skip


@pytest.fixture(scope="module", params=[("corridor", 2, 0), ("rooms", 1, 1), ("maze", 1, 2)],
                ids=lambda p: f"{p[0]}-{p[1]}")  # fmt: skip
def episode(request):
    family, drones, index = request.param
    # the corridor's drones carry a stereo pair and a noisy IMU
    extra = {"stereo_baseline": BASELINE, "imu_noise": {"enabled": True}} if drones > 1 else {}
    config = _config(family, drones, down_camera=family == "maze", **extra)
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


def test_a_stereo_pair_is_rectified_and_fully_annotated(episode):
    config, _, item = episode
    meta = item["meta"]
    pairs = [(n, c["stereo"]["left"]) for n, c in meta["cameras"].items() if "stereo" in c]
    assert len(pairs) == (len(meta["episode"]["agents"]) if config.aerial.stereo_baseline else 0)
    for right, left in pairs:
        assert meta["cameras"][right]["intrinsics"] == meta["cameras"][left]["intrinsics"]
        assert meta["cameras"][right]["stereo"]["baseline_m"] == BASELINE
        k = np.asarray(meta["cameras"][left]["intrinsics"])
        depth_errors, colour_errors = [], []
        for frame in item["frames"]:
            e_left = np.asarray(frame["meta"]["cameras"][left]["extrinsics_world_to_camera"])
            e_right = np.asarray(frame["meta"]["cameras"][right]["extrinsics_world_to_camera"])
            relative = e_right @ np.linalg.inv(e_left)  # left camera -> right camera
            np.testing.assert_allclose(relative[:3, :3], np.eye(3), atol=1e-5)  # parallel axes
            np.testing.assert_allclose(relative[:3, 3], [-BASELINE, 0.0, 0.0], atol=1e-5)
            images = frame["cameras"][left], frame["cameras"][right]
            depth_l = images[0]["depth"].astype(float) / 1000.0
            rows, cols = np.nonzero(depth_l > 0.5)
            column = cols + 0.5 - k[0, 0] * BASELINE / depth_l[rows, cols]  # on the same row
            keep = column >= 0.5
            rows, cols, seen = rows[keep], cols[keep], np.floor(column[keep]).astype(int)
            depth_r = images[1]["depth"][rows, seen].astype(float) / 1000.0
            depth_errors.append(np.abs(depth_r - depth_l[rows, cols]))
            colour = images[1]["rgb"][rows, seen].astype(int) - images[0]["rgb"][rows, cols]
            colour_errors.append(np.abs(colour).max(axis=1))
            assert set(images[1]) >= {"rgb", "depth", "seg", "semantic"}
            assert "things" in frame["meta"]["cameras"][right]
        # occlusions and edges aside (the right camera on the left side matches about half)
        assert np.mean(np.concatenate(depth_errors) < 0.01) > 0.85
        assert np.mean(np.concatenate(colour_errors) <= 10) > 0.85


def test_the_stored_imu_integrates_back_to_every_flight(episode):
    """tests/aerial/aerial_strapdown.py on each drone's imu.d<k>.npz, from its state at t = 0
    alone, against the per-frame states of the episode's JSON."""
    config, _, item = episode
    meta = item["meta"]
    assert meta["imu"]["rate_hz"] == config.aerial.imu_hz == 200.0
    for k, agent in enumerate(meta["episode"]["agents"]):
        imu = item["imu"][f"d{k}"]
        indices, positions, _, quaternions = integrate(
            imu["time_s"],
            imu["accelerometer"],
            imu["gyroscope"],
            imu["position"][0],
            imu["velocity"][0],
            imu["quaternion_xyzw"][0],
        )
        at = {round(float(t), 6): j for j, t in enumerate(imu["time_s"][indices])}
        for record in meta["frames"]:
            if (j := at.get(record["time_s"])) is None:
                continue
            state = record["agents"][k]
            assert np.linalg.norm(positions[j] - state["position"]) < 0.01
            turn = angle_between(quaternions[j : j + 1], np.asarray([state["quaternion_xyzw"]]))
            assert np.degrees(turn[0]) < 0.1
        assert np.linalg.norm(positions[-1] - agent["goal"]) < 0.01
        assert imu["time_s"][-1] >= agent["take_off_s"] + agent["flight_s"]
        noisy = "accelerometer_noisy" in imu
        assert noisy == config.aerial.imu_noise.enabled == (meta["imu"]["noise"] is not None)


def test_both_pose_files_give_the_same_camera_motion(episode):
    """TartanAir's ned2cam (T P T^-1) of the NED file is the OpenCV file's motion."""
    _, _, item = episode
    t = np.array([[0, 1, 0, 0], [0, 0, 1, 0], [1, 0, 0, 0], [0, 0, 0, 1]], float)
    assert sorted(item["poses_ned"]) == sorted(item["poses"])
    for name in item["poses"]:
        opencv = [_pose(p[:3], p[3:]) for p in item["poses"][name]]
        ned = [t @ _pose(p[:3], p[3:]) @ t.T for p in item["poses_ned"][name]]
        for a, b in zip(range(len(ned)), range(1, len(ned)), strict=False):
            np.testing.assert_allclose(
                np.linalg.inv(ned[a]) @ ned[b], np.linalg.inv(opencv[a]) @ opencv[b], atol=1e-5
            )
    assert set(item["meta"]["poses_convention"]) == {"poses.<camera>.txt", "poses_ned.<camera>.txt"}
