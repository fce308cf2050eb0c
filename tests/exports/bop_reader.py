"""A small reader of BOP datasets, written from the format's documentation
(thodan/bop_toolkit docs/bop_datasets_format.md) and not from datagen's writer: the export test
reads what ``datagen export --to bop`` wrote through it."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

_PLY_TYPES = {"float": "<f4", "double": "<f8", "uchar": "u1", "int": "<i4", "uint": "<u4"}


def load_ply(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """(vertices (N, 3) float64, triangles (F, 3) int) of an ascii or binary little-endian PLY."""
    data = path.read_bytes()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode("ascii").splitlines()
    fmt = next(line.split()[1] for line in header if line.startswith("format"))
    elements: list[tuple[str, int, list[list[str]]]] = []
    for line in header:
        words = line.split()
        if words[0] == "element":
            elements.append((words[1], int(words[2]), []))
        elif words[0] == "property":
            elements[-1][2].append(words[1:])
    vertices = faces = None
    if fmt == "ascii":
        rows = data[end:].decode("ascii").split("\n")
        for name, count, props in elements:
            block, rows = rows[:count], rows[count:]
            if name == "vertex":
                names = [p[-1] for p in props]
                table = np.array([r.split() for r in block], float)
                vertices = table[:, [names.index(a) for a in "xyz"]]
            elif name == "face":
                faces = np.array([r.split()[1:4] for r in block], int)
        return vertices, faces
    assert fmt == "binary_little_endian", fmt
    offset = end
    for name, count, props in elements:
        if props[0][0] == "list":  # faces: a count then the indices, triangles only here
            _, count_type, index_type, _ = props[0]
            dtype = np.dtype([("n", _PLY_TYPES[count_type]), ("i", _PLY_TYPES[index_type], (3,))])
            table = np.frombuffer(data, dtype, count, offset)
            assert (table["n"] == 3).all()
            faces = table["i"].astype(int)
        else:
            dtype = np.dtype([(p[1], _PLY_TYPES[p[0]]) for p in props])
            table = np.frombuffer(data, dtype, count, offset)
            if name == "vertex":
                vertices = np.stack([table[a] for a in "xyz"], 1).astype(float)
        offset += dtype.itemsize * count
    return vertices, faces


@dataclass
class Image:
    scene: Path
    im_id: int
    K: np.ndarray  # (3, 3)
    camera: dict  # its scene_camera record
    depth_mm: np.ndarray  # (H, W) float
    gts: list[dict]  # obj_id, R (3, 3), t (3,) mm, and the scene_gt_info record under "info"

    def mask(self, gt_id: int, visible: bool) -> np.ndarray:
        folder = "mask_visib" if visible else "mask"
        path = self.scene / folder / f"{self.im_id:06d}_{gt_id:06d}.png"
        return cv2.imread(str(path), cv2.IMREAD_UNCHANGED) > 0

    def rgb(self) -> np.ndarray:
        """BGR; a ``train_pbr`` split's colour images are JPEG (bop_toolkit's dataset_params)."""
        return cv2.imread(str(self.scene / "rgb" / f"{self.im_id:06d}.jpg"), cv2.IMREAD_COLOR)


def images(root: Path, split: str = "train_pbr"):
    """Every image of every scene of the split, in order."""
    for scene in sorted((root / split).iterdir()):
        cameras = json.loads((scene / "scene_camera.json").read_text())
        gt = json.loads((scene / "scene_gt.json").read_text())
        info = json.loads((scene / "scene_gt_info.json").read_text())
        for key in sorted(cameras, key=int):
            camera = cameras[key]
            depth = cv2.imread(str(scene / "depth" / f"{int(key):06d}.png"), cv2.IMREAD_UNCHANGED)
            gts = [
                {
                    "obj_id": g["obj_id"],
                    "R": np.array(g["cam_R_m2c"], float).reshape(3, 3),
                    "t": np.array(g["cam_t_m2c"], float),
                    "info": i,
                }
                for g, i in zip(gt[key], info[key], strict=True)
            ]
            yield Image(
                scene,
                int(key),
                np.array(camera["cam_K"], float).reshape(3, 3),
                camera,
                depth.astype(float) * camera["depth_scale"],
                gts,
            )


def project(points_mm: np.ndarray, K: np.ndarray, R: np.ndarray, t: np.ndarray):
    """Model points (N, 3) mm -> image coordinates (N, 2) and camera depth (N,) mm, s p = K [R|t] P."""
    cam = points_mm @ R.T + t
    uvw = cam @ K.T
    return uvw[:, :2] / uvw[:, 2:3], cam[:, 2]


def bbox(mask: np.ndarray) -> list[int]:
    """(x, y, w, h) with w = x_max - x_min, as bop_toolkit's calc_2d_bbox; -1s when empty."""
    ys, xs = np.nonzero(mask)
    if not len(xs):
        return [-1, -1, -1, -1]
    return [int(xs.min()), int(ys.min()), int(xs.max() - xs.min()), int(ys.max() - ys.min())]
