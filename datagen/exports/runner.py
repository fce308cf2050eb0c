"""Runs the formats exported from a finished dataset's shards. The formats are the records of
``datagen.registries.EXPORTS``: each names the file or folder it writes in the dataset directory
and its ``export(dataset, manifest, out, on_progress=None) -> files`` function, which calls
``on_progress(done, total)`` as samples are exported. Nothing here draws progress bars: callers
pass ``on_progress(format, done, total)`` to :func:`run_exports` and show it as they like.

An export is written beside the shards into a temporary name, renamed into place when complete,
and then recorded in the manifest under ``exports``. An interrupted export leaves no partial
output and is redone by the next ``datagen build --resume`` or ``datagen export``.
"""

from __future__ import annotations

import functools
import os
import shutil
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from datagen.registries import EXPORTS, FAMILIES, STORE, ExportFormat, resolve
from datagen.shards import write_manifest

ExportProgress = Callable[[str, int, int], None]  # (format name, samples done, samples in all)


def _size(path: Path) -> int:
    if path.is_file():
        return path.stat().st_size
    return sum(p.stat().st_size for p in path.rglob("*") if p.is_file())


def _remove(path: Path) -> None:
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path, ignore_errors=True)
    else:
        path.unlink(missing_ok=True)


def check_world(fmt: ExportFormat, manifest: dict[str, Any], root: Path) -> None:
    """Raises DatasetError unless ``fmt`` can describe the dataset's scenes (its ``worlds``)."""
    from datagen.dataset.loader import DatasetError

    if fmt.worlds is None:
        return
    scene = manifest.get("scene")
    family = FAMILIES.get(scene) if isinstance(scene, str) else None
    world = family.world if family else None
    if world not in fmt.worlds:
        known = f"{world} world" if world else "no world" if family else "an unknown family"
        raise DatasetError(
            f"{root}: cannot export {fmt.name!r}: it describes scenes of the "
            f"{' or '.join(fmt.worlds)} world only, and this dataset's scene is {scene!r} ({known})"
        )


def run_exports(
    root: str | os.PathLike,
    sinks,
    force: bool = False,
    on_progress: ExportProgress | None = None,
) -> dict[str, dict[str, Any]]:
    """Exports each of ``sinks`` (other than the webdataset store) not yet recorded in the
    manifest, or every one with ``force``; returns the manifest's ``exports`` record."""
    from datagen.dataset.loader import DatasetError, load, read_manifest

    unknown = [s for s in sinks if s != STORE and s not in EXPORTS]
    if unknown:
        raise DatasetError(
            f"unknown {EXPORTS.kind} {unknown[0]!r}; expected one of {EXPORTS.names()}"
        )
    root = Path(root)
    manifest = read_manifest(root)
    done = dict(manifest.get("exports", {}))
    todo = [EXPORTS[s] for s in sinks if s in EXPORTS and (force or s not in done)]
    if not todo:
        return done
    for fmt in todo:  # refuse before writing anything
        check_world(fmt, manifest, root)
    dataset = load(root)
    for fmt in todo:
        export = resolve(fmt.export)
        final, tmp = root / fmt.path, root / f".{fmt.path}.partial"
        for stale in (tmp, final):
            if stale.is_dir():
                shutil.rmtree(stale)
            else:
                stale.unlink(missing_ok=True)
        start = time.monotonic()
        progress = functools.partial(on_progress, fmt.name) if on_progress else None
        try:
            export(dataset, manifest, tmp, on_progress=progress)
        except BaseException:
            _remove(tmp)  # a failed export leaves nothing behind (Ctrl-C included)
            raise
        os.replace(tmp, final)
        done[fmt.name] = {
            "path": fmt.path,
            "bytes": _size(final),
            "seconds": round(time.monotonic() - start, 3),
        }
        manifest = read_manifest(root) | {"exports": done}
        write_manifest(root, manifest)
    return done
