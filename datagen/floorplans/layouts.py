"""Seeded procedural floor plans: ``family(rng, params) -> Layout`` for rooms, corridor, maze.

Every random value comes from the ``rng`` passed in (derive it with
``datagen.seeding.sample_rng(seed, index, "nav_layout")``).
"""

from __future__ import annotations

import itertools
from dataclasses import asdict, dataclass, field

import numpy as np

from datagen.floorplans.grid import ClutterParams, Layout, Rect, add_clutter, fill, grid_to_rects
from datagen.registries import LAYOUTS
from datagen.registry import resolve


@dataclass
class RoomsParams:
    resolution: float = 0.05  # metres per cell
    wall_thickness: float = 0.15  # metres
    size: tuple[float, float] = (7.0, 11.0)  # outer width and depth range, metres
    rooms: tuple[int, int] = (2, 4)  # inclusive
    min_room: float = 2.2  # smallest room side, metres
    door_width: tuple[float, float] = (0.9, 1.2)  # metres
    clutter: ClutterParams = field(default_factory=ClutterParams)


@dataclass
class CorridorParams:
    resolution: float = 0.05
    wall_thickness: float = 0.15
    width: tuple[float, float] = (1.0, 1.6)  # corridor width, metres
    bends: tuple[int, int] = (1, 2)  # inclusive
    segment_length: tuple[float, float] = (3.0, 6.0)  # centreline length per leg, metres
    alcove_probability: float = 0.5  # per leg
    alcove_width: tuple[float, float] = (1.0, 1.5)  # along the corridor, metres
    alcove_depth: tuple[float, float] = (0.6, 1.0)  # metres
    clutter: ClutterParams = field(default_factory=lambda: ClutterParams(count=(1, 3)))


@dataclass
class MazeParams:
    resolution: float = 0.05
    wall_thickness: float = 0.15
    arm_length: tuple[float, float] = (3.0, 5.0)  # junction centre to dead end, metres
    arm_width: tuple[float, float] = (1.0, 1.6)  # metres
    stub_probability: float = 0.5  # per arm: a short dead-end side branch
    stub_length: tuple[float, float] = (1.0, 2.0)  # metres, from the arm's side wall
    clutter: ClutterParams = field(default_factory=lambda: ClutterParams(count=(1, 4)))


@dataclass
class PlusMazeParams:
    """The four-arm maze of the Neurorobotics Platform's car experiment: four equal arms."""

    resolution: float = 0.05
    wall_thickness: float = 0.15
    arm_length: tuple[float, float] = (3.0, 4.0)  # junction centre to an arm's end, metres
    arm_width: tuple[float, float] = (1.4, 1.8)  # metres: wide enough for a car to turn in
    clutter: ClutterParams = field(default_factory=lambda: ClutterParams(count=(0, 0)))


def _r(v) -> float:
    return round(float(v), 4)


def _overlaps(a: Rect, b: Rect, margin: float = 0.0) -> bool:
    return (
        a[0] < b[2] + margin
        and b[0] < a[2] + margin
        and a[1] < b[3] + margin
        and b[1] < a[3] + margin
    )


def _finish(rng, family, grid, res, doors, params, sampled) -> Layout:
    layout = Layout(
        grid=grid,
        resolution=res,
        family=family,
        walls=grid_to_rects(grid, res),
        doors=[(_r(d[0]), _r(d[1]), _r(d[2]), _r(d[3])) for d in doors],
        params={"config": asdict(params), **sampled},
    )
    return add_clutter(rng, layout, params.clutter)


