"""Lens distortion, OpenCV's model (coefficients k1, k2, p1, p2, k3 in ``cv2.projectPoints``'
order), applied to a pinhole render and to every pixel annotation with the same map.

Each distorted pixel takes the render's value at the undistorted position of its centre
(colour: bilinear; depth and labels: nearest, so no value is invented). The distorted images keep
the render's principal point; their focal lengths are the render's times ``zoom`` >= 1, the
smallest zoom for which every distorted pixel lies inside the render (barrel distortion would
otherwise leave corners with nothing to show). ``Lens.intrinsics`` is the calibration of the
stored (distorted) images: ``cv2.projectPoints`` / ``cv2.undistortPoints`` with it and the
coefficients map between camera-frame points and stored pixels, in the image-plane convention
of :func:`datagen.geometry.image_points` (pixel (col, row) has its centre at (col + .5, row + .5)).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import cv2
import numpy as np

from datagen.geometry import undistorted_normalised

DISTORTION_MODEL = "opencv"  # k1, k2, p1, p2, k3
_GRID_PX = 4  # the map is exact every 4 pixels, bilinear between (error < 0.05 px)
_MAX_ZOOM = 4.0


@dataclass(frozen=True)
class Lens:
    intrinsics: np.ndarray  # (3, 3) of the distorted images
    coefficients: np.ndarray  # (5,) k1, k2, p1, p2, k3
    zoom: float  # distorted focal length / render focal length
    map_x: np.ndarray  # (H, W) float32 render column index sampled by each distorted pixel
    map_y: np.ndarray  # (H, W) float32 render row index


def _scaled(intrinsics: np.ndarray, zoom: float) -> np.ndarray:
    scaled = intrinsics.copy()
    scaled[0, 0] *= zoom
    scaled[1, 1] *= zoom
    return scaled


def _render_points(
    plane: np.ndarray, render_k: np.ndarray, coefficients: np.ndarray, zoom: float
) -> np.ndarray:
    """Distorted image-plane points (N, 2) -> where the render shows them (N, 2), same
    convention."""
    normalised = undistorted_normalised(plane, _scaled(render_k, zoom), coefficients)
    return normalised * np.diag(render_k)[:2] + render_k[:2, 2]


def _smallest_zoom(render_k, coefficients, width: int, height: int) -> float:
    """The smallest zoom for which the distorted image's border lies inside the render."""
    cols, rows = np.linspace(0, width, 65), np.linspace(0, height, 49)
    border = np.concatenate(
        [
            np.stack([cols, np.zeros_like(cols)], 1),
            np.stack([cols, np.full_like(cols, height)], 1),
            np.stack([np.zeros_like(rows), rows], 1),
            np.stack([np.full_like(rows, width), rows], 1),
        ]
    )

    def inside(zoom: float) -> bool:
        source = _render_points(border, render_k, coefficients, zoom)
        tolerance = 1e-3
        return bool(
            (source[:, 0] >= -tolerance).all()
            and (source[:, 0] <= width + tolerance).all()
            and (source[:, 1] >= -tolerance).all()
            and (source[:, 1] <= height + tolerance).all()
        )

    if inside(1.0):
        return 1.0
    if not inside(_MAX_ZOOM):
        raise ValueError(f"distortion {coefficients.tolist()} is too strong to render")
    lo, hi = 1.0, _MAX_ZOOM
    for _ in range(12):  # to within 0.001: a zoom a little larger than needed is harmless
        mid = (lo + hi) / 2
        lo, hi = (lo, mid) if inside(mid) else (mid, hi)
    return hi


@functools.lru_cache(maxsize=8)
def _lens(render_k: tuple, coefficients: tuple, width: int, height: int) -> Lens:
    k, d = np.array(render_k, float).reshape(3, 3), np.array(coefficients, float)
    zoom = _smallest_zoom(k, d, width, height)
    # exact on a coarse grid of pixel centres, then bilinear to every pixel
    grid_cols = np.arange(0, width + _GRID_PX, _GRID_PX, dtype=float)
    grid_rows = np.arange(0, height + _GRID_PX, _GRID_PX, dtype=float)
    gu, gv = np.meshgrid(grid_cols + 0.5, grid_rows + 0.5)
    source = _render_points(np.stack([gu, gv], -1).reshape(-1, 2), k, d, zoom) - 0.5
    coarse = source.reshape(len(grid_rows), len(grid_cols), 2).astype(np.float32)
    cols, rows = np.meshgrid(
        np.arange(width, dtype=np.float32) / _GRID_PX,
        np.arange(height, dtype=np.float32) / _GRID_PX,
    )
    fine = cv2.remap(coarse, cols, rows, cv2.INTER_LINEAR)
    return Lens(_scaled(k, zoom), d, zoom, fine[..., 0].copy(), fine[..., 1].copy())


def lens_for(render_intrinsics: np.ndarray, coefficients, width: int, height: int) -> Lens:
    """The lens of a view (cached: the maps depend only on these values)."""
    return _lens(
        tuple(np.asarray(render_intrinsics, float).ravel().tolist()),
        tuple(float(c) for c in coefficients),
        int(width),
        int(height),
    )


def distort(image: np.ndarray, lens: Lens, nearest: bool) -> np.ndarray:
    """The render ``image`` (H, W[, C]) as the distorted camera sees it; ``nearest`` for depth
    and label maps (values copied, never blended)."""
    interpolation = cv2.INTER_NEAREST if nearest else cv2.INTER_LINEAR
    return cv2.remap(image, lens.map_x, lens.map_y, interpolation, borderMode=cv2.BORDER_REPLICATE)


def project_distorted(points_camera: np.ndarray, lens: Lens) -> np.ndarray:
    """Camera-frame points (N, 3), z > 0, -> distorted image-plane coordinates (N, 2)."""
    if len(points_camera) == 0:
        return np.zeros((0, 2))
    uv, _ = cv2.projectPoints(
        np.asarray(points_camera, np.float64).reshape(-1, 1, 3),
        np.zeros(3),
        np.zeros(3),
        lens.intrinsics,
        lens.coefficients,
    )
    return uv.reshape(-1, 2)
