"""The BOP export's object models: one per distinct shape record, met as the samples stream.

An object's ``shape`` record (``datagen.assets.shapes.build_geometry``, the mesh the renderer
draws) is its identity: the first object with a given record gets the next ``obj_id`` (1, 2, ...)
and its model is written then, ``models/obj_{id:06d}.ply`` (binary PLY: vertices and angle-weighted
normals in millimetres, triangles). BOP wants the model's origin at the centre of its 3D box, so
the mesh is moved by ``-centre`` (the centre of its axis-aligned box in datagen's object frame) and
a pose ``T_o2c`` of datagen's object becomes ``T_o2c @ translate(centre)``. Symmetries are found
on the mesh itself: continuous about a model axis where every vertex lies on a ring of >= 16
vertices about it (a revolved or cylindrical shape), every vertex at one distance from the origin
(a sphere: continuous about x, y and z); discrete where an axis-aligned rotation (the cube's 24)
maps the vertices onto themselves (a box, a symmetric prism), less those a continuous symmetry
already covers.
"""

from __future__ import annotations

import hashlib
import itertools
import json
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from scipy.spatial import ConvexHull, QhullError, cKDTree

from datagen.assets.shapes import build_geometry
from datagen.exports.checks import finite_json
from datagen.exports.files import inside

RING_VERTICES = 16  # a ring of fewer vertices is a polygon (an octagonal prism is no cylinder)
MATCH_TOLERANCE = 1e-3  # of the diameter: a vertex's image this close to a vertex matches it


def _cube_rotations() -> list[np.ndarray]:
    """The 23 proper rotations (other than the identity) mapping the axes onto the axes."""
    rotations = []
    for perm in itertools.permutations(range(3)):
        for signs in itertools.product((1.0, -1.0), repeat=3):
            rot = np.zeros((3, 3))
            rot[range(3), perm] = signs
            if np.linalg.det(rot) > 0 and not np.allclose(rot, np.eye(3)):
                rotations.append(rot)
    return rotations


_ROTATIONS = _cube_rotations()


def _revolved_about(vertices: np.ndarray, axis: int, tol: float) -> bool:
    """Whether every vertex lies on a ring of >= RING_VERTICES vertices about the axis (or on it)."""
    height = np.round(vertices[:, axis] / tol)
    radius = np.round(np.linalg.norm(np.delete(vertices, axis, 1), axis=1) / tol)
    on_axis = radius == 0
    rings = np.stack([height[~on_axis], radius[~on_axis]], 1)
    if not len(rings):
        return False
    _, counts = np.unique(rings, axis=0, return_counts=True)
    return bool(counts.min() >= RING_VERTICES)


def symmetries(vertices: np.ndarray, diameter: float) -> dict[str, Any]:
    """``symmetries_continuous`` / ``symmetries_discrete`` (BOP's models_info keys) of a centred
    mesh's vertices (N, 3) in mm; empty when it has none."""
    tol = MATCH_TOLERANCE * diameter
    distance = np.linalg.norm(vertices, axis=1)
    if len(vertices) >= 20 and np.ptp(distance) <= 2 * tol:  # a sphere
        axes = [0, 1, 2]
    else:
        axes = [a for a in range(3) if _revolved_about(vertices, a, 2 * tol)]
    found: dict[str, Any] = {}
    if axes:
        found["symmetries_continuous"] = [
            {"axis": np.eye(3, dtype=int)[a].tolist(), "offset": [0, 0, 0]} for a in axes
        ]
    if len(axes) > 1:  # every rotation is one of the continuous ones
        return found
    tree = cKDTree(vertices)
    kept: list[np.ndarray] = []
    for rot in _ROTATIONS:
        if axes and (rot[axes[0], axes[0]] == 1 or kept):
            continue  # about the continuous axis, or one flip of it is kept already
        if tree.query(vertices @ rot.T, distance_upper_bound=tol)[0].max() <= tol:
            kept.append(rot)
    if kept:
        found["symmetries_discrete"] = [
            np.block([[rot, np.zeros((3, 1))], [np.zeros((1, 3)), 1.0]]).ravel().tolist()
            for rot in kept
        ]
    return found


def _diameter(vertices: np.ndarray) -> float:
    """Largest distance between two vertices (those of the convex hull: the same), in blocks
    of rows so that a large user mesh needs little memory."""
    try:
        points = vertices[ConvexHull(vertices, qhull_options="QJ").vertices]
    except (QhullError, ValueError):  # flat or too few points: every vertex
        points = vertices
    best = 0.0
    for start in range(0, len(points), 512):
        block = points[start : start + 512]
        best = max(best, float(((block[:, None, :] - points[None, :, :]) ** 2).sum(-1).max()))
    return float(np.sqrt(best))


