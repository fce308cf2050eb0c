"""Grid planning: robot-radius inflation, start/goal sampling, 8-connected A*, smoothing.

Cells are (row, col) tuples; world points are (x, y) in metres (see the package docstring).
"""

from __future__ import annotations

import heapq
import math

import numpy as np
from scipy import ndimage

from datagen.floorplans.grid import Layout, inflate

SQRT2 = math.sqrt(2.0)
_FOUR = ndimage.generate_binary_structure(2, 1)


class PlanningError(RuntimeError):
    """No valid start/goal pair or path could be found."""


def footprint_collides(
    grid: np.ndarray, resolution: float, x: float, y: float, radius: float
) -> bool:
    """True if a disk of ``radius`` at world (x, y) overlaps an occupied cell or leaves the grid."""
    rows, cols = grid.shape
    if (
        x - radius < 0
        or y - radius < 0
        or x + radius > cols * resolution
        or y + radius > rows * resolution
    ):
        return True
    c0, c1 = int((x - radius) / resolution), int((x + radius) / resolution) + 1
    r0, r1 = int((y - radius) / resolution), int((y + radius) / resolution) + 1
    r, c = np.nonzero(grid[r0:r1, c0:c1])
    if r.size == 0:
        return False
    px = np.clip(x, (c + c0) * resolution, (c + c0 + 1) * resolution)
    py = np.clip(y, (r + r0) * resolution, (r + r0 + 1) * resolution)
    return bool((np.hypot(px - x, py - y) < radius).any())


def clearance(grid: np.ndarray, resolution: float, x: float, y: float, reach: float = 3.0) -> float:
    """Metres from world (x, y) to the nearest occupied cell (its square), looking ``reach``
    metres around; ``reach`` when none is that close. The grid's outside counts as occupied."""
    rows, cols = grid.shape
    edge = min(x, y, cols * resolution - x, rows * resolution - y)
    c0, c1 = max(int((x - reach) / resolution), 0), min(int((x + reach) / resolution) + 1, cols)
    r0, r1 = max(int((y - reach) / resolution), 0), min(int((y + reach) / resolution) + 1, rows)
    r, c = np.nonzero(grid[r0:r1, c0:c1])
    if r.size == 0:
        return float(min(reach, max(edge, 0.0)))
    px = np.clip(x, (c + c0) * resolution, (c + c0 + 1) * resolution)
    py = np.clip(y, (r + r0) * resolution, (r + r0 + 1) * resolution)
    return float(min(np.hypot(px - x, py - y).min(), max(edge, 0.0), reach))


def draw_start_goal(
    rng: np.random.Generator,
    layout: Layout,
    robot_radius: float,
    min_distance: float,
    max_tries: int = 100,
) -> tuple[tuple[int, int], tuple[int, int]]:
    """A start and a goal cell, free in the grid inflated by ``robot_radius``, at least
    ``min_distance`` metres apart in a straight line, and connected (same 4-connected component,
    so A* finds a path). Raises :class:`PlanningError` after ``max_tries`` starts."""
    free = ~inflate(layout.grid, robot_radius, layout.resolution)
    labels, _ = ndimage.label(free, structure=_FOUR)
    cells = np.argwhere(free)
    if len(cells) == 0:
        raise PlanningError(
            f"{layout.family} layout has no free cell for robot radius {robot_radius} m"
        )
    for _ in range(max_tries):
        start = cells[rng.integers(len(cells))]
        same = cells[labels[cells[:, 0], cells[:, 1]] == labels[tuple(start)]]
        far = same[np.hypot(*(same - start).T) * layout.resolution >= min_distance]
        if len(far):
            goal = far[rng.integers(len(far))]
            return (int(start[0]), int(start[1])), (int(goal[0]), int(goal[1]))
    raise PlanningError(
        f"no start/goal pair {min_distance} m apart with a path in the {layout.family} layout "
        f"(robot radius {robot_radius} m) after {max_tries} tries"
    )


