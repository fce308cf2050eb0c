"""The :class:`Layout` record, rectangle rasterisation and clutter placement."""

from __future__ import annotations

import logging
import math
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
from scipy import ndimage

Rect = tuple[float, float, float, float]  # (x0, y0, x1, y1) in world metres

log = logging.getLogger(__name__)
_FOUR = ndimage.generate_binary_structure(2, 1)


@dataclass
class Layout:
    """A 2-D floor plan. See the package docstring for the grid/world convention."""

    grid: np.ndarray  # bool (rows, cols), True = occupied (walls and obstacles)
    resolution: float  # metres per cell
    family: str
    walls: list[Rect]  # occupied area without the obstacles, as disjoint rectangles
    doors: list[Rect] = field(default_factory=list)  # openings cut through walls
    obstacles: list[Rect] = field(default_factory=list)  # clutter boxes
    params: dict[str, Any] = field(default_factory=dict)  # sampled values + config, JSON-able

    @property
    def size_m(self) -> tuple[float, float]:
        return self.grid.shape[1] * self.resolution, self.grid.shape[0] * self.resolution


def cell_span(a: float, b: float, res: float) -> tuple[int, int]:
    """Cells [i, j) whose centres lie inside [a, b]."""
    return int(np.ceil(a / res - 0.5 - 1e-9)), int(np.floor(b / res - 0.5 + 1e-9)) + 1


def fill(grid: np.ndarray, rect: Rect, res: float, value: bool) -> None:
    c0, c1 = cell_span(rect[0], rect[2], res)
    r0, r1 = cell_span(rect[1], rect[3], res)
    grid[max(r0, 0) : max(r1, 0), max(c0, 0) : max(c1, 0)] = value


def grid_to_rects(occupied: np.ndarray, res: float) -> list[Rect]:
    """Disjoint rectangles covering ``occupied``: row runs merged with identical runs below."""
    rects: list[list[int]] = []  # [c0, c1, r0, r1)
    open_runs: dict[tuple[int, int], list[int]] = {}
    for r in range(occupied.shape[0] + 1):
        runs: set[tuple[int, int]] = set()
        if r < occupied.shape[0]:
            row = np.concatenate([[False], occupied[r], [False]]).astype(np.int8)
            edges = np.flatnonzero(np.diff(row))
            runs = {(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2], strict=True)}
        for run in list(open_runs):
            if run in runs:
                open_runs[run][3] = r + 1
            else:
                rects.append(open_runs.pop(run))
        for run in runs - set(open_runs):
            open_runs[run] = [run[0], run[1], r, r + 1]
    rects.sort(key=lambda q: (q[2], q[0]))
    return [(c0 * res, r0 * res, c1 * res, r1 * res) for c0, c1, r0, r1 in rects]


def disk(radius_m: float, resolution: float) -> np.ndarray:
    """Offsets of the cells whose square comes closer than ``radius_m`` to a cell's centre."""
    n = math.ceil(radius_m / resolution + 0.5)
    d = np.abs(np.arange(-n, n + 1))
    gap = np.maximum(d - 0.5, 0.0) * resolution  # centre-to-nearest-edge distance per axis
    return np.hypot(gap[:, None], gap[None, :]) < radius_m


def inflate(grid: np.ndarray, radius_m: float, resolution: float) -> np.ndarray:
    """Occupied grid for a disk robot's centre: a cell is free only if a disk of ``radius_m``
    at its centre touches no occupied cell (exact at cell centres). Outside the grid counts as
    occupied."""
    return ndimage.binary_dilation(grid, structure=disk(radius_m, resolution), border_value=1)


def free_components(grid: np.ndarray, clearance_m: float, res: float) -> int:
    """Number of 4-connected components of free space, after inflation by ``clearance_m``."""
    occupied = inflate(grid, clearance_m, res) if clearance_m > 0 else grid
    return int(ndimage.label(~occupied, structure=_FOUR)[1])


@dataclass
class ClutterParams:
    count: tuple[int, int] = (2, 6)  # obstacles requested, inclusive range
    size: tuple[float, float] = (0.3, 0.7)  # box side lengths, metres
    clearance: float = 0.35  # robot radius + margin kept passable between obstacles, metres
    max_tries: int = 30  # positions tried per obstacle before it is dropped


def add_clutter(rng: np.random.Generator, layout: Layout, params: ClutterParams) -> Layout:
    """Place axis-aligned boxes in free space; an obstacle that would split the free space
    (raw, or inflated by ``clearance``) is retried elsewhere, then dropped. What happened is
    recorded in ``layout.params["clutter"]``."""
    res, grid = layout.resolution, layout.grid
    before = (free_components(grid, 0.0, res), free_components(grid, params.clearance, res))
    requested = int(rng.integers(params.count[0], params.count[1] + 1))
    free_cells = np.argwhere(~grid)
    report: dict[str, Any] = {
        "requested": requested,
        "placed": 0,
        "dropped": 0,
        "rejected_positions": 0,
    }
    for _ in range(requested):
        for _ in range(params.max_tries):
            w, h = rng.uniform(*params.size, size=2)
            r, c = free_cells[rng.integers(len(free_cells))]
            x, y = (c + 0.5) * res, (r + 0.5) * res
            rect = (x - w / 2, y - h / 2, x + w / 2, y + h / 2)
            c0, c1 = cell_span(rect[0], rect[2], res)
            r0, r1 = cell_span(rect[1], rect[3], res)
            if min(r0, c0) < 0 or grid[r0:r1, c0:c1].any():
                continue  # overlaps a wall, an obstacle or the border
            trial = grid.copy()
            trial[r0:r1, c0:c1] = True
            after = (
                free_components(trial, 0.0, res),
                free_components(trial, params.clearance, res),
            )
            if after[0] > before[0] or after[1] > before[1]:
                report["rejected_positions"] += 1
                continue
            grid = trial
            x0, y0, x1, y1 = (round(float(v), 4) for v in rect)
            layout.obstacles.append((x0, y0, x1, y1))
            report["placed"] += 1
            break
        else:
            report["dropped"] += 1
    if report["dropped"]:
        log.info(
            "%s layout: dropped %d of %d obstacles", layout.family, report["dropped"], requested
        )
    report["components_before"] = list(before)  # (raw, inflated by clearance)
    report["components_after"] = [free_components(grid, c, res) for c in (0.0, params.clearance)]
    layout.grid = grid
    layout.params["clutter"] = {**asdict(params), **report}
    return layout
