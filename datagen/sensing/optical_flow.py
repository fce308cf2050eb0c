"""Optical flow to the next frame from depth and poses (as TartanAir computes it), with a validity
mask, and its KITTI encoding.

Pixel (col, row) is the point at its centre, (col + 0.5, row + 0.5) in image coordinates (origin
at the top-left corner, as the intrinsics K). It is back-projected with its depth at frame t
(metres along the optical axis) through K and the camera pose at t, moved with its instance if
that instance moves (``motions``: a 4x4 world transform from t to t+1 per instance id; the
rest of the world is static), and projected through the camera pose and K at t+1. The flow is
the projected position less the original, in pixels (x right, y down). A pixel is valid where it
has depth at t, lands inside the image in front of the camera at t+1, and is not hidden there:
its depth at t+1 is at most ``OCCLUSION_TOLERANCE`` (relative) behind the depth rendered at t+1
at the pixel it lands in.

Stored as KITTI's 16-bit PNG: :mod:`datagen.dataset.flow_png`.
"""

from __future__ import annotations

import numpy as np

OCCLUSION_TOLERANCE = 0.02  # relative depth: farther than this behind what t+1 sees is hidden


def flow_to_next(
    depth: np.ndarray,
    intrinsics: np.ndarray,
    world_to_camera: np.ndarray,
    next_world_to_camera: np.ndarray,
    next_depth: np.ndarray,
    instances: np.ndarray | None = None,
    motions: dict[int, np.ndarray] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """(flow (H, W, 2) float32 pixels, valid (H, W) bool). ``depth`` and ``next_depth`` in
    metres (0 = no surface); the poses are 4x4 world -> OpenCV camera transforms."""
    height, width = depth.shape
    rows, cols = np.mgrid[0:height, 0:width]
    uv1 = np.stack([cols + 0.5, rows + 0.5, np.ones_like(depth)], axis=-1).reshape(-1, 3)
    rays = uv1 @ np.linalg.inv(intrinsics).T  # z = 1
    camera_points = rays * depth.reshape(-1, 1)
    camera_to_world = np.linalg.inv(world_to_camera)
    world = camera_points @ camera_to_world[:3, :3].T + camera_to_world[:3, 3]
    if instances is not None and motions:
        ids = instances.reshape(-1)
        for instance, motion in motions.items():
            mine = ids == instance
            world[mine] = world[mine] @ motion[:3, :3].T + motion[:3, 3]
    seen = world @ next_world_to_camera[:3, :3].T + next_world_to_camera[:3, 3]
    z = seen[:, 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        projected = (seen @ intrinsics.T)[:, :2] / z[:, None]
    flow = (projected - uv1[:, :2]).reshape(height, width, 2)
    col, row = np.floor(projected[:, 0]), np.floor(projected[:, 1])
    inside = (z > 1e-6) & (col >= 0) & (col < width) & (row >= 0) & (row < height)
    valid = inside & (depth.reshape(-1) > 0)
    target = np.zeros(len(z))
    target[valid] = next_depth[row[valid].astype(int), col[valid].astype(int)]
    valid &= (target > 0) & (z <= target * (1 + OCCLUSION_TOLERANCE))
    flow = np.where(valid.reshape(height, width, 1), flow, 0.0)
    return flow.astype(np.float32), valid.reshape(height, width)
