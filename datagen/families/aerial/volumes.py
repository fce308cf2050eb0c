"""3-D volumes to fly in: a floor plan of :mod:`datagen.floorplans.layouts` (rooms, corridor,
maze, plus maze; the same seeded plans ground robots drive) extended in height, with a voxel
occupancy grid of the same solids.

Solids are axis-aligned boxes ``(x0, y0, z0, x1, y1, z1)`` in metres (world frame of the floor
plan, z up from the floor at 0): the plan's walls and obstacles raised to their heights, a
ceiling slab at ``height``, and what only a flyer meets: **pillars** (floor to ceiling),
**beams** (horizontal bars across a passage at a random height), **hanging** boxes (from the
ceiling down), **screens** (a wall across a passage with one opening at a random height) and,
in rooms, **windows** (an opening at a random height through an inner wall beside its door).
A flyer-only solid that would split the free space, inflated by the drone's clearance, is
tried elsewhere, then dropped, as floor-plan clutter is.

Voxel grid: ``occupancy[k, i, j]`` is the voxel of side ``resolution`` spanning
z in [k r, (k+1) r), y in [i r, (i+1) r), x in [j r, (j+1) r); True when a solid touches it
(a face on a voxel boundary marks both voxels: every point of a solid is in an occupied voxel).
Outside the grid (beyond the plan, below the floor, above the ceiling) counts as occupied.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
from scipy import ndimage

from datagen.floorplans.grid import Layout
from datagen.scene_values.rounding import uniform

Box = tuple[float, float, float, float, float, float]  # x0, y0, z0, x1, y1, z1 (metres)
CEILING_THICKNESS = 0.1  # metres
FLYER_KINDS = ("pillar", "beam", "hanging", "screen", "window")
_SIX = ndimage.generate_binary_structure(3, 1)


@dataclass(frozen=True)
class VolumeParams:
    resolution: float = 0.1  # metres: voxel side
    height: tuple[float, float] = (2.6, 4.0)  # floor to ceiling, metres
    obstacle_height: tuple[float, float] = (0.3, 2.0)  # the plan's clutter boxes, metres
    pillars: tuple[int, int] = (0, 3)
    pillar_size: tuple[float, float] = (0.15, 0.4)  # metres across
    beams: tuple[int, int] = (0, 3)
    beam_thickness: tuple[float, float] = (0.1, 0.3)  # metres, vertical and along the passage
    hanging: tuple[int, int] = (0, 3)
    hanging_size: tuple[float, float] = (0.3, 0.8)  # metres across
    hanging_length: tuple[float, float] = (0.4, 1.5)  # metres down from the ceiling
    screens: tuple[int, int] = (0, 2)
    opening: tuple[float, float] = (0.7, 1.2)  # metres: a screen's or window's opening side
    window_probability: float = 0.5  # per inner wall of a rooms plan
    clearance: float = 0.3  # metres: kept passable (the drone's radius plus margin)
    max_tries: int = 30  # positions tried per solid before it is dropped


@dataclass
class Solid:
    kind: str  # wall, obstacle, ceiling, pillar, beam, hanging, screen, window
    box: Box


@dataclass
class Volume:
    layout: Layout
    height: float  # metres, floor to ceiling
    resolution: float  # metres, voxel side
    solids: list[Solid]
    params: dict[str, Any] = field(default_factory=dict)  # sampled values, JSON-able

    @property
    def shape(self) -> tuple[int, int, int]:
        """(nz, ny, nx) voxels."""
        width, depth = self.layout.size_m
        r = self.resolution
        return (
            math.ceil(self.height / r - 1e-9),
            math.ceil(depth / r - 1e-9),
            math.ceil(width / r - 1e-9),
        )

    @property
    def occupancy(self) -> np.ndarray:
        return voxelise([s.box for s in self.solids], self.shape, self.resolution)

    def boxes(self) -> np.ndarray:
        """(n, 6) every solid's box."""
        return np.asarray([s.box for s in self.solids], float).reshape(-1, 6)


def voxelise(boxes: list[Box], shape: tuple[int, int, int], resolution: float) -> np.ndarray:
    """Occupancy (nz, ny, nx), conservative: a voxel is occupied when a box touches it (the
    closed box and the closed voxel share a point), so every point of a solid, its faces
    included, lies in an occupied voxel; a face on a voxel boundary marks the voxels on both
    sides."""
    grid = np.zeros(shape, bool)
    r = resolution
    for x0, y0, z0, x1, y1, z1 in boxes:
        lo = [math.ceil(v / r - 1e-9) - 1 for v in (z0, y0, x0)]
        hi = [math.floor(v / r + 1e-9) + 1 for v in (z1, y1, x1)]
        lo = [min(max(v, 0), n) for v, n in zip(lo, shape, strict=True)]
        hi = [min(max(v, 0), n) for v, n in zip(hi, shape, strict=True)]
        grid[lo[0] : hi[0], lo[1] : hi[1], lo[2] : hi[2]] = True
    return grid


