"""The manifest the coordinator hands the writers to finalise: what was built, how, with which
versions (``DIR/manifest.json`` once every sample is durable)."""

from __future__ import annotations

import contextlib
import os
import platform
from importlib import metadata
from typing import Any

from datagen.config import BuildConfig
from datagen.config.pictures import picture_report
from datagen.pipeline.out_dir import DATASET_FORMAT, now_utc
from datagen.registries import FAMILIES
from datagen.transport.wire import VERSION as WIRE_VERSION

_VERSIONED_PACKAGES = (
    "datagen",
    "sapien",
    "mani-skill",
    "numpy",
    "opencv-python-headless",
    "trimesh",
    "paho-mqtt",
)


def _versions() -> dict[str, str]:
    versions = {"python": platform.python_version(), "platform": platform.platform()}
    # OpenBLAS's kernel decides metadata's low digits (docs/configuration.md, "Reproducibility");
    # the coordinator's, which its local workers inherit
    versions["OPENBLAS_CORETYPE"] = os.environ.get("OPENBLAS_CORETYPE", "unset")
    for name in _VERSIONED_PACKAGES:
        with contextlib.suppress(metadata.PackageNotFoundError):
            versions[name] = metadata.version(name)
    return versions


def build_manifest(config: BuildConfig, build_id: str, workers: int) -> dict[str, Any]:
    return (
        {
            "dataset_format": DATASET_FORMAT,
            "build_id": build_id,
            "created_utc": now_utc(),
            "scene": config.scene,
            "seed": config.seed,
            "num_samples": config.num_samples,
            "workers": workers,
            "classes": list(FAMILIES[config.scene].class_names(config)),
            "wire_format_version": WIRE_VERSION,
            "config": config.to_dict(),
            "versions": _versions(),
        }
        | _asset_report(config)
        | picture_report(config)
    )


def _asset_report(config: BuildConfig) -> dict[str, Any]:
    if config.objects.source != "folder":
        return {}
    from datagen.assets.mesh_library import load_library  # parses every mesh: only when used

    return {"assets": load_library(config.objects.assets_dir).report()}
