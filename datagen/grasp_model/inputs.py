"""What a grasp model sees of one candidate: a depth crop centred on the grasp, turned so the
fingers close left-right, as GQ-CNN does, and fourteen numbers on the grasp itself.

The crop covers ``CROP_SIDE_M`` of the scene at the grasp centre's depth (so it shows the same
extent of the object whatever the camera's resolution or distance), sampled to ``size`` x
``size`` pixels by nearest neighbour from the view's depth image as it is stored (uint16
millimetres); each pixel holds the scene's depth minus the grasp centre's, in metres, clipped to
``+-CROP_RANGE_M`` (a pixel without a reading holds ``+CROP_RANGE_M``: far behind the grasp).
The features: the grasp centre's depth in metres, the opening width in metres, then the approach
and the closing axes in the camera frame (OpenCV: x right, y down, z forward), the closing axis
signed to point right in the image (the fingers are alike, so a grasp and its twin with the
fingers swapped give the same inputs); then the grasp centre (metres) and the approach axis in the
robot's base frame. The crop shows the object but not where it lies from the arm; whether the
arm reaches a grasp depends on that, and on a wrist camera whose pose is randomised per scene
the camera frame does not tell it."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import cv2
import numpy as np

CROP_SIDE_M = 0.16  # metres of the scene a crop spans at the grasp centre's depth
CROP_RANGE_M = 0.1  # metres: depths relative to the grasp centre are clipped to +-this
# centre depth, width, approach (3), closing (3) in the camera frame; centre (3), approach (3)
# in the robot's base frame
GRASP_FEATURES = 14
MIN_DEPTH_M = 0.01  # a grasp centre nearer than this to the camera is not in its view
DEPTH_SCALE = 0.001  # metres per unit of a stored depth image (uint16 millimetres)


@dataclass(frozen=True)
class DepthView:
    """One camera's depth image and calibration, and the pose of the robot's base, as a
    campaign sample stores them."""

    depth_mm: np.ndarray  # (H, W) uint16 millimetres, 0 = no reading
    intrinsics: np.ndarray  # (3, 3) pixels, OpenCV convention
    extrinsics: np.ndarray  # (4, 4) world -> camera, OpenCV convention
    robot_base: np.ndarray  # (4, 4) the robot's base pose in the world (base -> world)

    @cached_property
    def metres(self) -> np.ndarray:
        """(H, W) float32 depth in metres, +inf where there is no reading: computed once per
        view, however many candidates are cropped from it."""
        depth = self.depth_mm.astype(np.float32) * np.float32(DEPTH_SCALE)
        depth[self.depth_mm == 0] = np.inf
        return depth

    @classmethod
    def from_record(
        cls, depth_mm: np.ndarray, camera: Mapping[str, Any], robot: Mapping[str, Any]
    ) -> DepthView:
        """From a stored depth image, its view record's ``camera`` entry and the sample's
        ``robot`` record."""
        return cls(
            np.asarray(depth_mm),
            np.asarray(camera["intrinsics"], float),
            np.asarray(camera["extrinsics_world_to_camera"], float),
            np.asarray(robot["base_pose"]["matrix"], float),
        )


def grasp_inputs(
    view: DepthView, pose_world: np.ndarray, width: float, size: int
) -> tuple[np.ndarray, np.ndarray]:
    """The (``size``, ``size``) float32 crop and the (``GRASP_FEATURES``,) float32 features of
    the grasp whose TCP pose is ``pose_world`` (4x4; z approach, y closing) opened ``width``
    metres, seen in ``view``."""
    pose = np.asarray(pose_world, float)
    rotation, translation = view.extrinsics[:3, :3], view.extrinsics[:3, 3]
    centre = rotation @ pose[:3, 3] + translation
    approach = rotation @ pose[:3, 2]
    closing = rotation @ pose[:3, 1]
    if (closing[0], closing[1]) < (0.0, 0.0):  # the fingers are alike: one sign per grasp
        closing = -closing
    to_base = view.robot_base[:3, :3].T  # world -> base rotation
    in_base = to_base @ (pose[:3, 3] - view.robot_base[:3, 3]), to_base @ pose[:3, 2]
    features = np.array(
        [centre[2], width, *approach, *closing, *np.concatenate(in_base)], np.float32
    )
    if centre[2] < MIN_DEPTH_M:
        return np.full((size, size), CROP_RANGE_M, np.float32), features
    fx, fy, cx, cy = (view.intrinsics[0, 0], view.intrinsics[1, 1], *view.intrinsics[:2, 2])
    u, v = fx * centre[0] / centre[2] + cx, fy * centre[1] / centre[2] + cy
    angle = np.arctan2(fy * closing[1], fx * closing[0])  # the closing axis in the image
    scale = size / (fx * CROP_SIDE_M / centre[2])  # crop pixels per image pixel
    cos, sin = scale * np.cos(angle), scale * np.sin(angle)
    half = (size - 1) / 2
    # image -> crop: turn by -angle about (u, v), scale, put (u, v) at the crop's centre
    warp = np.array(
        [[cos, sin, half - cos * u - sin * v], [-sin, cos, half + sin * u - cos * v]], np.float64
    )
    crop = cv2.warpAffine(
        view.metres,
        warp,
        (size, size),
        flags=cv2.INTER_NEAREST,
        borderMode=cv2.BORDER_CONSTANT,
        borderValue=(float("inf"),),
    )
    crop = np.clip(crop - np.float32(centre[2]), -CROP_RANGE_M, CROP_RANGE_M)
    return crop.astype(np.float32), features


def grasp_batch(
    view: DepthView, grasps: Sequence[tuple[np.ndarray, float]], size: int
) -> tuple[np.ndarray, np.ndarray]:
    """The model's two inputs for several (pose_world, width) grasps seen in one view:
    crops (N, 1, size, size) and features (N, GRASP_FEATURES), float32."""
    pairs = [grasp_inputs(view, pose, width, size) for pose, width in grasps]
    crops = np.stack([crop for crop, _ in pairs])[:, None]
    return crops, np.stack([features for _, features in pairs])
