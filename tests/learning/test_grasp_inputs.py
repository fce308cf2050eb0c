"""What a grasp model sees of a candidate: the depth crop around the grasp and its features."""

from __future__ import annotations

import numpy as np
import pytest

from datagen.grasp_model.inputs import (
    CROP_RANGE_M,
    CROP_SIDE_M,
    GRASP_FEATURES,
    DepthView,
    grasp_batch,
    grasp_inputs,
)

F = 300.0  # pixels, focal length
W, H = 320, 240


def looking_down(depth_m: np.ndarray, robot_base: np.ndarray | None = None) -> DepthView:
    """A camera at the world origin looking along +z (world = camera frame), over a depth map;
    the robot's base at ``robot_base`` (default: the world origin)."""
    intrinsics = np.array([[F, 0, W / 2], [0, F, H / 2], [0, 0, 1]])
    base = np.eye(4) if robot_base is None else robot_base
    return DepthView(np.round(depth_m * 1000).astype(np.uint16), intrinsics, np.eye(4), base)


def grasp_at(x: float, y: float, z: float, closing_deg: float) -> np.ndarray:
    """A TCP pose at (x, y, z) approaching along +z, closing at ``closing_deg`` in the image."""
    a = np.deg2rad(closing_deg)
    closing = np.array([np.cos(a), np.sin(a), 0.0])
    approach = np.array([0.0, 0.0, 1.0])
    pose = np.eye(4)
    pose[:3, :3] = np.column_stack([np.cross(closing, approach), closing, approach])
    pose[:3, 3] = (x, y, z)
    return pose


def table_with_bar(distance: float, bar_deg: float, length=0.1, width=0.02) -> np.ndarray:
    """Depth of a table ``distance`` away with a bar 3 cm high through the image centre."""
    v, u = np.mgrid[0:H, 0:W]
    x, y = (u - W / 2 + 0.5) * distance / F, (v - H / 2 + 0.5) * distance / F
    a = np.deg2rad(bar_deg)
    along, across = x * np.cos(a) + y * np.sin(a), -x * np.sin(a) + y * np.cos(a)
    bar = (np.abs(along) < length / 2) & (np.abs(across) < width / 2)
    return np.where(bar, distance - 0.03, distance)


def test_the_crop_is_centred_on_the_grasp_in_metres_relative_to_its_depth():
    view = looking_down(table_with_bar(0.5, 0.0))
    crop, features = grasp_inputs(view, grasp_at(0, 0, 0.47, 0.0), 0.05, 32)
    assert crop.shape == (32, 32) and crop.dtype == np.float32
    assert crop[16, 16] == pytest.approx(0.0, abs=1e-3)  # the bar's top is the grasp's depth
    assert crop[0, 0] == pytest.approx(0.03, abs=1e-3)  # the table, 3 cm behind it
    camera_frame, base_frame = [0.47, 0.05, 0, 0, 1, 1, 0, 0], [0, 0, 0.47, 0, 0, 1]
    assert features.tolist() == pytest.approx(camera_frame + base_frame, abs=1e-6)


def test_the_grasp_is_told_in_the_robot_base_frame_too():
    """Where the arm must reach: the centre and the approach as the base sees them, whatever
    the camera's pose."""
    base = np.eye(4)
    base[:3, :3] = [[0, -1, 0], [1, 0, 0], [0, 0, 1]]  # turned 90 degrees about z
    base[:3, 3] = (0.5, 0.0, 0.1)
    view = looking_down(table_with_bar(0.5, 0.0), base)
    _, features = grasp_inputs(view, grasp_at(0.1, 0.2, 0.47, 0.0), 0.05, 32)
    # world (0.1, 0.2, 0.47) is (0.2, 0.4, 0.37) from the base; world +z is the base's +z
    assert features[8:].tolist() == pytest.approx([0.2, 0.4, 0.37, 0, 0, 1], abs=1e-6)
    assert features[:8].tolist() == pytest.approx(
        grasp_inputs(
            looking_down(table_with_bar(0.5, 0.0)), grasp_at(0.1, 0.2, 0.47, 0.0), 0.05, 32
        )[1][:8].tolist()
    )


@pytest.mark.parametrize("angle", [0.0, 37.0, 90.0, 135.0])
def test_the_crop_turns_with_the_closing_axis(angle):
    """A bar along the closing axis lies left-right in the crop whatever its angle in the
    image."""
    reference, _ = grasp_inputs(
        looking_down(table_with_bar(0.5, 0.0)), grasp_at(0, 0, 0.47, 0), 0.05, 32
    )
    turned, _ = grasp_inputs(
        looking_down(table_with_bar(0.5, angle)), grasp_at(0, 0, 0.47, angle), 0.05, 32
    )
    assert np.mean(np.abs(turned - reference) < 1e-3) > 0.95


def test_a_crop_spans_the_same_metres_at_any_distance():
    near, _ = grasp_inputs(
        looking_down(table_with_bar(0.4, 0.0)), grasp_at(0, 0, 0.37, 0), 0.05, 32
    )
    far, _ = grasp_inputs(looking_down(table_with_bar(0.9, 0.0)), grasp_at(0, 0, 0.87, 0), 0.05, 32)
    bar_share = 0.1 / CROP_SIDE_M  # the bar's length over the crop's side
    for crop in (near, far):
        assert np.mean(crop[16] < 0.015) == pytest.approx(bar_share, abs=0.07)


def test_swapping_the_fingers_changes_nothing():
    view = looking_down(table_with_bar(0.5, 20.0))
    one = grasp_inputs(view, grasp_at(0.01, 0, 0.47, 20.0), 0.05, 32)
    swapped = grasp_inputs(view, grasp_at(0.01, 0, 0.47, 200.0), 0.05, 32)
    assert np.array_equal(one[0], swapped[0]) and np.allclose(one[1], swapped[1], atol=1e-6)


def test_pixels_without_a_reading_and_a_grasp_behind_the_camera():
    depth = table_with_bar(0.5, 0.0)
    depth[:, W // 2 :] = 0.0  # no reading on the right half
    crop, _ = grasp_inputs(looking_down(depth), grasp_at(0, 0, 0.47, 0), 0.05, 16)
    assert np.all(crop[:, 12:] == np.float32(CROP_RANGE_M))
    crop, _ = grasp_inputs(looking_down(depth), grasp_at(0, 0, -0.2, 0), 0.05, 16)
    assert np.all(crop == np.float32(CROP_RANGE_M))


def test_a_batch_stacks_the_candidates():
    view = looking_down(table_with_bar(0.5, 0.0))
    grasps = [(grasp_at(0, 0, 0.47, a), 0.04) for a in (0, 45, 90)]
    crops, features = grasp_batch(view, grasps, 24)
    assert crops.shape == (3, 1, 24, 24) and features.shape == (3, GRASP_FEATURES)
    assert crops.dtype == features.dtype == np.float32
