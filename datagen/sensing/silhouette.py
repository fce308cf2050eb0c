"""Counting the pixels a projected silhouette covers, by the rasteriser's own rule.

A GPU rasteriser (Vulkan, as SAPIEN uses it; lavapipe the same) covers pixel (col, row) when its
centre (col + 0.5, row + 0.5) lies inside the projected triangle. A convex part's silhouette is
the convex hull of its projected vertices, so counting the pixel centres inside those hulls
reproduces the rendered mask of an unoccluded object. (OpenCV's polygon fill, used before, also
colours every pixel an edge passes through: fully visible objects measured 0.42-0.98 visible.)

Coordinates are image-plane pixels as the intrinsics define them: origin at the top-left corner of
the top-left pixel. Work is a few operations per covered row and hull edge, never per pixel.
"""

from __future__ import annotations

import cv2
import numpy as np

# Rasterisers snap projected vertices to a sub-pixel grid (Vulkan's subPixelPrecisionBits: 8 on
# lavapipe, so 1/256 pixel), so a pixel centre this close to an edge may fall either way.
# Leaving such pixels out keeps a fully visible object's visible_fraction at 1.
SNAP_MARGIN = 1 / 256  # pixels
WINDOW = 4  # image sizes counted beyond each border of the image
CHUNK = 65536  # outlines at a time


def convex_outlines(points: list[np.ndarray]) -> np.ndarray:
    """(M, N, 2): the convex hull of each (K_i, 2) point set in cyclic order, padded by repeating
    its last vertex (a zero-length edge, which covers nothing)."""
    hulls = []
    for p in points:
        # indices only: the float32 copy cv2 works on never replaces the float64 coordinates
        index = cv2.convexHull(p.astype(np.float32), returnPoints=False).ravel()
        hulls.append(p[index])
    n = max(len(h) for h in hulls)
    return np.stack([np.vstack([h, np.repeat(h[-1:], n - len(h), axis=0)]) for h in hulls])


def front_facing(triangles: np.ndarray) -> np.ndarray:
    """(M,) bool: which projected triangles (M, 3, 2) the renderer draws. SAPIEN culls back
    faces: a triangle is drawn when its vertices, in their stored order, run counter-clockwise
    as the image is looked at (pixel coordinates x right, y down: a negative signed area;
    tests/sensing/test_silhouette.py renders one of each). A closed mesh's silhouette is the
    union of its front faces alone, so its back faces need no counting."""
    a, b, c = triangles[:, 0], triangles[:, 1], triangles[:, 2]
    twice_area = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (
        b[:, 1] - a[:, 1]
    )
    return twice_area < 0


def _fold(op, x: np.ndarray) -> np.ndarray:
    """``op`` folded over axis 1 one column at a time: the same values as ``x.max(axis=1)``
    (or min, all), several times faster for the few columns of an outline."""
    out = x[:, 0]
    for i in range(1, x.shape[1]):
        out = op(out, x[:, i])
    return out


