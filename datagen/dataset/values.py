"""The rules for the numbers a sample stores, one set for every reader that uses them: the tools
(``inspect``, ``preview``: a sample that breaks one is left out and named,
``datagen.tools.sample_checks``) and the exports (the dataset is refused in one line naming the
sample and the key: an export is whole or absent, docs/exports.md).

A value that is valid JSON can still be one no format should carry: ``1e308`` is finite, but it
is ``inf`` once stored as float32 (LeRobot, robomimic) or multiplied by 1000 (BOP's millimetres),
and a box of ``1e30`` pixels or a focal length of ``1e308`` makes labels that no reader can use.
Each rule raises ``BadSample`` naming the key and saying what was expected.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

MAX_PIXEL = 100_000  # pixels from the image origin: a box, point or principal point farther is not datagen's
MAX_FOCAL_PX = 1e6  # a focal length beyond sees less than 0.25 degrees across 4096 pixels
MAX_METRES = 1e6  # a position farther from the world's origin is not datagen's (1000 km)
FLOAT32_MAX = float(np.finfo(np.float32).max)


class BadSample(ValueError):
    """A sample's stored content breaks a rule; the text names the key and what was expected."""


def shown(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 80 else text[:77] + "..."


def finite_matrix(value: Any, shape: tuple[int, int], where: str) -> np.ndarray:
    """``value`` as a float array of ``shape`` with only finite entries, else BadSample."""
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError, OverflowError):
        array = np.empty(0)
    if array.shape != shape or not np.isfinite(array).all():
        raise BadSample(
            f"{where}: expected a {shape[0]}x{shape[1]} matrix of finite numbers, "
            f"got {shown(value)}"
        )
    return array


def intrinsics(camera: Mapping[str, Any], where: str, key: str = "intrinsics") -> np.ndarray:
    """A camera record's 3x3 intrinsics (``key``): finite, focal lengths in (0, MAX_FOCAL_PX],
    the principal point within MAX_PIXEL, last row (0, 0, 1)."""
    K = finite_matrix(camera[key], (3, 3), f"{where}.{key}")
    focal = (K[0, 0], K[1, 1])
    if not (
        all(0 < f <= MAX_FOCAL_PX for f in focal)
        and np.abs(K[:2, 1:]).max() <= MAX_PIXEL
        and np.array_equal(K[2], [0, 0, 1])
    ):
        raise BadSample(
            f"{where}.{key}: expected [[fx, s, cx], [0, fy, cy], [0, 0, 1]] with 0 < fx, fy <= "
            f"{MAX_FOCAL_PX:g} and s, cx, cy within +-{MAX_PIXEL}, got {shown(camera[key])}"
        )
    return K


def pose_matrix(value: Any, where: str) -> np.ndarray:
    """A 4x4 pose (or world-to-camera transform): finite, its translation within MAX_METRES, its
    rotation part within [-1, 1] (a little more for rounding) and last row (0, 0, 0, 1)."""
    T = finite_matrix(value, (4, 4), where)
    if not (
        np.abs(T[:3, 3]).max() <= MAX_METRES
        and np.abs(T[:3, :3]).max() <= 1.001
        and np.allclose(T[3], [0, 0, 0, 1])
    ):
        raise BadSample(
            f"{where}: expected a rigid transform (rotation entries within [-1, 1], translation "
            f"within +-{MAX_METRES:g} m, last row 0 0 0 1), got {shown(value)}"
        )
    return T


def pixel_box(value: Any, where: str) -> tuple[int, int, int, int]:
    """A stored (x0, y0, x1, y1) box as whole pixels within ``MAX_PIXEL``, else BadSample."""
    box = None
    if isinstance(value, list | tuple) and len(value) == 4:
        try:
            box = pixels(np.asarray(value, dtype=float))
        except (TypeError, ValueError, OverflowError):
            box = None
    if box is None:
        raise BadSample(
            f"{where}: expected 4 pixel coordinates within +-{MAX_PIXEL}, got {shown(value)}"
        )
    x0, y0, x1, y1 = (int(v) for v in box)
    return x0, y0, x1, y1


def image_box(value: Any, size: tuple[int, int], where: str) -> tuple[int, int, int, int]:
    """A stored box of visible pixels: whole pixel indices (x0, y0, x1, y1), inclusive, inside
    an image of ``size`` (width, height), else BadSample."""
    width, height = size
    whole = isinstance(value, list) and len(value) == 4 and all(type(v) is int for v in value)
    if not (whole and 0 <= value[0] <= value[2] < width and 0 <= value[1] <= value[3] < height):
        raise BadSample(
            f"{where}: expected whole pixel indices [x0, y0, x1, y1] with 0 <= x0 <= x1 < "
            f"{width} and 0 <= y0 <= y1 < {height}, got {shown(value)}"
        )
    return value[0], value[1], value[2], value[3]


def pixels(points: np.ndarray) -> np.ndarray | None:
    """Image points (..., 2) rounded to whole pixels, or None if one is non-finite or farther
    than ``MAX_PIXEL`` (OpenCV cannot draw it)."""
    points = np.asarray(points, dtype=float)
    if not np.isfinite(points).all() or (np.abs(points) > MAX_PIXEL).any():
        return None
    return np.rint(points).astype(int)


def non_finite(value: Any, limit: float = math.inf) -> tuple[str, Any] | None:
    """(path such as ``a.b[2]``, number) of the first number in a JSON-like ``value`` that is
    not finite or exceeds ``limit`` in magnitude, or None. Iterative: safe on any depth."""
    stack: list[tuple[Any, str]] = [(value, "")]
    while stack:
        item, path = stack.pop()
        if isinstance(item, bool) or item is None or isinstance(item, str):
            continue
        if isinstance(item, int | float | np.number):
            try:
                number = float(item)
            except OverflowError:  # an int beyond any float
                number = math.inf
            if not (math.isfinite(number) and abs(number) <= limit):
                return path or "(the value)", item
        elif isinstance(item, Mapping):
            stack.extend((v, f"{path}.{k}" if path else str(k)) for k, v in item.items())
        elif isinstance(item, list | tuple | np.ndarray):
            stack.extend((v, f"{path}[{i}]") for i, v in enumerate(item))
    return None
