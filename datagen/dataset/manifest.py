"""``manifest.json`` as a reader meets it: ``read_manifest`` checks that a directory holds a
datagen dataset of a format this datagen reads (docs/dataset-format.md), and ``DatasetError``
says what is wrong, naming the path."""

from __future__ import annotations

import re
import unicodedata
from pathlib import Path
from typing import Any, cast

from datagen.errors import DatasetError
from datagen.records import Manifest
from datagen.safe_json import JsonInputError, loads_bounded
from datagen.sample import BUILD_ID_RULE, valid_build_id
from datagen.shards import (
    DATASET_FORMAT,
    DATASET_FORMAT_NAME,
    DATASET_FORMAT_VERSION,
    MANIFEST,
)

_FORMAT = re.compile(rf"^{re.escape(DATASET_FORMAT_NAME)}/(\d{{1,9}})$")
# 10^6 samples' digests take 89 MB (docs/dataset-format.md); a manifest beyond is not datagen's
MAX_MANIFEST_BYTES = 2**30
MAX_TEXT_CHARS = 1000  # a class name, a version, a date: far fewer
# control characters and line or paragraph separators: what could end a line of YAML or Markdown
_NOT_TEXT = ("Cc", "Cs", "Zl", "Zp")
__all__ = ["DatasetError", "fields_problem", "format_problem", "read_manifest"]


def read_manifest(root: str | Path) -> Manifest:
    """``root/manifest.json``, checked to be a datagen manifest of a format this datagen reads:
    a ``shards`` list of records naming files in ``root``, a ``samples`` count. Raises
    DatasetError naming the path."""
    path = Path(root) / MANIFEST
    try:
        found = None if Path(root).is_dir() else Path(root).exists()
        size = path.stat().st_size if found is None and path.is_file() else None
        if size is not None and size > MAX_MANIFEST_BYTES:
            raise DatasetError(f"{path}: {size} bytes, more than a manifest may hold")
        data = path.read_bytes() if size is not None else None
    except OSError as exc:
        raise DatasetError(f"{exc.filename or path}: cannot read it: {exc.strerror}") from None
    if found is not None:
        what = "not a directory" if found else "no such directory"
        raise DatasetError(f"{root}: {what}; expected a dataset directory (with {MANIFEST})")
    if data is None:
        raise DatasetError(f"{root} is not a datagen dataset: no {MANIFEST} (not finalized?)")
    try:
        manifest = loads_bounded(data, what=str(path), max_bytes=MAX_MANIFEST_BYTES)
    except JsonInputError as exc:
        raise DatasetError(str(exc)) from None
    if not isinstance(manifest, dict):
        raise DatasetError(f"{path}: not a JSON object; not a datagen manifest")
    if problem := format_problem(manifest.get("dataset_format")):
        raise DatasetError(f"{path}: {problem}")
    if not isinstance(manifest.get("shards"), list):
        raise DatasetError(f"{path}: no 'shards' list; not a datagen manifest")
    for i, record in enumerate(manifest["shards"]):
        if problem := _shard_record_problem(record):
            raise DatasetError(f"{path}: shards[{i}]: {problem}; not a datagen manifest")
    samples = manifest.get("samples")
    if samples is not None and (type(samples) is not int or samples < 0):
        raise DatasetError(f"{path}: 'samples' is {repr(samples)[:60]}, expected a count")
    if problem := fields_problem(manifest):
        raise DatasetError(f"{path}: {problem}; not a manifest datagen writes")
    return cast(Manifest, manifest)  # the keys a reader uses, checked above


def fields_problem(manifest: dict[str, Any]) -> str | None:
    """What is wrong with the manifest's fields that readers and exports write out as text
    (build id, scene, seed, classes, versions, ...), or None; a field may be absent."""
    checks = (
        ("build_id", valid_build_id, f"a build id ({BUILD_ID_RULE})"),
        ("scene", _scene_name, "a scene family's name (a Python identifier)"),
        ("seed", lambda v: type(v) is int, "a whole number"),
        ("num_samples", lambda v: type(v) is int and v >= 0, "a count"),
        ("created_utc", _text, "a line of text"),
        ("datagen_version", _text, "a line of text"),
        ("classes", lambda v: isinstance(v, list) and all(map(_text, v)), "a list of class names"),
        ("versions", _texts, "an object of names and versions"),
        (
            "exports",
            lambda v: _objects(v) and all(map(_objects, v.values())),
            "an object of records",
        ),
        *((name, _objects, "an object") for name in ("config", "campaign")),
    )
    for name, valid, expected in checks:
        if name in manifest and not valid(manifest[name]):
            return f"{name!r} is {repr(manifest[name])[:60]}, expected {expected}"
    return None


def _text(value: Any) -> bool:
    """A string of at most ``MAX_TEXT_CHARS`` without control characters or line breaks."""
    return (
        isinstance(value, str)
        and len(value) <= MAX_TEXT_CHARS
        and not any(unicodedata.category(c) in _NOT_TEXT for c in value)
    )


def _texts(value: Any) -> bool:
    return _objects(value) and all(_text(k) and _text(v) for k, v in value.items())


def _scene_name(value: Any) -> bool:
    return isinstance(value, str) and value.isidentifier() and len(value) <= 64


def _objects(value: Any) -> bool:
    return isinstance(value, dict)


def format_problem(dataset_format: Any) -> str | None:
    """Why this datagen cannot read a manifest of ``dataset_format``, or None. A manifest
    without one is read as version 1, the only version before the field was required."""
    if dataset_format is None:
        return None
    match = _FORMAT.match(dataset_format) if isinstance(dataset_format, str) else None
    if match is None or int(match[1]) < 1:
        return (
            f"dataset_format {repr(dataset_format)[:60]} is not a datagen dataset format "
            f"(expected {DATASET_FORMAT!r})"
        )
    if int(match[1]) > DATASET_FORMAT_VERSION:
        return (
            f"dataset_format {dataset_format!r} is newer than this datagen, which reads "
            f"{DATASET_FORMAT} and older; upgrade datagen to read it"
        )
    return None


def _shard_record_problem(record: Any) -> str | None:
    """What is wrong with one record of a manifest's ``shards``, or None."""
    if not isinstance(record, dict):
        return f"expected a record with a 'name', got {repr(record)[:60]}"
    name = record.get("name")
    if not isinstance(name, str) or name in ("", ".", "..") or any(c in name for c in "/\\\0"):
        return f"'name' is {repr(name)[:60]}, expected the file name of a shard in the dataset"
    for count in ("bytes", "samples"):
        value = record.get(count, 0)
        if type(value) is not int or value < 0:
            return f"'{count}' is {repr(value)[:60]}, expected a count"
    digests = record.get("sample_sha256", {})
    if not isinstance(digests, dict):
        return f"'sample_sha256' is {repr(digests)[:60]}, expected an object (key -> sha256)"
    return None