def clearance_map(occupancy: np.ndarray, resolution: float) -> np.ndarray:
    """(nz, ny, nx) metres from each voxel's centre to the nearest occupied voxel's cube (a lower
    bound: the centre-to-centre distance less half a cube's diagonal), outside counted occupied;
    0 on occupied voxels."""
    padded = np.pad(~occupancy, 1, constant_values=False)
    centres = ndimage.distance_transform_edt(padded)[1:-1, 1:-1, 1:-1] * resolution
    return np.where(occupancy, 0.0, np.maximum(centres - resolution * math.sqrt(3) / 2, 0.0))


def free_space(occupancy: np.ndarray, resolution: float, clearance: float) -> np.ndarray:
    """Voxels whose centre keeps ``clearance`` metres from every solid (by :func:`clearance_map`)."""
    return clearance_map(occupancy, resolution) >= clearance


def components(free: np.ndarray) -> int:
    return int(ndimage.label(free, structure=_SIX)[1])


def box_distance(points: np.ndarray, boxes: np.ndarray) -> np.ndarray:
    """(n,) metres from each point (n, 3) to the nearest box (m, 6); inf without boxes."""
    if len(boxes) == 0:
        return np.full(len(points), np.inf)
    lo, hi = boxes[None, :, :3], boxes[None, :, 3:]
    p = points[:, None, :]
    gap = np.maximum(np.maximum(lo - p, p - hi), 0.0)
    return np.sqrt((gap**2).sum(axis=-1)).min(axis=1)


def _free_run(free2d: np.ndarray, r: int, c: int, axis: int) -> tuple[int, int]:
    """[first, last] free cells through (r, c) along ``axis`` (0: rows, y; 1: cols, x)."""
    line = free2d[:, c] if axis == 0 else free2d[r, :]
    at = r if axis == 0 else c
    lo = at
    while lo > 0 and line[lo - 1]:
        lo -= 1
    hi = at
    while hi < len(line) - 1 and line[hi + 1]:
        hi += 1
    return lo, hi


def _across(rng, layout: Layout, height: float, thickness: float) -> tuple[Box, bool] | None:
    """A slab across the passage through a random free cell, ``thickness`` metres along the
    passage, spanning its width and the full height (cut down by the caller); None when the
    cell lies in the open (wider than 3 m both ways)."""
    free2d = ~layout.grid
    cells = np.argwhere(free2d)
    r, c = cells[rng.integers(len(cells))]
    res = layout.resolution
    runs = [_free_run(free2d, r, c, axis) for axis in (0, 1)]
    widths = [(hi - lo + 1) * res for lo, hi in runs]
    across = int(np.argmin(widths))  # the passage runs along the other axis
    if widths[across] > 3.0:
        return None
    lo, hi = runs[across]
    x, y = (c + 0.5) * res, (r + 0.5) * res
    if across == 0:  # spans y, thin along x
        box = (x - thickness / 2, lo * res, 0.0, x + thickness / 2, (hi + 1) * res, height)
    else:
        box = (lo * res, y - thickness / 2, 0.0, (hi + 1) * res, y + thickness / 2, height)
    x0, y0, z0, x1, y1, z1 = (round(float(v), 4) for v in box)
    return (x0, y0, z0, x1, y1, z1), across == 0


def subtract(box: Box, hole: Box) -> list[Box]:
    """``box`` less ``hole``: at most six boxes (none where the hole covers it all; ``box``
    itself where they do not overlap)."""
    lo, hi = list(box[:3]), list(box[3:])
    hlo, hhi = hole[:3], hole[3:]
    if any(hlo[a] >= hi[a] or hhi[a] <= lo[a] for a in range(3)):
        return [box]
    pieces: list[Box] = []
    for axis in range(3):  # peel off what lies below, then above, the hole along each axis
        if hlo[axis] > lo[axis]:
            below_hi = list(hi)
            below_hi[axis] = hlo[axis]
            pieces.append((*lo, *below_hi))  # type: ignore[arg-type]
            lo[axis] = hlo[axis]
        if hhi[axis] < hi[axis]:
            above_lo = list(lo)
            above_lo[axis] = hhi[axis]
            pieces.append((*above_lo, *hi))  # type: ignore[arg-type]
            hi[axis] = hhi[axis]
    return [tuple(round(float(v), 4) for v in p) for p in pieces]  # type: ignore[misc]


