"""Optical flow from depth and poses (datagen/sensing/optical_flow.py) against closed forms:
a camera sliding past a wall, a camera turning, a moving object, a hidden point; the KITTI
encoding round-trips."""

from __future__ import annotations

import numpy as np
import pytest

from datagen.dataset.flow_png import decode_kitti, encode_kitti
from datagen.sensing.optical_flow import flow_to_next

W, H, F = 64, 48, 50.0  # pixels, focal length in pixels
K = np.array([[F, 0, W / 2], [0, F, H / 2], [0, 0, 1]])


def _world_to_camera(position, yaw=0.0) -> np.ndarray:
    """OpenCV camera at ``position`` looking along world +z (turned by ``yaw`` about world y)."""
    c, s = np.cos(yaw), np.sin(yaw)
    camera_to_world = np.eye(4)
    camera_to_world[:3, :3] = [[c, 0, s], [0, 1, 0], [-s, 0, c]]
    camera_to_world[:3, 3] = position
    return np.linalg.inv(camera_to_world)


def test_sliding_past_a_wall_moves_every_pixel_by_focal_times_baseline_over_depth():
    depth = np.full((H, W), 2.0)
    flow, valid = flow_to_next(
        depth, K, _world_to_camera([0, 0, 0]), _world_to_camera([0.1, 0, 0]), depth
    )
    inside = valid[:, 5:-5]
    assert inside.all()  # pixels near the left edge leave the image
    assert np.allclose(flow[valid][:, 0], -F * 0.1 / 2.0) and np.allclose(flow[valid][:, 1], 0.0)
    assert not valid[:, :2].any()


def test_turning_moves_pixels_whatever_their_depth():
    rng = np.random.default_rng(0)
    depth = rng.uniform(1.0, 5.0, (H, W))
    far = np.full((H, W), 1e6)  # nothing in front at t+1: no pixel hidden
    flow, valid = flow_to_next(
        depth, K, _world_to_camera([0, 0, 0]), _world_to_camera([0, 0, 0], 0.02), far
    )
    u = np.arange(W) + 0.5 - W / 2
    expected = F * np.tan(np.arctan(u / F) - 0.02) - u  # a pure turn: depth does not matter
    assert valid.mean() > 0.9  # a turn of 0.02 rad pushes one column or two out of the image
    assert np.allclose(flow[..., 0][valid], np.broadcast_to(expected, (H, W))[valid], atol=1e-4)


def test_a_moving_instance_moves_with_its_motion_and_a_hidden_point_is_invalid():
    depth = np.full((H, W), 3.0)
    instances = np.zeros((H, W), np.uint16)
    instances[10:20, 10:20] = 7
    motion = np.eye(4)
    motion[0, 3] = 0.3  # instance 7 moves 0.3 m along x; the camera stays
    pose = _world_to_camera([0, 0, 0])
    next_depth = depth.copy()
    next_depth[30:40, 30:40] = 1.0  # something came in front of these pixels
    flow, valid = flow_to_next(depth, K, pose, pose, next_depth, instances, {7: motion})
    assert np.allclose(flow[10:20, 10:20, 0], F * 0.3 / 3.0) and valid[12:18, 12:18].all()
    assert np.allclose(flow[instances == 0], 0.0)
    assert not valid[30:40, 30:40].any() and valid[25, 25]


def test_kitti_encoding_round_trips_to_a_64th_of_a_pixel():
    rng = np.random.default_rng(1)
    flow = rng.uniform(-100, 100, (H, W, 2)).astype(np.float32)
    valid = rng.random((H, W)) < 0.7
    decoded, back = decode_kitti(encode_kitti(flow, valid))
    assert np.array_equal(back, valid)
    assert np.abs(decoded - flow).max() <= 1 / 128 + 1e-4  # rounding to 1/64, float32
    assert encode_kitti(flow, valid).dtype == np.uint16


@pytest.mark.parametrize("bad", [0.0, -1.0])
def test_pixels_without_depth_are_invalid(bad):
    depth = np.full((H, W), 2.0)
    depth[0, 0] = bad
    _, valid = flow_to_next(
        depth, K, _world_to_camera([0, 0, 0]), _world_to_camera([0, 0, 0]), np.full((H, W), 2.0)
    )
    assert not valid[0, 0] and valid[1, 1]
