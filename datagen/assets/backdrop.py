"""Where a room's backdrop walls stand (pure: stored background values in, boxes out), shared
by the scene builder and the USD export. World metres, the table centred on the origin."""

from __future__ import annotations

from typing import Any

WALL_THICKNESS = 0.05  # metres


def wall_boxes(values: dict[str, Any]) -> dict[str, tuple[list[float], list[float]]]:
    """(half size, centre) of each wall (``x_min``, ``x_max``, ``y_min``, ``y_max``) and of the
    ceiling if the room has one, from ``randomisation.background``."""
    (x0, x1), (y0, y1) = values["room"]["x"], values["room"]["y"]
    h, t = values["room"]["height"], WALL_THICKNESS
    cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
    half_x, half_y = (x1 - x0) / 2 + t, (y1 - y0) / 2 + t
    boxes = {
        "x_min": ([t / 2, half_y, h / 2], [x0 - t / 2, cy, h / 2]),
        "x_max": ([t / 2, half_y, h / 2], [x1 + t / 2, cy, h / 2]),
        "y_min": ([half_x, t / 2, h / 2], [cx, y0 - t / 2, h / 2]),
        "y_max": ([half_x, t / 2, h / 2], [cx, y1 + t / 2, h / 2]),
    }
    if values["ceiling"]:
        boxes["ceiling"] = ([half_x, half_y, t / 2], [cx, cy, h + t / 2])
    return boxes