def dump_json(path: Path, doc: Mapping[Any, Any]) -> None:
    """JSON as bop_toolkit writes it: one line per top-level key."""
    finite_json(doc, path.name)
    lines = ",\n".join(
        f"  {json.dumps(str(k), allow_nan=False)}: {json.dumps(v, allow_nan=False)}"
        for k, v in doc.items()
    )
    path.write_text("{\n" + lines + "\n}\n" if doc else "{}\n")


def write_ply(path: Path, vertices: np.ndarray, normals: np.ndarray, faces: np.ndarray) -> None:
    """Binary little-endian PLY: float x y z nx ny nz per vertex, uchar-counted int triangles."""
    header = (
        "ply\nformat binary_little_endian 1.0\ncomment datagen BOP model, millimetres\n"
        f"element vertex {len(vertices)}\n"
        + "".join(f"property float {n}\n" for n in ("x", "y", "z", "nx", "ny", "nz"))
        + f"element face {len(faces)}\nproperty list uchar int vertex_indices\nend_header\n"
    )
    vertex_rows = np.hstack([vertices, normals]).astype("<f4")
    face_rows = np.zeros(len(faces), dtype=[("n", "u1"), ("idx", "<i4", (3,))])
    face_rows["n"], face_rows["idx"] = 3, faces
    with open(path, "wb") as f:
        f.write(header.encode("ascii"))
        f.write(vertex_rows.tobytes())
        f.write(face_rows.tobytes())


@dataclass(frozen=True)
class Model:
    """An object's model: its id, mesh (mm, about its centre) and object-frame centre (m)."""

    obj_id: int
    centre: np.ndarray  # (3,) metres, in datagen's object frame
    vertices: np.ndarray  # (N, 3) mm
    faces: np.ndarray  # (F, 3)

    def to_model(self, object_to_camera: np.ndarray) -> np.ndarray:
        """A pose of datagen's object (4x4, metres) -> the pose of this model (4x4, metres)."""
        shift = np.eye(4)
        shift[:3, 3] = self.centre
        return np.asarray(object_to_camera, float) @ shift


def _info(vertices: np.ndarray) -> dict[str, Any]:
    """BOP's models_info record of a centred mesh's vertices (mm)."""
    diameter = _diameter(vertices)
    lo, hi = vertices.min(0), vertices.max(0)
    record: dict[str, Any] = {"diameter": diameter}
    for axis, name in enumerate("xyz"):
        record[f"min_{name}"], record[f"size_{name}"] = float(lo[axis]), float(hi[axis] - lo[axis])
    return record | symmetries(vertices, diameter)


class ModelSet:
    """The models of ``folder`` (``models/``), an id per distinct shape record as met. Only
    each id's small records stay in memory (the meshes are rebuilt, cached, per sample)."""

    def __init__(self, folder: Path):
        self.folder = folder
        folder.mkdir(parents=True)
        self.ids: dict[str, int] = {}  # sha256 of the shape record's JSON -> obj_id
        self.info: dict[int, dict[str, Any]] = {}
        self.records: dict[int, dict[str, Any]] = {}

    def model(self, obj: dict[str, Any], key: str) -> Model:
        """The model of object record ``obj`` (``shape``, ``class``, ``instance_id``) of sample
        ``key``; written when its shape is new."""
        visual = build_geometry(obj["shape"]).visual
        lo, hi = visual.bounds
        centre = (lo + hi) / 2
        vertices = (np.asarray(visual.vertices) - centre) * 1000.0
        digest = hashlib.sha256(
            json.dumps(obj["shape"], sort_keys=True, allow_nan=False).encode()
        ).hexdigest()
        obj_id = self.ids.setdefault(digest, len(self.ids) + 1)
        if obj_id not in self.info:
            path = inside(self.folder, f"obj_{obj_id:06d}.ply")
            write_ply(path, vertices, np.asarray(visual.vertex_normals), np.asarray(visual.faces))
            self.info[obj_id] = _info(vertices)
            self.records[obj_id] = {
                "class": obj["class"],
                "family": obj["shape"].get("family"),
                "centre_m": centre.round(9).tolist(),
                "first_seen": {"key": key, "instance_id": obj["instance_id"]},
            }
        return Model(obj_id, centre, vertices, np.asarray(visual.faces))

    def write_info(self) -> list[Path]:
        """``models_info.json`` (BOP's) and ``models_datagen.json`` (each id's class, family,
        the object-frame centre its origin sits at, and the first object with its shape)."""
        paths = [self.folder / "models_info.json", self.folder / "models_datagen.json"]
        dump_json(paths[0], self.info)
        dump_json(paths[1], self.records)
        return paths


@dataclass(frozen=True)
class Silhouette:
    """A model's whole silhouette: ``image`` (h, w) bool, its part inside the image; ``count``
    pixels and ``box`` [x0, y0, x1, y1] (inclusive, None when empty) of all of it, the part
    outside the image included (as far as 1 image width or height beyond each side)."""

    image: np.ndarray
    count: int
    box: list[int] | None


