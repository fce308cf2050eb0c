"""Formats exported from a finished dataset's shards: each sink is one module with ``NAME`` and
``export(dataset, manifest, out) -> files``; this registry is the only place that lists them.

An export is written beside the shards into a temporary name, renamed into place when complete,
and then recorded in the manifest under ``exports``. An interrupted export leaves no partial
output and is redone by the next ``datagen build --resume`` or ``datagen export``.
"""

from __future__ import annotations

import os
import shutil
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from datagen.exports import coco, hdf5, pointcloud, usd
from datagen.shards import write_manifest

EXPORTS: dict[str, tuple[str, Callable]] = {  # sink name -> (path in DIR, export function)
    coco.NAME: ("coco", coco.export),
    hdf5.NAME: ("episodes.h5", hdf5.export),
    pointcloud.NAME: ("pointclouds", pointcloud.export),
    usd.NAME: ("usd", usd.export),
}


def _size(path: Path) -> int:
    if path.is_file():
        return path.stat().st_size
    return sum(p.stat().st_size for p in path.rglob("*") if p.is_file())


def run_exports(root: str | os.PathLike, sinks, force: bool = False) -> dict[str, dict[str, Any]]:
    """Exports each of ``sinks`` (other than webdataset) not yet recorded in the manifest."""
    from datagen.dataset.loader import load, read_manifest

    root = Path(root)
    manifest = read_manifest(root)
    done = dict(manifest.get("exports", {}))
    todo = [s for s in sinks if s in EXPORTS and (force or s not in done)]
    if not todo:
        return done
    dataset = load(root)
    for sink in todo:
        name, export = EXPORTS[sink]
        final, tmp = root / name, root / f".{name}.partial"
        for stale in (tmp, final):
            if stale.is_dir():
                shutil.rmtree(stale)
            else:
                stale.unlink(missing_ok=True)
        start = time.monotonic()
        export(dataset, manifest, tmp)
        os.replace(tmp, final)
        done[sink] = {
            "path": name,
            "bytes": _size(final),
            "seconds": round(time.monotonic() - start, 3),
        }
        manifest = read_manifest(root) | {"exports": done}
        write_manifest(root, manifest)
    return done
