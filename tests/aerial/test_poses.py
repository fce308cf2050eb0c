"""Camera pose files (datagen/sensing/encode.py): ``poses.<camera>.txt`` (OpenCV camera axes,
world z up) and ``poses_ned.<camera>.txt`` (TartanAir's own convention: camera x forward, y right,
z down in a NED world). TartanAir's evaluation tools turn a NED trajectory into camera axes by
``T P T^-1`` with ``T = [[0,1,0],[0,0,1],[1,0,0]]`` (tartanair_tools, ``ned2cam``): applied to the
NED file, it gives the camera motion of the OpenCV file, frame to frame."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from datagen.dataset.episode_parts import pose_lines
from datagen.sensing.encode import pose_file, pose_file_ned

TARTANAIR_NED_TO_CAMERA = np.array(
    [[0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]]
)


def _matrices(lines: np.ndarray) -> np.ndarray:
    """(T, 4, 4) of lines ``tx ty tz qx qy qz qw``."""
    out = np.tile(np.eye(4), (len(lines), 1, 1))
    out[:, :3, :3] = Rotation.from_quat(lines[:, 3:]).as_matrix()
    out[:, :3, 3] = lines[:, :3]
    return out


def _extrinsics(camera_to_world: np.ndarray) -> np.ndarray:
    return np.linalg.inv(camera_to_world)


def _level_camera(position, yaw_deg: float) -> np.ndarray:
    """OpenCV camera-to-world of a level camera at ``position`` looking along the world heading
    ``yaw_deg`` (counter-clockwise from +x, z up)."""
    forward = Rotation.from_euler("z", yaw_deg, degrees=True).apply([1.0, 0.0, 0.0])
    down = np.array([0.0, 0.0, -1.0])
    pose = np.eye(4)
    pose[:3, :3] = np.stack([np.cross(down, forward), down, forward], axis=1)
    pose[:3, 3] = position
    return pose


def test_a_level_camera_looking_along_x_has_the_identity_attitude_in_ned():
    extrinsics = [_extrinsics(_level_camera([1.0, 2.0, 1.5], 0.0))]
    ned = pose_lines(pose_file_ned(extrinsics), "poses_ned.d0.txt")[0]
    np.testing.assert_allclose(ned, [1.0, -2.0, -1.5, 0.0, 0.0, 0.0, 1.0], atol=1e-7)
    # looking along +y (west of north in NED): yawed -90 degrees about the down axis
    extrinsics = [_extrinsics(_level_camera([0.0, 0.0, 1.0], 90.0))]
    ned = pose_lines(pose_file_ned(extrinsics), "poses_ned.d0.txt")[0]
    expected = Rotation.from_euler("z", -90.0, degrees=True).as_quat()
    np.testing.assert_allclose(ned[3:], expected, atol=1e-7)


def test_tartanairs_conversion_of_the_ned_file_gives_the_opencv_files_motion():
    rng = np.random.default_rng(0)
    poses = []
    for _ in range(12):
        pose = np.eye(4)
        pose[:3, :3] = Rotation.random(random_state=rng).as_matrix()
        pose[:3, 3] = rng.uniform(-5.0, 5.0, 3)
        poses.append(pose)
    extrinsics = [_extrinsics(p) for p in poses]
    opencv = _matrices(pose_lines(pose_file(extrinsics), "poses.d0.txt"))
    ned = _matrices(pose_lines(pose_file_ned(extrinsics), "poses_ned.d0.txt"))
    t = TARTANAIR_NED_TO_CAMERA
    converted = np.array([t @ p @ np.linalg.inv(t) for p in ned])
    for a, b in zip(range(len(poses)), range(1, len(poses)), strict=False):
        ours = np.linalg.inv(opencv[a]) @ opencv[b]
        theirs = np.linalg.inv(converted[a]) @ converted[b]
        np.testing.assert_allclose(theirs, ours, atol=1e-6)
    # and the same places: the NED world is the z-up one turned half round x
    np.testing.assert_allclose(ned[:, :3, 3], opencv[:, :3, 3] * [1.0, -1.0, -1.0], atol=1e-7)