def row_spans(
    outlines: np.ndarray,
    rows: tuple[int, int],
    cols: tuple[int, int],
    margin: float = SNAP_MARGIN,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pixels whose centres lie at least ``margin`` pixels inside a convex outline (M, N, 2), as
    spans (row, first col, last col), inclusive, within the window rows[0]..rows[1] x
    cols[0]..cols[1]. An outline of no area covers nothing."""
    a = outlines - 0.5  # pixel (col, row) now has its centre at (col, row)
    # an outline whose bounding box holds no pixel centre covers none: most of a detailed
    # mesh's triangles are smaller than a pixel, so they are dropped before the edge work
    low, high = np.ceil(_fold(np.minimum, a)), np.floor(_fold(np.maximum, a))  # (M, 2) cols, rows
    holds = (low[:, 0] <= high[:, 0]) & (low[:, 1] <= high[:, 1])
    holds &= (low[:, 1] <= rows[1]) & (high[:, 1] >= rows[0])
    a = a[holds]
    edge = np.roll(a, -1, axis=1) - a
    length = np.hypot(edge[..., 0], edge[..., 1])
    twice_area = (a[..., 0] * edge[..., 1] - a[..., 1] * edge[..., 0]).sum(axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        # unit normals pointing inside, whichever way round the outline runs; padding edges
        # (zero length) get a zero normal and constrain nothing
        inward = np.sign(twice_area)[:, None, None] * np.stack([-edge[..., 1], edge[..., 0]], -1)
        inward = np.where(length[..., None] > 0, inward / length[..., None], 0.0)
    # a point q is inside when inward . q >= inward . a + margin for every edge
    offset = (inward * a).sum(axis=-1) + np.where(length > 0, margin, -np.inf)

    y = a[..., 1]
    top = np.maximum(np.ceil(_fold(np.minimum, y)), rows[0]).astype(np.int64)
    bottom = np.minimum(np.floor(_fold(np.maximum, y)), rows[1]).astype(np.int64)
    counts = np.where(np.abs(twice_area) > 0, np.maximum(bottom - top + 1, 0), 0)
    which = np.repeat(np.arange(len(a)), counts)
    row = top[which] + np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)

    nx, ny = inward[which, :, 0], inward[which, :, 1]  # (K, N) per span row, per edge
    bound = offset[which] - ny * row[:, None]  # the edge's constraint on x: nx * x >= bound
    with np.errstate(divide="ignore", invalid="ignore"):
        left = _fold(np.maximum, np.where(nx > 0, bound / nx, -np.inf))
        right = _fold(np.minimum, np.where(nx < 0, bound / nx, np.inf))
    row_allowed = _fold(np.logical_and, np.where(nx == 0, bound <= 0, True))  # horizontal edges
    first = np.maximum(np.ceil(left), cols[0])
    last = np.minimum(np.floor(right), cols[1])
    keep = row_allowed & (first <= last)
    return row[keep], first[keep].astype(np.int64), last[keep].astype(np.int64)


def union_pixel_count(row: np.ndarray, first: np.ndarray, last: np.ndarray) -> int:
    """Pixels covered by at least one span (spans of one row may overlap)."""
    if len(row) == 0:
        return 0
    order = np.lexsort((first, row))
    row, first, last = row[order], first[order], last[order]
    starts_row = np.r_[True, row[1:] != row[:-1]]
    # running maximum of `last` over the earlier spans of the same row: offsetting each row by
    # more than any column range keeps np.maximum.accumulate from carrying across rows
    rank = np.cumsum(starts_row)
    base, stride = first.min() - 1, last.max() - first.min() + 2
    running = np.maximum.accumulate(last - base + rank * stride)
    covered_before = np.r_[base - 1, running[:-1] - rank[1:] * stride + base]
    covered_before[starts_row] = base - 1
    start = np.maximum(first, covered_before + 1)
    return int(np.maximum(last - start + 1, 0).sum())


def silhouette_pixels(
    outlines: np.ndarray,
    width: int,
    height: int,
    margin: float = SNAP_MARGIN,
    max_spans: int | None = None,
) -> tuple[int, int] | None:
    """(pixels of the union of convex outlines, of which inside the width x height image), or
    None when that needs more than ``max_spans`` spans. Only WINDOW image sizes beyond each
    border are counted: an object that large in view is truncated anyway, and the work stays
    bounded. Outlines go through in chunks, so a mesh of a million triangles needs no more
    memory than one of a hundred thousand."""
    if len(outlines) == 0:
        return 0, 0
    window_rows = (-WINDOW * height, (WINDOW + 1) * height - 1)
    window_cols = (-WINDOW * width, (WINDOW + 1) * width - 1)
    spans, total = [], 0
    for start in range(0, len(outlines), CHUNK):
        chunk = row_spans(outlines[start : start + CHUNK], window_rows, window_cols, margin)
        total += len(chunk[0])
        if max_spans is not None and total > max_spans:
            return None
        spans.append(chunk)
    row, first, last = (np.concatenate(a) for a in zip(*spans, strict=True))
    inside = (row >= 0) & (row < height)
    clipped = (row[inside], np.maximum(first[inside], 0), np.minimum(last[inside], width - 1))
    keep = clipped[1] <= clipped[2]
    return union_pixel_count(row, first, last), union_pixel_count(*(c[keep] for c in clipped))
