"""Drop-pose randomiser: where each object starts above the tray before physics settles it."""

from __future__ import annotations

from typing import Any

import numpy as np

from datagen.config.sections import ObjectsConfig
from datagen.geometry import random_quaternion


def draw_drop_poses(
    rng: np.random.Generator,
    cfg: ObjectsConfig,
    count: int,
    tray_floor_top: tuple[float, float, float],
    tray_inner_half: tuple[float, float],
) -> list[dict[str, Any]]:
    """Positions over the tray's inner area (metres, world frame; ``tray_floor_top``: the
    centre of its floor's top face), uniform orientations.

    Objects start stacked in height, one largest-size apart, so no two start interpenetrating.
    """
    margin = cfg.size[1] / 2
    half_x = max(tray_inner_half[0] - margin, 0.0)
    half_y = max(tray_inner_half[1] - margin, 0.0)
    poses = []
    for i in range(count):
        x = tray_floor_top[0] + rng.uniform(-half_x, half_x)
        y = tray_floor_top[1] + rng.uniform(-half_y, half_y)
        z = tray_floor_top[2] + cfg.size[1] + rng.uniform(*cfg.drop_height) + i * cfg.size[1] * 1.05
        poses.append(
            {"position": [float(x), float(y), float(z)], "quat_wxyz": random_quaternion(rng)}
        )
    return poses