def rooms(rng: np.random.Generator, params: RoomsParams | None = None) -> Layout:
    """An apartment: a walled rectangle split (binary partition) into 2-4 rooms, each split wall
    pierced by one door; later walls avoid earlier doors so every door stays passable."""
    p = params or RoomsParams()
    t, res = p.wall_thickness, p.resolution
    width, depth = (float(v) for v in rng.uniform(*p.size, size=2))
    target = int(rng.integers(p.rooms[0], p.rooms[1] + 1))
    cells: list[Rect] = [(t, t, width - t, depth - t)]
    walls: list[Rect] = []
    doors: list[Rect] = []
    for _ in range(8 * target):
        if len(cells) == target:
            break
        i = int(np.argmax([(c[2] - c[0]) * (c[3] - c[1]) for c in cells]))
        x0, y0, x1, y1 = cells[i]
        vertical = (x1 - x0) >= (y1 - y0)  # split the longer side with a wall across it
        lo, hi = (x0, x1) if vertical else (y0, y1)
        a0, a1 = (y0, y1) if vertical else (x0, x1)
        if hi - lo < 2 * p.min_room + t:
            break
        s = float(rng.uniform(lo + p.min_room + t / 2, hi - p.min_room - t / 2))
        wall = (
            (s - t / 2, a0 - t, s + t / 2, a1 + t)
            if vertical
            else (a0 - t, s - t / 2, a1 + t, s + t / 2)
        )
        if any(_overlaps(wall, d, 0.1) for d in doors):
            continue  # would close part of an existing door; try another split
        dw = float(rng.uniform(*p.door_width))
        d0 = float(rng.uniform(a0 + 0.15, a1 - 0.15 - dw))
        door = (
            (s - t / 2, d0, s + t / 2, d0 + dw) if vertical else (d0, s - t / 2, d0 + dw, s + t / 2)
        )
        walls.append(wall)
        doors.append(door)
        cells[i : i + 1] = (
            [(x0, y0, s - t / 2, y1), (s + t / 2, y0, x1, y1)]
            if vertical
            else [(x0, y0, x1, s - t / 2), (x0, s + t / 2, x1, y1)]
        )
    grid = np.ones((round(depth / res), round(width / res)), dtype=bool)
    fill(grid, (t, t, width - t, depth - t), res, False)
    for w in walls:
        fill(grid, w, res, True)
    for d in doors:
        fill(grid, d, res, False)
    sampled = {
        "width": _r(width),
        "depth": _r(depth),
        "rooms_target": target,
        "rooms": [[_r(v) for v in c] for c in cells],
    }
    return _finish(rng, "rooms", grid, res, doors, p, sampled)


def _carve(free: list[Rect], res: float, t: float) -> tuple[np.ndarray, list[Rect]]:
    """An all-occupied grid with ``free`` rectangles carved out, shifted so that a border of at
    least ``t`` surrounds them."""
    arr = np.array(free)
    lo = arr[:, :2].min(axis=0)
    shift = t - lo
    shifted = [(a + shift[0], b + shift[1], c + shift[0], d + shift[1]) for a, b, c, d in free]
    hi = np.array(shifted)[:, 2:].max(axis=0) + t
    grid = np.ones((int(np.ceil(hi[1] / res)), int(np.ceil(hi[0] / res))), dtype=bool)
    for rect in shifted:
        fill(grid, rect, res, False)
    return grid, shifted


def _leg_rect(a: np.ndarray, b: np.ndarray, half: float) -> Rect:
    """Axis-aligned rectangle around the segment a-b, extended by ``half`` at both ends."""
    return (
        min(a[0], b[0]) - half,
        min(a[1], b[1]) - half,
        max(a[0], b[0]) + half,
        max(a[1], b[1]) + half,
    )


