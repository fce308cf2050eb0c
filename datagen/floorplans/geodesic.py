"""The shortest path any robot can drive between two points of a floor plan: a true lower bound
for SPL.

A disk robot of radius r whose centre stays where the disk touches no occupied cell moves in the
plan's free space eroded by r. Its shortest path there bends only at corners of the eroded
obstacles, so it is the shortest path of the visibility graph over those corners (start, goal and
every convex corner of the occupied cells). The eroded plan is rasterised with a slightly smaller
radius than the robot's (:func:`lower_bound_grid`), so every position a collision-free robot takes
lies in a free cell, and visibility is tested by sampling each segment finely: both make the
computed length, if anything, shorter than the truth, never longer, so a collision-free path
from start to goal is never shorter than it (``tests/navigation/test_geodesic.py``).
"""

from __future__ import annotations

import heapq
import math

import numpy as np

from datagen.floorplans.grid import inflate

SAMPLES_PER_CELL = 4  # visibility samples per cell length along a segment


def lower_bound_grid(grid: np.ndarray, resolution: float, radius: float, step: float) -> np.ndarray:
    """Occupied cells for the centre of a disk of ``radius`` metres: dilated by the radius less
    half a cell's diagonal (a centre in a cell lies at most that far from the cell's centre) and
    half of ``step`` (the longest straight move between two recorded positions)."""
    shrunk = radius - resolution * math.sqrt(2) / 2 - step / 2
    return inflate(grid, shrunk, resolution) if shrunk > 0 else grid.copy()


def convex_corners(occupied: np.ndarray) -> np.ndarray:
    """(n, 2) cell-corner coordinates (x = col, y = row; in cells) where exactly one of the
    four cells meeting there is occupied (outside the grid counts as occupied): the corners a
    shortest path may bend round."""
    padded = np.pad(occupied, 1, constant_values=True).astype(np.int8)
    # quad[y, x]: occupied cells around corner (x, y), which touches cells (y-1|y, x-1|x)
    quad = padded[:-1, :-1] + padded[:-1, 1:] + padded[1:, :-1] + padded[1:, 1:]
    rows, cols = np.nonzero(quad == 1)
    return np.stack([cols, rows], axis=1).astype(float)


def _blocked(occupied: np.ndarray, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    outside = (rows < 0) | (cols < 0) | (rows >= occupied.shape[0]) | (cols >= occupied.shape[1])
    hit = outside.copy()
    inside = ~outside
    hit[inside] = occupied[rows[inside], cols[inside]]
    return hit


def _visible(occupied: np.ndarray, a: np.ndarray, b: np.ndarray) -> bool:
    """True unless a sample of segment a-b (cell coordinates, x = col) lies in occupied space:
    inside an occupied cell, or on a boundary every cell of which is occupied (a sample on the
    boundary of a free cell is free: grazing a corner or running along a wall is allowed)."""
    n = max(int(np.ceil(np.hypot(*(b - a)) * SAMPLES_PER_CELL)), 1)
    t = (np.arange(n) + 0.5) / n
    points = a + t[:, None] * (b - a)
    blocked = np.ones(len(points), bool)
    for dx in (-1e-9, 1e-9):  # the cells on either side of a boundary the sample lies on
        for dy in (-1e-9, 1e-9):
            cells = np.floor(points + np.array([dx, dy])).astype(int)
            blocked &= _blocked(occupied, cells[:, 1], cells[:, 0])
    return not blocked.any()


def shortest_length(
    occupied: np.ndarray, resolution: float, start: tuple[float, float], goal: tuple[float, float]
) -> float:
    """Metres of the shortest path from world ``start`` to ``goal`` (x, y) through the free
    cells of ``occupied`` (A* on the visibility graph, straight-line heuristic); inf when the
    goal cannot be reached."""
    points = np.vstack([np.asarray([start, goal], float) / resolution, convex_corners(occupied)])
    n = len(points)
    to_goal = np.hypot(*(points - points[1]).T)
    best = np.full(n, np.inf)
    best[0] = 0.0
    done = np.zeros(n, bool)
    heap = [(to_goal[0], 0.0, 0)]
    while heap:
        _, d, i = heapq.heappop(heap)
        if done[i]:
            continue
        if i == 1:
            return d * resolution
        done[i] = True
        gaps = np.hypot(*(points - points[i]).T)
        for j in np.argsort(gaps):
            if done[j] or d + gaps[j] >= best[j]:
                continue
            if _visible(occupied, points[i], points[j]):
                best[j] = d + gaps[j]
                heapq.heappush(heap, (best[j] + to_goal[j], best[j], int(j)))
    return math.inf
