"""A camera's record in a sample's metadata, one constructor for every family: image size, lens,
clip planes, where the camera is (the family's mount fields), the OpenCV convention and the
depth PNG's scale."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from datagen.scene_values.rounding import rounded
from datagen.sensing.render import DEPTH_SCALE


def camera_record(
    width: int,
    height: int,
    fovy: float,
    near: float,
    far: float,
    intrinsics: np.ndarray,
    mount: Mapping[str, Any],
) -> dict[str, Any]:
    """``fovy`` in radians (stored in degrees), ``near``/``far`` in metres, ``intrinsics`` K
    (3, 3) in pixels; ``mount``: the fields that place the camera, in order (the tabletop's
    ``extrinsics_world_to_camera``, a ground robot's ``camera_in_robot``, a drone's
    ``camera_in_body``, ...). Numbers are stored to 6 decimals."""
    return {
        "width": int(width),
        "height": int(height),
        "fovy_deg": round(math.degrees(fovy), 6),
        "near": round(float(near), 6),
        "far": round(float(far), 6),
        "intrinsics": rounded(intrinsics),
        **mount,
        "convention": "opencv",
        "depth_scale": DEPTH_SCALE,
    }
