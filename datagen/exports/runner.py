"""Runs the formats exported from a finished dataset's shards. The formats are the records of
``datagen.registries.EXPORTS``: each names the file or folder it writes in the dataset directory
and its ``export(dataset, manifest, out, on_progress=None) -> files`` function, which calls
``on_progress(done, total)`` as samples are exported. Nothing here draws progress bars: callers
pass ``on_progress(format, done, total)`` to :func:`run_exports` and show it as they like.

An export is written beside the shards into a temporary name (``.NAME.partial``), flushed to
disk, renamed into place when complete (an older copy, with ``force``, is kept aside until
then), and then recorded in the manifest under ``exports``. An export that fails or is
interrupted leaves nothing behind and is redone by the next ``datagen build --resume`` or
``datagen export``: a full disk is a BuildError that says "disk full", a sample whose content is
not what datagen writes a DatasetError naming it.
"""

from __future__ import annotations

import functools
import logging
import os
import shutil
import time
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any, NoReturn

from datagen.dataset.manifest import DatasetError, read_manifest
from datagen.dataset.values import BadSample
from datagen.errors import BuildError
from datagen.exports.card import write_export_card
from datagen.exports.episodes import require_episodes
from datagen.exports.files import disk_full, fsync_tree, inside
from datagen.images import ImageInputError
from datagen.records import ExportedDataset, ExportRecord, Manifest
from datagen.registries import EXPORTS, FAMILIES, STORE, ExportFormat
from datagen.shards import fsync_dir, write_json_durably

log = logging.getLogger(__name__)
ExportProgress = Callable[[str, int, int], None]  # (format name, samples done, samples in all)
# what an export meets in a sample whose metadata is not what datagen writes (RuntimeError:
# USD's Tf.ErrorException and Qhull's errors, on a name or a shape they refuse)
_CONTENT_ERRORS = (
    KeyError,
    IndexError,
    TypeError,
    AttributeError,
    ValueError,
    ArithmeticError,
    RuntimeError,
)
# what names the part or the key that is wrong: the user is told it as it is
_NAMED = (DatasetError, ImageInputError, BadSample)


def _size(path: Path) -> int:
    if path.is_file():
        return path.stat().st_size
    return sum(p.stat().st_size for p in path.rglob("*") if p.is_file())


def _remove(path: Path) -> None:
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path, ignore_errors=True)
    else:
        path.unlink(missing_ok=True)


def check_world(fmt: ExportFormat, manifest: Manifest, root: Path) -> None:
    """Raises DatasetError unless ``fmt`` can describe the dataset's scenes (its ``worlds``, and
    episodes for a format of episodes)."""
    if fmt.episodes:
        require_episodes(manifest, root, fmt.name)
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
    formats,
    force: bool = False,
    on_progress: ExportProgress | None = None,
    options: Mapping[str, Mapping[str, Any]] | None = None,
) -> dict[str, ExportRecord]:
    """Exports each of ``formats`` (other than the webdataset store) not yet recorded in the
    manifest or no longer there, or every one with ``force``; returns the manifest's
    ``exports`` record. ``options``: format -> keyword arguments of its export function
    (``{"lerobot": {"robot": "so100_follower"}}``); a format given options is written again."""
    from datagen.dataset.loader import load

    unknown = [s for s in formats if s != STORE and s not in EXPORTS]
    if unknown:
        raise DatasetError(
            f"unknown {EXPORTS.kind} {unknown[0]!r}; expected one of {EXPORTS.names()}"
        )
    root = Path(root)
    manifest = read_manifest(root)
    recorded = manifest.get("exports", {})
    done = dict(recorded) if isinstance(recorded, dict) else {}
    missing = {s for s in done if s in EXPORTS and not os.path.lexists(root / EXPORTS[s].path)}
    options = options or {}
    redo = {s for s in formats if force or s not in done or s in missing or options.get(s)}
    todo = [EXPORTS[s] for s in formats if s in EXPORTS and s in redo]
    if not todo:
        return done
    for fmt in todo:  # refuse before writing anything
        check_world(fmt, manifest, root)
    dataset = load(root)
    for fmt in todo:
        export = functools.partial(fmt.load(), **options.get(fmt.name, {}))
        done[fmt.name] = _export(root, fmt, export, dataset, manifest, done, on_progress)
    return done


def _export(
    root: Path,
    fmt: ExportFormat,
    export: Callable[..., object],
    dataset: ExportedDataset,
    manifest: Manifest,
    done: dict[str, ExportRecord],
    on_progress: ExportProgress | None,
) -> ExportRecord:
    """Writes one format into place and records it in the manifest, or leaves nothing."""
    final = inside(root, fmt.path)
    tmp, aside = inside(root, f".{fmt.path}.partial"), inside(root, f".{fmt.path}.old")
    for stale in (tmp, aside):  # left by a crash
        _remove(stale)
    start, exported = time.monotonic(), [0]

    def progress(count: int, total: int) -> None:
        exported[0] = count
        if on_progress:
            on_progress(fmt.name, count, total)

    try:
        export(dataset, manifest, tmp, on_progress=progress)
        write_export_card(tmp, fmt, dataset)  # README.md + croissant.json in its folder
        fsync_tree(tmp)
    except BaseException as exc:
        _fail(exc, root, fmt, tmp, dataset.keys[exported[0] :][:1])
    if final.exists() or final.is_symlink():
        os.replace(final, aside)
    os.replace(tmp, final)
    record: ExportRecord = {
        "path": fmt.path,
        "bytes": _size(final),
        "seconds": round(time.monotonic() - start, 3),
    }
    try:
        write_json_durably(root, read_manifest(root) | {"exports": done | {fmt.name: record}})
    except BaseException as exc:  # as it was: the older copy back in place
        os.replace(final, tmp)
        if aside.exists() or aside.is_symlink():
            os.replace(aside, final)
        _fail(exc, root, fmt, tmp, [])
    _remove(aside)
    fsync_dir(root)
    return record


def _fail(
    exc: BaseException, root: Path, fmt: ExportFormat, tmp: Path, keys: list[str]
) -> NoReturn:
    """Removes ``tmp`` and raises what the user is told: "disk full", or the sample (``keys``:
    the one being exported, if any) whose content the export could not use."""
    full = disk_full(exc, tmp)  # before the removal frees space
    _remove(tmp)
    sample = f"sample {keys[0]}, " if keys else ""
    if full:
        where = getattr(exc, "filename", None) or tmp
        raise BuildError(
            f"disk full: the {fmt.name} export of {root} needs more space than is free "
            f"(writing {where}); nothing of it was kept"
        ) from None
    if isinstance(exc, _NAMED) and not str(exc).startswith(str(root)):  # says what is wrong
        raise DatasetError(f"{root}: {sample}{fmt.name} export: {exc}") from None
    if isinstance(exc, _CONTENT_ERRORS) and not isinstance(exc, _NAMED):
        log.info("export %s of %s failed", fmt.name, root, exc_info=exc)
        raise DatasetError(
            f"{root}: the dataset's content is not what datagen writes ({sample}{fmt.name} "
            f"export: {type(exc).__name__}: {str(exc)[:200]}); -v shows where"
        ) from None
    raise exc
