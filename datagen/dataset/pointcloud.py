"""Labelled point clouds from depth and intrinsics, per view or fused across a sample's views in
the world frame, written as PLY files that Open3D reads (``open3d.t.io.read_point_cloud`` keeps
the ``instance`` and ``semantic`` attributes; the legacy reader gets positions and colours)."""

from __future__ import annotations

import errno
from pathlib import Path
from typing import Literal, overload

import numpy as np

from datagen.dataset.parts import decode_parts
from datagen.dataset.views import labelled_views
from datagen.geometry import undistorted_normalised
from datagen.records import SampleMetadata

_IMAGE_PARTS = ("rgb.png", "depth.png", "seg.png", "semantic.png")


def view_points(
    depth_mm: np.ndarray,
    intrinsics,
    extrinsics,
    depth_scale: float = 0.001,
    stride: int = 1,
    distortion=None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """World points (N, 3) of the pixels with depth, and their rows and columns (every
    ``stride``-th pixel). Pixel (col, row) has its centre at (col + 0.5, row + 0.5). With
    ``distortion`` (OpenCV k1, k2, p1, p2, k3: a view's ``camera.distortion``) the pixel
    centres are undistorted first, so the cloud stays metric."""
    rows, cols = np.nonzero(depth_mm[::stride, ::stride] > 0)
    rows, cols = rows * stride, cols * stride
    z = depth_mm[rows, cols].astype(np.float64) * depth_scale
    rays = _rays(cols + 0.5, rows + 0.5, np.asarray(intrinsics, float), distortion)
    camera = np.vstack([rays * z, np.ones_like(z)])
    world = (np.linalg.inv(np.asarray(extrinsics, float)) @ camera)[:3].T
    return world, rows, cols


def _rays(u: np.ndarray, v: np.ndarray, intrinsics: np.ndarray, distortion) -> np.ndarray:
    """(3, N) camera-frame directions with z = 1 through image-plane points (u, v)."""
    if distortion is None or not any(distortion):
        return np.linalg.inv(intrinsics) @ np.stack([u, v, np.ones_like(u)])
    normalised = undistorted_normalised(np.stack([u, v], -1), intrinsics, distortion)
    return np.vstack([normalised.T, np.ones(len(normalised))])


PointCloud = dict[str, np.ndarray]  # array name -> one value per point


@overload
def sample_point_cloud(
    raw: dict[str, bytes], meta: SampleMetadata, stride: int = 1, fuse: Literal[True] = True
) -> PointCloud: ...


@overload
def sample_point_cloud(
    raw: dict[str, bytes], meta: SampleMetadata, stride: int = 1, *, fuse: Literal[False]
) -> list[PointCloud]: ...


def sample_point_cloud(
    raw: dict[str, bytes], meta: SampleMetadata, stride: int = 1, fuse: bool = True
) -> PointCloud | list[PointCloud]:
    """The labelled cloud of every view of one stored sample (``dataset.raw(i)`` and its
    metadata): fused into one (``fuse``) or one per view. Arrays: positions (N, 3) float32
    metres (world), colors (N, 3) uint8, instance (N,) int32, semantic (N,) int32, view (N,)
    int32 (the view's number)."""
    clouds = []
    for number, view in enumerate(labelled_views(meta)):
        images = decode_parts(
            {p: raw[view.prefix + p] for p in _IMAGE_PARTS if view.prefix + p in raw}
        )
        camera = view.camera
        world, rows, cols = view_points(
            images["depth"],
            camera["intrinsics"],
            camera["extrinsics_world_to_camera"],
            camera.get("depth_scale", 0.001),
            stride,
            camera.get("distortion"),
        )
        clouds.append(
            {
                "positions": world.astype(np.float32),
                "colors": images["rgb"][rows, cols],
                "instance": images["seg"][rows, cols].astype(np.int32),
                "semantic": images["semantic"][rows, cols].astype(np.int32),
                "view": np.full(len(rows), number, np.int32),
            }
        )
    if not fuse:
        return clouds
    return {k: np.concatenate([c[k] for c in clouds]) for k in clouds[0]}


def write_ply(path: str | Path, cloud: dict[str, np.ndarray]) -> None:
    import open3d as o3d

    pcd = o3d.t.geometry.PointCloud()
    pcd.point.positions = o3d.core.Tensor(cloud["positions"].astype(np.float32))
    pcd.point.colors = o3d.core.Tensor(cloud["colors"].astype(np.float32) / 255.0)
    for name in ("instance", "semantic", "view"):
        pcd.point[name] = o3d.core.Tensor(cloud[name].astype(np.int32).reshape(-1, 1))
    if not o3d.t.io.write_point_cloud(str(path), pcd) or not _whole_ply(Path(path)):
        raise OSError(errno.EIO, "Open3D could not write it whole", str(path))


_PLY_TYPE_BYTES = {
    "char": 1,
    "uchar": 1,
    "short": 2,
    "ushort": 2,
    "int": 4,
    "uint": 4,
    "float": 4,
    "double": 8,
}


def _whole_ply(path: Path) -> bool:
    """Whether a binary PLY of vertices is as long as its header says (Open3D reports success
    when a write fails part way, on a full disk say)."""
    with open(path, "rb") as f:
        head = f.read(4096)
    end = head.find(b"end_header\n")
    lines = head[:end].decode("ascii", "replace").splitlines()
    vertices = [int(line.split()[2]) for line in lines if line.startswith("element vertex ")]
    sizes = [
        _PLY_TYPE_BYTES.get(line.split()[1], 0) for line in lines if line.startswith("property ")
    ]
    expected = end + len(b"end_header\n") + sum(vertices) * sum(sizes)
    return end >= 0 and path.stat().st_size == expected


def read_ply(path: str | Path) -> dict[str, np.ndarray]:
    import open3d as o3d

    pcd = o3d.t.io.read_point_cloud(str(path))
    out = {
        "positions": pcd.point.positions.numpy(),
        "colors": np.rint(pcd.point.colors.numpy() * 255).astype(np.uint8),
    }
    for name in ("instance", "semantic", "view"):
        if name in pcd.point:
            out[name] = pcd.point[name].numpy().reshape(-1).astype(np.int32)
    return out