def corridor(rng: np.random.Generator, params: CorridorParams | None = None) -> Layout:
    """A corridor of constant width along an axis-aligned centreline with 1-2 bends (+x, then
    +-y, then +x), with optional alcoves on the legs' sides."""
    p = params or CorridorParams()
    width = float(rng.uniform(*p.width))
    bends = int(rng.integers(p.bends[0], p.bends[1] + 1))
    turn = float(rng.choice([-1.0, 1.0]))
    directions = [np.array([1.0, 0.0]), np.array([0.0, turn]), np.array([1.0, 0.0])][: bends + 1]
    points = [np.zeros(2)]
    for d in directions:
        points.append(points[-1] + d * rng.uniform(*p.segment_length))
    free = [_leg_rect(a, b, width / 2) for a, b in itertools.pairwise(points)]
    alcoves = []
    for a, b, d in zip(points, points[1:], directions, strict=False):
        if rng.random() >= p.alcove_probability:
            continue
        aw, ad = rng.uniform(*p.alcove_width), rng.uniform(*p.alcove_depth)
        centre = a + d * rng.uniform(0.3, 0.7) * np.linalg.norm(b - a)
        normal = np.array([-d[1], d[0]]) * rng.choice([-1.0, 1.0])
        inner = centre + normal * (width / 2 - 0.05)  # overlap the corridor a little
        outer = centre + normal * (width / 2 + ad)
        along = d * aw / 2
        corners = np.array([inner - along, inner + along, outer - along, outer + along])
        rect = (*corners.min(axis=0), *corners.max(axis=0))
        alcoves.append(rect)
        free.append(rect)
    grid, _ = _carve(free, p.resolution, p.wall_thickness)
    sampled = {
        "width": _r(width),
        "bends": bends,
        "centreline": [
            [_r(v) for v in q - np.array(free).min(axis=0)[:2] + p.wall_thickness] for q in points
        ],
        "alcoves": len(alcoves),
    }
    return _finish(rng, "corridor", grid, p.resolution, [], p, sampled)


def maze(rng: np.random.Generator, params: MazeParams | None = None) -> Layout:
    """A plus-shaped maze: four arms of random length and width from a central junction, each
    ending in a dead end, some with a short dead-end side stub."""
    p = params or MazeParams()
    free: list[Rect] = []
    arms = []
    for d in (
        np.array([1.0, 0.0]),
        np.array([0.0, 1.0]),
        np.array([-1.0, 0.0]),
        np.array([0.0, -1.0]),
    ):
        length, width = float(rng.uniform(*p.arm_length)), float(rng.uniform(*p.arm_width))
        end = d * length
        free.append(_leg_rect(np.zeros(2), end - d * width / 2, width / 2))
        stub = None
        sw = float(rng.uniform(*p.arm_width))
        lo, hi = p.arm_width[1] / 2 + sw / 2 + 0.3, length - sw / 2 - 0.2  # clear of other arms
        if rng.random() < p.stub_probability and lo < hi:
            at = d * rng.uniform(lo, hi)
            normal = np.array([-d[1], d[0]]) * rng.choice([-1.0, 1.0])
            tip = at + normal * (width / 2 + rng.uniform(*p.stub_length))
            free.append(_leg_rect(at, tip, sw / 2))
            stub = {"width": _r(sw), "length": _r(np.linalg.norm(tip - at) - width / 2)}
        arms.append({"length": _r(length), "width": _r(width), "stub": stub})
    grid, _ = _carve(free, p.resolution, p.wall_thickness)
    return _finish(rng, "maze", grid, p.resolution, [], p, {"arms": arms})


def plus_maze(rng: np.random.Generator, params: PlusMazeParams | None = None) -> Layout:
    """A plus-shaped four-arm maze: four arms of one length and one width from a central
    junction, no side branches; the arms' ends are in ``params["arm_ends"]`` (x, y, metres)."""
    p = params or PlusMazeParams()
    length, width = _r(rng.uniform(*p.arm_length)), _r(rng.uniform(*p.arm_width))
    directions = [np.array(d) for d in ((1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0))]
    free = [_leg_rect(np.zeros(2), d * (length - width / 2), width / 2) for d in directions]
    grid, shifted = _carve(free, p.resolution, p.wall_thickness)
    centre = np.array([shifted[2][0] + length, shifted[3][1] + length])  # the junction
    ends = [[_r(v) for v in centre + d * (length - width / 2)] for d in directions]
    sampled = {
        "arm_length": length,
        "arm_width": width,
        "junction": [_r(v) for v in centre],
        "arm_ends": ends,
    }
    return _finish(rng, "plus_maze", grid, p.resolution, [], p, sampled)


def make_layout(family: str, rng: np.random.Generator, params=None) -> Layout:
    """A floor plan of ``family`` (a name in ``datagen.registries.LAYOUTS``)."""
    try:
        kind = LAYOUTS[family]
    except KeyError:
        raise ValueError(
            f"unknown layout family {family!r}; expected one of {LAYOUTS.names()}"
        ) from None
    return resolve(kind.make)(rng, params)
