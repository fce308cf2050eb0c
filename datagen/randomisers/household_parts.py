"""Household-like shape families: sampled parameters of bottles, cans, mugs, bowls, boxes with
lids and tools, as the part lists :mod:`datagen.assets.household` and :mod:`datagen.assets.shapes` build.

Every family's largest extent is about ``size`` (metres); the object frame's origin is near the
middle of the object and a vessel's axis is z.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from datagen.assets.family_names import HOUSEHOLD_FAMILIES

_IDENTITY = [1.0, 0.0, 0.0, 0.0]
_Z_TO_X = [float(np.cos(np.pi / 4)), 0.0, float(np.sin(np.pi / 4)), 0.0]  # 90 deg about y


def _round(values) -> list:
    return np.round(np.asarray(values, float), 6).tolist()


def _bottle(rng: np.random.Generator, size: float) -> list[dict[str, Any]]:
    bottom, radius = -size / 2, size * rng.uniform(0.14, 0.24)
    neck = radius * rng.uniform(0.3, 0.45)
    shoulder = bottom + size * rng.uniform(0.5, 0.62)
    neck_start = bottom + size * rng.uniform(0.74, 0.8)
    cap_height = size * rng.uniform(0.06, 0.1)
    cap = neck * rng.uniform(1.1, 1.25)
    bulge = rng.uniform(0.8, 0.92)  # the shoulder's middle, between straight and round
    profile = [
        [radius * 0.9, bottom],
        [radius, bottom + size * 0.02],
        [radius, shoulder],
        [neck + (radius - neck) * bulge, (shoulder + neck_start) / 2],
        [neck, neck_start],
        [neck, size / 2 - cap_height],
        [cap, size / 2 - cap_height],
        [cap, size / 2],
    ]
    return [{"kind": "revolve", "profile": _round(profile)}]


def _can(rng: np.random.Generator, size: float) -> list[dict[str, Any]]:
    height = size * rng.uniform(0.8, 1.0)
    radius = min(size * rng.uniform(0.2, 0.4), size / 2)
    rim, half = height * 0.05, height / 2
    profile = [
        [radius * 0.88, -half],
        [radius, rim - half],
        [radius, half - rim],
        [radius * 0.9, half],
    ]
    return [{"kind": "revolve", "profile": _round(profile)}]


def _mug(rng: np.random.Generator, size: float) -> list[dict[str, Any]]:
    height = size * rng.uniform(0.75, 1.0)
    top = size * rng.uniform(0.25, 0.32)  # with the handle, at most about size across
    bottom_radius = top * rng.uniform(0.8, 1.0)
    thickness = max(0.003, top * rng.uniform(0.1, 0.15))
    arc = height * rng.uniform(0.28, 0.38)
    tube = arc * rng.uniform(0.15, 0.22)
    # the arc's ends (at +-80 deg) lie inside the wall at mid-height
    centre_x = (top + bottom_radius) / 2 - arc * np.cos(np.deg2rad(80)) - tube / 2
    return [
        {
            "kind": "shell",
            "profile": _round([[bottom_radius, -height / 2], [top, height / 2]]),
            "thickness": round(thickness, 6),
            "base": round(thickness * 1.2, 6),
        },
        {
            "kind": "handle",
            "centre": _round([centre_x, 0.0]),
            "radius": round(arc, 6),
            "tube": round(tube, 6),
            "arc_deg": [-80.0, 80.0],
        },
    ]


def _bowl(rng: np.random.Generator, size: float) -> list[dict[str, Any]]:
    radius, height = size / 2, size * rng.uniform(0.3, 0.5)
    foot = radius * rng.uniform(0.35, 0.55)
    fractions = np.array([0.0, 0.5, 1.0])
    profile = np.column_stack(
        [foot + (radius - foot) * np.sqrt(fractions), -height / 2 + fractions * height]
    )
    thickness = max(0.003, radius * rng.uniform(0.06, 0.1))
    return [
        {
            "kind": "shell",
            "profile": _round(profile),
            "thickness": round(thickness, 6),
            "base": round(thickness, 6),
        }
    ]


def _rounded_rectangle(half_x: float, half_y: float, corner: float) -> np.ndarray:
    """(16, 2) convex polygon, counter-clockwise: a rectangle with quarter-circle corners."""
    points = []
    for k, (sx, sy) in enumerate([(1, 1), (-1, 1), (-1, -1), (1, -1)]):
        angles = np.pi / 2 * k + np.linspace(0, np.pi / 2, 4)
        centre = np.array([sx * (half_x - corner), sy * (half_y - corner)])
        points.append(centre + corner * np.column_stack([np.cos(angles), np.sin(angles)]))
    return np.vstack(points)


def _lidded_box(rng: np.random.Generator, size: float) -> list[dict[str, Any]]:
    half_x, half_y = size / 2 * 0.96, size / 2 * rng.uniform(0.45, 0.9)
    corner = min(half_x, half_y) * rng.uniform(0.05, 0.4)
    body_height = size * rng.uniform(0.3, 0.7)
    lid_height = body_height * rng.uniform(0.12, 0.2)
    lip = size * 0.02
    body_z = -lid_height * 0.35
    lid_z = body_z + body_height / 2 + lid_height * 0.2  # overlaps the body's top edge
    return [
        {
            "kind": "prism",
            "polygon": _round(_rounded_rectangle(half_x - lip, half_y - lip, corner)),
            "height": round(body_height, 6),
            "offset": _round([0, 0, body_z]),
            "quat_wxyz": _IDENTITY,
        },
        {
            "kind": "prism",
            "polygon": _round(_rounded_rectangle(half_x, half_y, corner)),
            "height": round(lid_height, 6),
            "offset": _round([0, 0, lid_z]),
            "quat_wxyz": _IDENTITY,
        },
    ]


def _tool(rng: np.random.Generator, size: float) -> list[dict[str, Any]]:
    """A hammer (handle + box head) or a spatula (handle + flat blade), along x."""
    radius = size * rng.uniform(0.03, 0.05)
    if rng.uniform() < 0.5:
        head = size * rng.uniform(0.1, 0.16)  # the head's square section
        handle_length = size - head
        head_part: dict[str, Any] = {
            "kind": "box",
            "extents": _round([head, head, size * rng.uniform(0.3, 0.45)]),
            "offset": _round([size / 2 - head / 2, 0, 0]),
            "quat_wxyz": _IDENTITY,
        }
    else:
        blade_length, width = size * rng.uniform(0.25, 0.4), size * rng.uniform(0.18, 0.3)
        handle_length = size - blade_length
        taper = width / 2 * rng.uniform(0.35, 0.6)  # half width where the blade meets the handle
        polygon = [[0, -taper], [blade_length, -width / 2], [blade_length, width / 2], [0, taper]]
        head_part = {
            "kind": "prism",
            "polygon": _round(polygon),
            "height": round(max(0.002, size * 0.02), 6),
            "offset": _round([size / 2 - blade_length, 0, 0]),
            "quat_wxyz": _IDENTITY,
        }
    handle_part = {
        "kind": "cylinder",
        "radius": round(radius, 6),
        "height": round(handle_length, 6),
        "offset": _round([-size / 2 + handle_length / 2, 0, 0]),
        "quat_wxyz": _Z_TO_X,
    }
    return [handle_part, head_part]


# in the order of HOUSEHOLD_FAMILIES
_SAMPLERS = dict(
    zip(HOUSEHOLD_FAMILIES, (_bottle, _can, _mug, _bowl, _lidded_box, _tool), strict=True)
)


def draw_household_parts(
    rng: np.random.Generator, family: str, size: float
) -> list[dict[str, Any]]:
    return _SAMPLERS[family](rng, size)