def _flyer_solids(rng, kind: str, layout: Layout, height: float, p: VolumeParams) -> list[Solid]:
    """One flyer-only feature of ``kind`` at a random place (several boxes for a screen)."""
    res = layout.resolution
    if kind in ("pillar", "hanging"):
        cells = np.argwhere(~layout.grid)
        r, c = cells[rng.integers(len(cells))]
        side = uniform(rng, p.pillar_size if kind == "pillar" else p.hanging_size, 4)
        x, y = (c + 0.5) * res, (r + 0.5) * res
        bottom = 0.0 if kind == "pillar" else max(height - uniform(rng, p.hanging_length, 4), 0.3)
        box = (x - side / 2, y - side / 2, bottom, x + side / 2, y + side / 2, height)
        x0, y0, z0, x1, y1, z1 = (round(float(v), 4) for v in box)
        return [Solid(kind, (x0, y0, z0, x1, y1, z1))]
    thickness = uniform(rng, p.beam_thickness, 4)
    found = _across(rng, layout, height, thickness)
    if found is None:
        return []
    box, spans_y = found
    if kind == "beam":
        z0 = uniform(rng, (0.4, max(height - 0.4 - thickness, 0.5)), 4)
        return [Solid("beam", (box[0], box[1], z0, box[3], box[4], round(z0 + thickness, 4)))]
    side = uniform(rng, p.opening, 4)
    lo, hi = (box[1], box[4]) if spans_y else (box[0], box[3])
    at = uniform(rng, (lo + side / 2, max(hi - side / 2, lo + side / 2)), 4)
    z0 = uniform(rng, (0.2, max(height - 0.2 - side, 0.2)), 4)
    a, b = at - side / 2, at + side / 2
    hole = (
        (box[0], a, z0, box[3], b, z0 + side) if spans_y else (a, box[1], z0, b, box[4], z0 + side)
    )
    return [Solid("screen", piece) for piece in subtract(box, hole)]


def _window(rng, layout: Layout, door, height: float, p: VolumeParams) -> Box | None:
    """An opening through the inner wall of ``door``, beside it along the wall, its low edge
    0.5 m or more above the floor (a ground robot still meets a wall)."""
    x0, y0, x1, y1 = door
    along_y = (y1 - y0) > (x1 - x0)  # the door's long side lies along the wall
    side = uniform(rng, p.opening, 4)
    z0 = uniform(rng, (0.5, max(height - 0.2 - side, 0.5)), 4)
    gap = uniform(rng, (0.3, 1.5), 4)
    sign = 1.0 if rng.random() < 0.5 else -1.0
    if along_y:
        a = y1 + gap if sign > 0 else y0 - gap - side
        return (x0 - 0.01, a, z0, x1 + 0.01, a + side, z0 + side)
    a = x1 + gap if sign > 0 else x0 - gap - side
    return (a, y0 - 0.01, z0, a + side, y1 + 0.01, z0 + side)


def make_volume(rng: np.random.Generator, layout: Layout, p: VolumeParams) -> Volume:
    """The floor plan ``layout`` raised into a volume with flyer-only solids drawn from ``rng``
    (every value recorded in ``Volume.params``)."""
    height = uniform(rng, p.height, 4)
    solids = [Solid("wall", (*w[:2], 0.0, *w[2:], height)) for w in layout.walls]
    solids += [
        Solid("obstacle", (*o[:2], 0.0, *o[2:], min(uniform(rng, p.obstacle_height, 4), height)))
        for o in layout.obstacles
    ]
    width, depth = layout.size_m
    solids.append(Solid("ceiling", (0.0, 0.0, height, width, depth, height + CEILING_THICKNESS)))
    volume = Volume(layout, height, p.resolution, solids)
    report: dict[str, Any] = {"height": height}
    if layout.family == "rooms":
        windows = [
            w
            for d in layout.doors
            if rng.random() < p.window_probability
            if (w := _window(rng, layout, d, height, p)) is not None
        ]
        for hole in windows:
            volume.solids = [
                Solid(s.kind, piece)
                for s in volume.solids
                for piece in (subtract(s.box, hole) if s.kind == "wall" else [s.box])
            ]
        report["windows"] = [list(w) for w in windows]
    free = free_space(volume.occupancy, p.resolution, p.clearance)
    before = components(free)
    for kind, count in (
        ("pillar", p.pillars),
        ("beam", p.beams),
        ("hanging", p.hanging),
        ("screen", p.screens),
    ):
        placed = dropped = 0
        for _ in range(int(rng.integers(count[0], count[1] + 1))):
            for _ in range(p.max_tries):
                new = _flyer_solids(rng, kind, layout, height, p)
                if not new:
                    continue
                trial = voxelise(
                    [s.box for s in [*volume.solids, *new]], volume.shape, p.resolution
                )
                after = components(free_space(trial, p.resolution, p.clearance))
                if after > before:
                    continue  # would cut the free space in two
                volume.solids += new
                before = after
                placed += 1
                break
            else:
                dropped += 1
        report[kind] = {"placed": placed, "dropped": dropped}
    volume.params = {"config": asdict(p), **report}
    return volume
