"""The tabletop world's static geometry, described once (metres; world frame z up): the floor,
the table (top and legs), the robot's base on its edge at negative x and the tray in front of it.
The constants are the Panda's workspace; a smaller arm gets them scaled about the world origin
(:class:`Workspace`, from ``RobotSpec.workspace_scale``; the floor is not scaled), and the tray's
walls and floor as its objects are (``RobotSpec.object_scale``).
Pure numbers, realised by the simulator scene (``datagen.families.grasp_tabletop.world``) and the USD export
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


@dataclass(frozen=True)
class Workspace:
    """The table, the tray and the robot's base, scaled by ``scale`` (1: the constants above);
    the tray's wall (thickness, height) and floor thickness by ``object_scale``: the tray holds
    the objects, so its walls stay as high beside them as the Panda's (walls scaled with a
    small arm's reach let its half-size objects bounce out or tunnel through 2 mm walls)."""

    scale: float = 1.0
    object_scale: float = 1.0

    def _scaled(self, values):
        return tuple(v * self.scale for v in values)

    @property
    def table_top(self) -> float:
        return TABLE_TOP * self.scale

    @property
    def table_half(self) -> tuple[float, float]:
        return self._scaled(TABLE_HALF)

    @property
    def robot_base(self) -> tuple[float, float, float]:
        return self._scaled(ROBOT_BASE)

    @property
    def tray_centre(self) -> tuple[float, float, float]:
        return self._scaled(TRAY_CENTRE)

    @property
    def tray_inner_half(self) -> tuple[float, float]:
        return self._scaled(TRAY_INNER_HALF)

    @property
    def tray_wall(self) -> tuple[float, float]:
        return (TRAY_WALL[0] * self.object_scale, TRAY_WALL[1] * self.object_scale)

    @property
    def tray_floor(self) -> float:
        return TRAY_FLOOR * self.object_scale

    @property
    def tray_floor_top(self) -> tuple[float, float, float]:
        """The middle of the tray floor's top face, where objects are dropped above."""
        x, y, z = self.tray_centre
        return (x, y, z + self.tray_floor)


DEFAULT_WORKSPACE = Workspace()


def tray_boxes(ws: Workspace = DEFAULT_WORKSPACE) -> list[Box]:
    """The tray as (half size, centre offset from the tray centre) boxes: floor and four walls."""
    (ix, iy), (t, h), floor = ws.tray_inner_half, ws.tray_wall, ws.tray_floor
    return [
        ([ix + t, iy + t, floor / 2], [0, 0, floor / 2]),
        ([t / 2, iy + t, h / 2], [ix + t / 2, 0, h / 2]),
        ([t / 2, iy + t, h / 2], [-ix - t / 2, 0, h / 2]),
        ([ix + t, t / 2, h / 2], [0, iy + t / 2, h / 2]),
        ([ix + t, t / 2, h / 2], [0, -iy - t / 2, h / 2]),
    ]


def in_tray(
    point: tuple[float, float, float] | list[float], ws: Workspace = DEFAULT_WORKSPACE
) -> bool:
    """True when ``point`` (an object's centre of mass, world metres) lies over the tray's inner
    rectangle and above its floor's top, within ``IN_TRAY_TOLERANCE``: where a target must be
    after settling (``datagen.worlds.tray_targets``)."""
    x, y, z = (float(v) for v in point)
    (cx, cy, cz), (ix, iy) = ws.tray_centre, ws.tray_inner_half
    return (
        abs(x - cx) <= ix + IN_TRAY_TOLERANCE
        and abs(y - cy) <= iy + IN_TRAY_TOLERANCE
        and z >= cz + ws.tray_floor - IN_TRAY_TOLERANCE
    )


def static_parts(ws: Workspace = DEFAULT_WORKSPACE) -> list[StaticPart]:
    """The floor, the table's top and four legs, and the tray, in the order they are built."""
    floor_half = [FLOOR_HALF, FLOOR_HALF, FLOOR_THICKNESS / 2]
    parts = [
        StaticPart("floor", "", (0.0, 0.0, 0.0), ((floor_half, [0, 0, -FLOOR_THICKNESS / 2]),))
    ]
    top_z, (hx, hy), thickness = ws.table_top, ws.table_half, TABLE_THICKNESS * ws.scale
    top = (0.0, 0.0, top_z - thickness / 2)
    parts.append(StaticPart("table", "top", top, (([hx, hy, thickness / 2], [0, 0, 0]),)))
    leg = (top_z - thickness) / 2  # half its height, so also its centre's height
    leg_half, inset = TABLE_LEG_HALF * ws.scale, TABLE_LEG_INSET * ws.scale
    leg_box = ([leg_half, leg_half, leg], [0, 0, 0])
    for k, (sx, sy) in enumerate(itertools.product((-1, 1), (-1, 1))):
        position = (sx * (hx - inset), sy * (hy - inset), leg)
        parts.append(StaticPart("table", f"leg_{k}", position, (leg_box,)))
    parts.append(StaticPart("tray", "", ws.tray_centre, tuple(tray_boxes(ws))))
    return parts