def silhouette(
    model: Model, model_to_camera: np.ndarray, K: np.ndarray, size: tuple[int, int], near: float
) -> Silhouette:
    """The model's silhouette through ``K``: a pixel is in where its centre is inside a
    projected triangle (as datagen measures silhouettes); triangles crossing the near plane
    (metres) are clipped to it."""
    w, h = size
    near = max(near, 1e-3)
    cam = (model.vertices / 1000.0) @ model_to_camera[:3, :3].T + model_to_camera[:3, 3]
    triangles = cam[model.faces]  # (F, 3, 3)
    front = (triangles[:, :, 2] >= near).sum(1)
    parts = [triangles[front == 3]]
    for i in np.nonzero((front > 0) & (front < 3))[0]:  # the clipped polygon, fanned
        poly = _clip_near(triangles[i], triangles[i, :, 2] >= near, near)
        parts.append(np.stack([np.repeat(poly[:1], len(poly) - 2, 0), poly[1:-1], poly[2:]], 1))
    tris = np.concatenate(parts)
    image = np.zeros((h, w), bool)
    if not len(tris):
        return Silhouette(image, 0, None)
    # pixel centres at integers (K puts them at col + .5, row + .5)
    xy = tris[..., :2] / tris[..., 2:3] * [K[0, 0], K[1, 1]] + [K[0, 2] - 0.5, K[1, 2] - 0.5]
    lo = np.clip(np.floor(xy.reshape(-1, 2).min(0)), [-w, -h], [2 * w, 2 * h]).astype(int)
    hi = np.clip(np.ceil(xy.reshape(-1, 2).max(0)) + 1, [-w, -h], [2 * w, 2 * h]).astype(int)
    window = _fill(xy - lo, *(hi - lo))  # the silhouette's bounding window, within 3x the image
    rows, cols = np.nonzero(window)
    if not len(rows):
        return Silhouette(image, 0, None)
    x0, y0 = max(lo[0], 0), max(lo[1], 0)
    x1, y1 = min(hi[0], w), min(hi[1], h)
    if x0 < x1 and y0 < y1:
        image[y0:y1, x0:x1] = window[y0 - lo[1] : y1 - lo[1], x0 - lo[0] : x1 - lo[0]]
    box = [
        int(cols.min() + lo[0]),
        int(rows.min() + lo[1]),
        int(cols.max() + lo[0]),
        int(rows.max() + lo[1]),
    ]
    return Silhouette(image, len(rows), box)


def _fill(xy: np.ndarray, width: int, height: int) -> np.ndarray:
    """Pixels (height, width) whose centre (integer x, y) lies in one of the triangles (T, 3, 2):
    each triangle's span on each row it crosses, summed as +1/-1 steps along the row."""
    ys = xy[..., 1]
    first = np.clip(np.ceil(ys.min(1)), 0, height).astype(np.int64)
    last = np.clip(np.floor(ys.max(1)), -1, height - 1).astype(np.int64)
    rows_per = np.maximum(last - first + 1, 0)
    tri = np.repeat(np.arange(len(xy)), rows_per)
    row = (np.arange(len(tri)) - np.repeat(np.cumsum(rows_per) - rows_per, rows_per)) + first[tri]
    a, b = xy[tri], np.roll(xy[tri], -1, axis=1)  # (N, 3, 2): each edge's two ends
    y = row[:, None].astype(float)
    dy = b[..., 1] - a[..., 1]
    crosses = (
        (np.minimum(a[..., 1], b[..., 1]) <= y)
        & (y <= np.maximum(a[..., 1], b[..., 1]))
        & (dy != 0)
    )
    with np.errstate(divide="ignore", invalid="ignore"):
        x = a[..., 0] + (y - a[..., 1]) * (b[..., 0] - a[..., 0]) / dy
    left = np.ceil(np.where(crosses, x, np.inf).min(1))
    right = np.floor(np.where(crosses, x, -np.inf).max(1))
    ok = (left <= right) & (right >= 0) & (left <= width - 1)
    left = np.clip(left[ok], 0, width - 1).astype(np.int64)
    right = np.clip(right[ok], 0, width - 1).astype(np.int64)
    steps = np.zeros((height, width + 1), np.int32)
    np.add.at(steps, (row[ok], left), 1)
    np.add.at(steps, (row[ok], right + 1), -1)
    return np.cumsum(steps[:, :width], axis=1) > 0


def _clip_near(tri: np.ndarray, keep: np.ndarray, near: float) -> np.ndarray:
    """The part of a triangle (3, 3) at z >= near, a polygon (k, 3)."""
    out = []
    for i in range(3):
        a, b = tri[i], tri[(i + 1) % 3]
        if keep[i]:
            out.append(a)
        if keep[i] != keep[(i + 1) % 3]:
            out.append(a + (b - a) * (near - a[2]) / (b[2] - a[2]))
    return np.asarray(out)
