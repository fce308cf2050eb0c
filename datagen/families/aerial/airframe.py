"""What planning and the world ask of a drone's frame, whatever the airframe
(``datagen.registries.AIRFRAMES``): its shape from the drawn span, its parts' meshes, where its
cameras sit, and how far from its centre of mass any of them reaches (pure: no simulator)."""

from __future__ import annotations

from typing import Any

import numpy as np
import trimesh

from datagen.plugin_records import Airframe
from datagen.registry import resolve


def drone_shape(airframe: Airframe, span: float) -> Any:
    """The airframe's shape at ``span`` metres."""
    return resolve(airframe.shape)(span)


def drone_parts(airframe: Airframe, shape: Any) -> dict[str, trimesh.Trimesh]:
    """One mesh per painted part, in the body frame."""
    return resolve(airframe.parts)(shape)


def camera_mounts(
    airframe: Airframe, shape: Any, shift: tuple[float, float] = (0.0, 0.0)
) -> dict[str, np.ndarray]:
    """Where its ``forward`` and ``down`` cameras sit in the body frame (metres)."""
    return resolve(airframe.mounts)(shape, shift)


def bounding_radius(airframe: Airframe, shape: Any) -> float:
    """Metres: the farthest vertex of any part from the centre of mass."""
    parts = drone_parts(airframe, shape).values()
    return float(max(np.linalg.norm(m.vertices, axis=1).max() for m in parts))


def right_camera(forward: np.ndarray, baseline: float) -> np.ndarray:
    """Where a stereo pair's right camera sits in the body frame: ``baseline`` metres to the
    right of the forward camera at ``forward`` (along -y: a tilt about y keeps the axes
    parallel)."""
    return np.asarray(forward, float) - np.array([0.0, baseline, 0.0])


def camera_reach(airframe: Airframe, shape: Any, baseline: float) -> float:
    """Metres from the centre of mass to the farthest place a camera may sit: the forward mount
    shifted as far as its randomisation goes, and a right camera ``baseline`` beside it."""
    mounts = [
        camera_mounts(airframe, shape, (y, z))["forward"] for y in (-1.0, 1.0) for z in (-1.0, 1.0)
    ]
    return float(max(np.linalg.norm(right_camera(m, baseline)) for m in mounts))
