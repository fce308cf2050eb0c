"""Labelled point clouds: ``DIR/pointclouds/<key>.ply``, one per sample, fused in the world frame
across its views (every camera of a sample; every frame of a sequence, every
``SEQUENCE_STRIDE``-th pixel). See ``datagen/dataset/pointcloud.py``."""

from __future__ import annotations

from pathlib import Path

from datagen.dataset.pointcloud import sample_point_cloud, write_ply
from datagen.dataset.views import is_sequence, labelled_views
from datagen.exports.checks import sample_metadata
from datagen.exports.files import inside
from datagen.records import ExportedDataset, Manifest, SampleProgress

SEQUENCE_STRIDE = 4  # pixels: a sequence's many frames would make clouds of millions of points


def export(
    dataset: ExportedDataset,
    manifest: Manifest,
    out: Path,
    on_progress: SampleProgress | None = None,
) -> list[Path]:
    out.mkdir(parents=True)
    files = []
    for i in range(len(dataset)):
        meta = sample_metadata(dataset, i)
        stride = SEQUENCE_STRIDE if is_sequence(labelled_views(meta)) else 1
        path = inside(out, f"{dataset.keys[i]}.ply")
        write_ply(path, sample_point_cloud(dataset.raw(i), meta, stride=stride))
        files.append(path)
        if on_progress:
            on_progress(i + 1, len(dataset))
    return files
