"""USD scene descriptions: ``DIR/usd/<key>.usda``, one per grasp sample or attempt, built from
its metadata by ``datagen/exports/usd_stage.py`` and checked with usd-core's validators."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from tqdm import tqdm

NAME = "usd"


def export(dataset, manifest: dict[str, Any], out: Path) -> list[Path]:
    from datagen.exports.usd_stage import scene_stage, validation_errors

    out.mkdir(parents=True)
    files = []
    for i in tqdm(range(len(dataset)), desc="usd", unit="sample", leave=False):
        stage = scene_stage(dataset.metadata(i))
        errors = validation_errors(stage)
        if errors:
            raise ValueError(f"USD of sample {dataset.keys[i]} fails validation: {errors[:5]}")
        path = out / f"{dataset.keys[i]}.usda"
        stage.GetRootLayer().Export(str(path))
        files.append(path)
    return files
