"""Pictures of an aerial episode (pure: the volume and the flights in, RGB images out): the plan
seen from above and the volume seen from the side, with each drone's planned path (its
waypoints, thin) and flown trajectory (thick), its start (circle) and goal (cross).

Top-down: a voxel column's grey is how much of its height is solid (black: floor to ceiling).
Side: looking along +y (x to the right, z up), a voxel's grey is how much of the depth is solid.
``PIXELS_PER_METRE`` pixels a metre, the floor plan's origin at the bottom-left corner.
"""

from __future__ import annotations

import cv2
import numpy as np

from datagen.families.aerial.fleet import Agent
from datagen.families.aerial.volumes import Volume

PIXELS_PER_METRE = 60
COLOURS = [  # RGB, one per drone
    (230, 25, 75),
    (60, 180, 75),
    (0, 130, 200),
    (245, 130, 48),
    (145, 30, 180),
    (70, 240, 240),
    (240, 50, 230),
    (128, 128, 0),
]


def _canvas(fraction: np.ndarray) -> np.ndarray:
    """(H, W, 3) uint8 from a solid fraction per cell (rows = up the picture's y axis)."""
    grey = (235 - 200 * fraction).astype(np.uint8)[::-1]
    big = cv2.resize(grey, None, fx=1, fy=1, interpolation=cv2.INTER_NEAREST)
    return np.repeat(big[..., None], 3, axis=2)


def _draw(
    picture: np.ndarray, agents: list[Agent], axes: tuple[int, int], resolution: float
) -> np.ndarray:
    """Paths in world axes ``axes`` (0 x, 1 y, 2 z) onto ``picture`` scaled to metres."""
    scale, height = PIXELS_PER_METRE, picture.shape[0]

    def to_px(p: np.ndarray) -> np.ndarray:
        return np.round(
            np.stack([p[:, axes[0]] * scale, height - p[:, axes[1]] * scale], 1)
        ).astype(np.int32)

    for k, agent in enumerate(agents):
        colour = COLOURS[k % len(COLOURS)]
        cv2.polylines(picture, [to_px(agent.flight.waypoints)], False, colour, 1, cv2.LINE_AA)
        time = np.linspace(0.0, agent.flight.duration, 400)
        cv2.polylines(
            picture, [to_px(agent.flight.path.evaluate(time))], False, colour, 3, cv2.LINE_AA
        )
        start, goal = to_px(agent.start[None])[0], to_px(agent.goal[None])[0]
        cv2.circle(picture, tuple(int(v) for v in start), 6, colour, 2, cv2.LINE_AA)
        cv2.drawMarker(picture, tuple(int(v) for v in goal), colour, cv2.MARKER_CROSS, 14, 2)
    return picture


def _projected(
    volume: Volume, agents: list[Agent], axis: int, shown: tuple[int, int]
) -> np.ndarray:
    fraction = volume.occupancy.mean(axis=axis)
    scale = PIXELS_PER_METRE * volume.resolution
    picture = cv2.resize(
        _canvas(fraction), None, fx=scale, fy=scale, interpolation=cv2.INTER_NEAREST
    )
    return _draw(picture, agents, shown, volume.resolution)


def top_down(volume: Volume, agents: list[Agent]) -> np.ndarray:
    """(H, W, 3) uint8 RGB: x to the right, y up."""
    return _projected(volume, agents, 0, (0, 1))


def side_view(volume: Volume, agents: list[Agent]) -> np.ndarray:
    """(H, W, 3) uint8 RGB: x to the right, z up (looking along +y)."""
    return _projected(volume, agents, 1, (0, 2))
