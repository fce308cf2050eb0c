"""Dimensions of the tabletop world (metres; world frame z up): the table, the robot's base on
its edge at negative x, and the tray in front of it. Pure numbers, shared by the simulator scene
(``datagen.worlds.tabletop``), grasp planning and the USD export."""

from __future__ import annotations

TABLE_TOP = 0.75  # metres
TABLE_HALF = (0.6, 0.75)
ROBOT_BASE = (-0.62, 0.0, TABLE_TOP)
TRAY_CENTRE = (0.08, 0.0, TABLE_TOP)  # centre of the tray's bottom face
TRAY_INNER_HALF = (0.2, 0.26)  # metres
TRAY_WALL = (0.008, 0.07)  # thickness, height (metres)
TRAY_FLOOR = 0.01  # floor thickness, metres


def tray_boxes() -> list[tuple[list[float], list[float]]]:
    """The tray as (half size, centre offset from TRAY_CENTRE) boxes: floor and four walls."""
    (ix, iy), (t, h) = TRAY_INNER_HALF, TRAY_WALL
    return [
        ([ix + t, iy + t, TRAY_FLOOR / 2], [0, 0, TRAY_FLOOR / 2]),
        ([t / 2, iy + t, h / 2], [ix + t / 2, 0, h / 2]),
        ([t / 2, iy + t, h / 2], [-ix - t / 2, 0, h / 2]),
        ([ix + t, t / 2, h / 2], [0, iy + t / 2, h / 2]),
        ([ix + t, t / 2, h / 2], [0, -iy - t / 2, h / 2]),
    ]
