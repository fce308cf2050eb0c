"""Small rigid-transform helpers (metres, radians; quaternions are w, x, y, z like SAPIEN)."""

from __future__ import annotations

import numpy as np
import transforms3d.quaternions as tq

from datagen.records import PoseRecord

# SAPIEN's camera entity frame is x forward, y left, z up; OpenCV's camera frame is
# x right, y down, z forward. This maps OpenCV camera coordinates to SAPIEN camera coordinates.
CV_TO_SAPIEN_CAMERA = np.array([[0, 0, 1, 0], [-1, 0, 0, 0], [0, -1, 0, 0], [0, 0, 0, 1]], float)


def random_quaternion(rng: np.random.Generator) -> list[float]:
    """Uniform on SO(3), w >= 0."""
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    return [float(x) for x in (q if q[0] >= 0 else -q)]


def look_at(eye, target, up=(0.0, 0.0, 1.0)) -> np.ndarray:
    """(4, 4) world pose of a SAPIEN camera at ``eye`` looking at ``target``."""
    eye, target = np.asarray(eye, float), np.asarray(target, float)
    forward = target - eye
    forward /= np.linalg.norm(forward)
    left = np.cross(np.asarray(up, float), forward)
    if np.linalg.norm(left) < 1e-6:  # looking straight along ``up``
        left = np.cross([0.0, 1.0, 0.0], forward)
    left /= np.linalg.norm(left)
    pose = np.eye(4)
    pose[:3, :3] = np.stack([forward, left, np.cross(forward, left)], axis=1)
    pose[:3, 3] = eye
    return pose


def world_to_cv_camera(camera_pose_world: np.ndarray) -> np.ndarray:
    """(4, 4) extrinsics, OpenCV convention: x_cam = E @ x_world, camera x right, y down, z ahead."""
    return np.linalg.inv(camera_pose_world @ CV_TO_SAPIEN_CAMERA)


def pose_record(transform: np.ndarray) -> PoseRecord:
    """A JSON record of a (4, 4) transform: the matrix plus position and quaternion (w, x, y, z)."""
    return {
        "matrix": np.round(transform, 7).tolist(),
        "position": np.round(transform[:3, 3], 7).tolist(),
        "quat_wxyz": np.round(tq.mat2quat(transform[:3, :3]), 7).tolist(),
    }


def image_points(
    points_world: np.ndarray, intrinsics: np.ndarray, extrinsics: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """World points (N, 3) -> image-plane coordinates (N, 2) as the intrinsics define them, and
    depth (N,) in metres. The origin is the top-left corner of the top-left pixel, so pixel
    (col, row) covers [col, col + 1) x [row, row + 1) and has its centre at (col + 0.5, row + 0.5).
    Labels (``obb_corners_px``) use these coordinates."""
    cam = points_world @ extrinsics[:3, :3].T + extrinsics[:3, 3]
    uvw = cam @ intrinsics.T
    with np.errstate(divide="ignore", invalid="ignore"):
        uv = uvw[:, :2] / uvw[:, 2:3]
    return uv, cam[:, 2]


def project(
    points_world: np.ndarray, intrinsics: np.ndarray, extrinsics: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """World points (N, 3) -> pixel coordinates (N, 2) with pixel centres at integers, as
    OpenCV's drawing functions take them (``image_points`` - 0.5), and depth (N,)."""
    uv, depth = image_points(points_world, intrinsics, extrinsics)
    return uv - 0.5, depth


def undistorted_normalised(plane: np.ndarray, intrinsics, distortion) -> np.ndarray:
    """Distorted image-plane points (N, 2), in :func:`image_points`' convention, -> normalised
    camera coordinates (N, 2) (x / z, y / z): OpenCV's lens model (k1, k2, p1, p2, k3) inverted
    by iteration. The one undistortion of the lens maps and of the point clouds."""
    import cv2  # here: most users of this module never undistort

    criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 40, 1e-10)
    return cv2.undistortPointsIter(
        np.asarray(plane, np.float64).reshape(-1, 1, 2),
        np.asarray(intrinsics, np.float64),
        np.asarray(distortion, np.float64),
        None,
        None,
        criteria,
    ).reshape(-1, 2)
