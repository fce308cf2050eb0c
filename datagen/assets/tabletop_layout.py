"""The tabletop world's static geometry, described once (metres; world frame z up): the floor,
the table (top and legs), the robot's base on its edge at negative x and the tray in front of it.
Pure numbers, realised by the simulator scene (``datagen.worlds.tabletop``) and the USD export
(``datagen.exports.usd_stage``) from :func:`static_parts`, and shared with grasp planning."""

from __future__ import annotations

import itertools
from dataclasses import dataclass

FLOOR_HALF = 10.0  # metres: half the side of the drawn floor (as SAPIEN draws its ground plane)
FLOOR_THICKNESS = 0.01  # metres: the floor is drawn as a slab below z = 0
TABLE_TOP = 0.75  # metres
TABLE_HALF = (0.6, 0.75)
TABLE_THICKNESS = 0.03  # metres
TABLE_LEG_HALF = 0.025  # metres: half the side of a leg's square section
TABLE_LEG_INSET = 0.05  # metres from the table's edges to a leg's axis
ROBOT_BASE = (-0.62, 0.0, TABLE_TOP)
TRAY_CENTRE = (0.08, 0.0, TABLE_TOP)  # centre of the tray's bottom face
TRAY_INNER_HALF = (0.2, 0.26)  # metres
TRAY_WALL = (0.008, 0.07)  # thickness, height (metres)
TRAY_FLOOR = 0.01  # floor thickness, metres
IN_TRAY_TOLERANCE = 0.01  # metres, beyond the inner rectangle or below the floor (in_tray)

Box = tuple[list[float], list[float]]  # (half size, centre offset from its part's position)


@dataclass(frozen=True)
class StaticPart:
    """A static part of the tabletop world: boxes about ``position`` (world metres, no
    rotation), drawn with ``randomisation.materials[surface]`` and labelled with the stuff class
    ``surface``. The floor collides as the plane z = 0 (the ground), the others as their boxes."""

    surface: str  # "floor", "table" or "tray"
    name: str  # the part within its surface ("top", "leg_0", ...); "" for a one-part surface
    position: tuple[float, float, float]
    boxes: tuple[Box, ...]


def tray_boxes() -> list[Box]:
    """The tray as (half size, centre offset from TRAY_CENTRE) boxes: floor and four walls."""
    (ix, iy), (t, h) = TRAY_INNER_HALF, TRAY_WALL
    return [
        ([ix + t, iy + t, TRAY_FLOOR / 2], [0, 0, TRAY_FLOOR / 2]),
        ([t / 2, iy + t, h / 2], [ix + t / 2, 0, h / 2]),
        ([t / 2, iy + t, h / 2], [-ix - t / 2, 0, h / 2]),
        ([ix + t, t / 2, h / 2], [0, iy + t / 2, h / 2]),
        ([ix + t, t / 2, h / 2], [0, -iy - t / 2, h / 2]),
    ]


def in_tray(point: tuple[float, float, float] | list[float]) -> bool:
    """True when ``point`` (an object's centre of mass, world metres) lies over the tray's inner
    rectangle and above its floor's top, within ``IN_TRAY_TOLERANCE``: where a target must be
    after settling (``datagen.worlds.tray_targets``)."""
    x, y, z = (float(v) for v in point)
    return (
        abs(x - TRAY_CENTRE[0]) <= TRAY_INNER_HALF[0] + IN_TRAY_TOLERANCE
        and abs(y - TRAY_CENTRE[1]) <= TRAY_INNER_HALF[1] + IN_TRAY_TOLERANCE
        and z >= TRAY_CENTRE[2] + TRAY_FLOOR - IN_TRAY_TOLERANCE
    )


def static_parts() -> list[StaticPart]:
    """The floor, the table's top and four legs, and the tray, in the order they are built."""
    floor_half = [FLOOR_HALF, FLOOR_HALF, FLOOR_THICKNESS / 2]
    parts = [
        StaticPart("floor", "", (0.0, 0.0, 0.0), ((floor_half, [0, 0, -FLOOR_THICKNESS / 2]),))
    ]
    top = (0.0, 0.0, TABLE_TOP - TABLE_THICKNESS / 2)
    parts.append(
        StaticPart("table", "top", top, (([*TABLE_HALF, TABLE_THICKNESS / 2], [0, 0, 0]),))
    )
    leg = (TABLE_TOP - TABLE_THICKNESS) / 2  # half its height, so also its centre's height
    leg_box = ([TABLE_LEG_HALF, TABLE_LEG_HALF, leg], [0, 0, 0])
    for k, (sx, sy) in enumerate(itertools.product((-1, 1), (-1, 1))):
        position = (
            sx * (TABLE_HALF[0] - TABLE_LEG_INSET),
            sy * (TABLE_HALF[1] - TABLE_LEG_INSET),
            leg,
        )
        parts.append(StaticPart("table", f"leg_{k}", position, (leg_box,)))
    parts.append(StaticPart("tray", "", TRAY_CENTRE, tuple(tray_boxes())))
    return parts