def astar(
    occupied: np.ndarray, start: tuple[int, int], goal: tuple[int, int]
) -> list[tuple[int, int]] | None:
    """Shortest 8-connected path of cells (diagonal steps cost sqrt 2 and may not cut an occupied
    corner), octile heuristic; None if the goal cannot be reached."""
    rows, cols = occupied.shape
    blocked = occupied.ravel().tolist()
    s, g = start[0] * cols + start[1], goal[0] * cols + goal[1]
    if blocked[s] or blocked[g]:
        return None
    gr, gc = goal

    def h(i: int) -> float:
        dr, dc = abs(i // cols - gr), abs(i % cols - gc)
        return max(dr, dc) + (SQRT2 - 1.0) * min(dr, dc)

    cost = {s: 0.0}
    parent = {s: -1}
    heap = [(h(s), 0.0, s)]
    steps = [
        (dr, dc, SQRT2 if dr and dc else 1.0) for dr in (-1, 0, 1) for dc in (-1, 0, 1) if dr or dc
    ]
    while heap:
        _, c, i = heapq.heappop(heap)
        if i == g:
            path = []
            while i != -1:
                path.append((i // cols, i % cols))
                i = parent[i]
            return path[::-1]
        if c > cost[i]:
            continue
        r, col = divmod(i, cols)
        for dr, dc, step in steps:
            nr, nc = r + dr, col + dc
            if not (0 <= nr < rows and 0 <= nc < cols):
                continue
            j = nr * cols + nc
            if blocked[j] or (dr and dc and (blocked[r * cols + nc] or blocked[nr * cols + col])):
                continue
            nc_cost = c + step
            if nc_cost < cost.get(j, math.inf):
                cost[j] = nc_cost
                parent[j] = i
                heapq.heappush(heap, (nc_cost + h(j), nc_cost, j))
    return None


def path_to_world(cells, resolution: float) -> np.ndarray:
    """(N, 2) world (x, y) of the cells' centres."""
    a = np.asarray(cells, dtype=float).reshape(-1, 2)
    return np.stack([(a[:, 1] + 0.5) * resolution, (a[:, 0] + 0.5) * resolution], axis=1)


def shortest_path_length_m(cells, resolution: float) -> float:
    """Length in metres of a polyline through the cells' centres."""
    a = np.asarray(cells, dtype=float).reshape(-1, 2)
    return float(np.hypot(*np.diff(a, axis=0).T).sum() * resolution) if len(a) > 1 else 0.0


def line_of_sight(occupied: np.ndarray, a: tuple[int, int], b: tuple[int, int]) -> bool:
    """True if the segment between the centres of cells a and b crosses only free cells
    (sampled every quarter cell, so corners it grazes count)."""
    n = math.ceil(4 * math.hypot(b[0] - a[0], b[1] - a[1])) + 1
    t = np.linspace(0.0, 1.0, n + 1)
    rr = a[0] + 0.5 + t * (b[0] - a[0])
    cc = a[1] + 0.5 + t * (b[1] - a[1])
    for dr in (-0.01, 0.01):  # both sides of a cell boundary the segment runs along
        for dc in (-0.01, 0.01):
            if occupied[np.floor(rr + dr).astype(int), np.floor(cc + dc).astype(int)].any():
                return False
    return True


def smooth_path(occupied: np.ndarray, cells: list[tuple[int, int]]) -> list[tuple[int, int]]:
    """Greedy line-of-sight shortcutting: from each kept cell, walk along the path while the
    next cell is still visible on ``occupied`` (the inflated grid), keep the last visible one."""
    if len(cells) < 3:
        return list(cells)
    out, i = [cells[0]], 0
    while i < len(cells) - 1:
        j = i + 1
        while j + 1 < len(cells) and line_of_sight(occupied, cells[i], cells[j + 1]):
            j += 1
        out.append(cells[j])
        i = j
    return out
