"""USD scene descriptions: ``DIR/usd/<key>.usda``, one per sample of a tabletop scene (grasp
samples and attempts), built from its metadata by ``datagen/exports/usd_stage.py`` and checked
with usd-core's validators. A sample that names a user's mesh or picture outside the folders of
the dataset's config is refused before anything of it is read (``datagen.dataset.assets``)."""

from __future__ import annotations

from pathlib import Path

from datagen.exports.checks import sample_metadata
from datagen.records import ExportedDataset, Manifest, SampleProgress


def export(
    dataset: ExportedDataset,
    manifest: Manifest,
    out: Path,
    on_progress: SampleProgress | None = None,
) -> list[Path]:
    from pxr import Usd

    from datagen.dataset.assets import check_asset_paths
    from datagen.exports.files import inside, written
    from datagen.exports.usd_stage import scene_stage, validation_errors

    out.mkdir(parents=True)
    files = []
    for i in range(len(dataset)):
        path = inside(out, f"{dataset.keys[i]}.usda")
        meta = sample_metadata(dataset, i)
        check_asset_paths(meta, manifest, dataset.root)  # users' files: the config's folders only
        # textured looks' tiles go to out/textures/; validated from the file, where they resolve
        stage = scene_stage(meta, out)  # type: ignore[arg-type]  # usd_stage: not typed yet
        written(stage.GetRootLayer().Export(str(path)), path, "USD")
        errors = validation_errors(Usd.Stage.Open(str(path)))
        if errors:
            raise ValueError(f"USD of sample {dataset.keys[i]} fails validation: {errors[:5]}")
        files.append(path)
        if on_progress:
            on_progress(i + 1, len(dataset))
    return files
