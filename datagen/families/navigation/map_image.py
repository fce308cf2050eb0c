"""Top-down pictures of an episode, drawn with OpenCV.

Both images keep the grid's orientation: pixel row r shows grid row r (world y grows downwards in
the picture, x to the right), ``scale`` pixels per cell.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from datagen.families.navigation.episode import Episode
from datagen.floorplans.grid import fill

FREE, INFLATED, WALL, OBSTACLE, DOOR = (
    (255, 255, 255),
    (225, 225, 225),
    (60, 60, 60),
    (60, 110, 170),
    (200, 160, 90),
)  # BGR
PLANNED, DRIVEN, START, GOAL, FRAME = (
    (230, 140, 30),
    (40, 40, 220),
    (40, 170, 40),
    (0, 200, 255),
    (200, 60, 160),
)  # BGR


def occupancy_image(grid: np.ndarray) -> np.ndarray:
    """The raw occupancy grid, one pixel per cell: 255 occupied, 0 free (uint8)."""
    return np.where(grid, 255, 0).astype(np.uint8)


def _plan(layout, inflated: np.ndarray, scale: int) -> np.ndarray:
    """BGR picture of free space, the inflated margin, walls, obstacles and doors."""
    obstacles = np.zeros_like(layout.grid)
    for rect in layout.obstacles:
        fill(obstacles, rect, layout.resolution, True)
    doors = np.zeros_like(layout.grid)
    for rect in layout.doors:
        fill(doors, rect, layout.resolution, True)
    image = np.empty((*layout.grid.shape, 3), np.uint8)
    image[:] = FREE
    image[inflated] = INFLATED
    image[doors & ~layout.grid] = DOOR
    image[layout.grid] = WALL
    image[obstacles] = OBSTACLE
    return cv2.resize(image, None, fx=scale, fy=scale, interpolation=cv2.INTER_NEAREST)


def episode_map(
    episode: Episode, inflated: np.ndarray, frame_steps: list[int], scale: int = 3
) -> np.ndarray:
    """BGR picture: free space, the inflated margin, walls, obstacles and doors; the planned
    (smoothed) path, the driven trajectory with a dot per rendered frame, start and goal."""
    image = _plan(episode.layout, inflated, scale)
    _draw_episode(image, episode, scale, frame_steps)
    return image


def fleet_map(layout, inflated: np.ndarray, episodes: list[Episode], scale: int = 3) -> np.ndarray:
    """The same picture with every robot's planned path, trajectory, start and goal."""
    image = _plan(layout, inflated, scale)
    for episode in episodes:
        _draw_episode(image, episode, scale, [])
    return image


def _draw_episode(image: np.ndarray, episode: Episode, scale: int, frame_steps: list[int]) -> None:
    px = scale / episode.layout.resolution  # pixels per metre

    def to_px(points) -> np.ndarray:
        return np.rint(np.asarray(points, float).reshape(-1, 2) * px).astype(np.int32)

    cv2.polylines(image, [to_px(episode.path)], False, PLANNED, 2, cv2.LINE_AA)
    poses = episode.trajectory.poses
    cv2.polylines(image, [to_px(poses[:, :2])], False, DRIVEN, 1, cv2.LINE_AA)
    for step in frame_steps:
        cv2.circle(image, tuple(to_px(poses[step, :2])[0]), 2, FRAME, -1, cv2.LINE_AA)
    x, y, yaw = episode.start
    start = to_px([x, y])[0]
    tip = to_px([x + 0.5 * math.cos(yaw), y + 0.5 * math.sin(yaw)])[0]
    cv2.circle(image, tuple(start), max(3, int(0.2 * px)), START, -1, cv2.LINE_AA)
    cv2.arrowedLine(image, tuple(start), tuple(tip), START, 2, cv2.LINE_AA, tipLength=0.3)
    cv2.drawMarker(
        image, tuple(to_px(episode.goal)[0]), GOAL, cv2.MARKER_STAR, max(9, int(0.5 * px)), 2
    )
