"""Labelled point clouds: ``DIR/pointclouds/<key>.ply``, one per sample, fused in the world frame
across its views (grasp: workspace and wrist cameras; navigation: every frame of the episode,
every ``SEQUENCE_STRIDE``-th pixel). See ``datagen/dataset/pointcloud.py``."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from tqdm import tqdm

from datagen.dataset.pointcloud import sample_point_cloud, write_ply

NAME = "pointcloud"
SEQUENCE_STRIDE = 4  # pixels: an episode's many frames would make clouds of millions of points


def export(dataset, manifest: dict[str, Any], out: Path) -> list[Path]:
    out.mkdir(parents=True)
    files = []
    for i in tqdm(range(len(dataset)), desc="pointcloud", unit="sample", leave=False):
        meta = dataset.metadata(i)
        stride = SEQUENCE_STRIDE if "frames" in meta else 1
        path = out / f"{dataset.keys[i]}.ply"
        write_ply(path, sample_point_cloud(dataset.raw(i), meta, stride=stride))
        files.append(path)
    return files
