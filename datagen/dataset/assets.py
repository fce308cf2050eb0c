"""The users' files a sample's metadata makes a reader open, checked before anything is read.

A sample names two kinds: a user's mesh (a shape's ``asset``: ``root``, the folder the mesh
library scans, and ``path`` in it) and a user's picture (a texture of family ``image``: the
picture ``root/path``). A dataset is untrusted input (issue 22): a sample may name only the
folders its own manifest's config names (``objects.assets_dir`` for meshes;
``materials.textures_dir`` and ``background.images_dir`` for pictures), and a ``path`` that
stays inside that folder, both resolved (links followed) and compared. The USD export and replay
call :func:`check_asset_paths` on a sample before they build its scene: anything else is a
DatasetError naming the key, and nothing of it is read (``"/"`` as a mesh folder would have the
library walk the whole file system, a picture path may name any file).
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from datagen.assets.texture_tiles import IMAGE_FAMILY
from datagen.config.pictures import PICTURE_FOLDERS
from datagen.dataset.manifest import DatasetError
from datagen.records import Manifest, SampleMetadata

# (section, key) of the config's folders a sample's metadata may name, per kind of file
CONFIG_FOLDERS = {"mesh": (("objects", "assets_dir"),), "picture": PICTURE_FOLDERS}
_PLURAL = {"mesh": "meshes", "picture": "pictures"}


def _real(path: str) -> str | None:
    """``path`` resolved (absolute, links followed), or None if it is not a usable path."""
    try:
        return os.path.realpath(path)
    except (OSError, ValueError):  # a NUL character, ...
        return None


def config_folders(manifest: Manifest, root: str | Path) -> dict[str, dict[str, str]]:
    """Per kind, the folders the manifest's config names (``"materials.textures_dir"`` -> the
    folder resolved; a relative one from ``root``, as replay reads the config)."""
    config = manifest.get("config")
    folders: dict[str, dict[str, str]] = {kind: {} for kind in CONFIG_FOLDERS}
    for kind, keys in CONFIG_FOLDERS.items():
        for section, key in keys:
            value = config.get(section, {}).get(key) if isinstance(config, dict) else None
            if isinstance(value, str) and value and isinstance(config.get(section), dict):
                real = _real(os.path.join(root, value))
                if real is not None:
                    folders[kind][f"{section}.{key}"] = real
    return folders


def asset_records(meta: Any) -> Iterator[tuple[str, Any, str]]:
    """(where, record, kind) of every record in the metadata that names a user's file: a
    shape's ``asset`` (kind ``mesh``) and a texture of family ``image`` (kind ``picture``)."""
    stack: list[tuple[str, Any]] = [("", meta)]
    while stack:
        where, value = stack.pop()
        if isinstance(value, dict):
            if "asset" in value:
                yield f"{where}.asset".lstrip("."), value["asset"], "mesh"
            if value.get("family") == IMAGE_FAMILY:
                yield where, value, "picture"
            stack.extend((f"{where}.{k}".lstrip("."), v) for k, v in value.items() if k != "asset")
        elif isinstance(value, list):
            stack.extend((f"{where}[{i}]", v) for i, v in enumerate(value))


def check_asset_paths(meta: SampleMetadata, manifest: Manifest, root: str | Path) -> None:
    """DatasetError naming the first key of ``meta`` whose file is not in a folder that the
    config of ``manifest`` (the dataset in ``root``) names for its kind; nothing is read."""
    folders = config_folders(manifest, root)
    for where, record, kind in asset_records(meta):
        if not (
            isinstance(record, dict)
            and isinstance(record.get("root"), str)
            and isinstance(record.get("path"), str)
        ):
            raise DatasetError(f"{where}: expected a {kind} record with text 'root' and 'path'")
        named, path = record["root"], record["path"]
        real = _real(named)
        if real is None or real not in folders[kind].values():
            allowed = ", ".join(f"{k}: {v!r}" for k, v in folders[kind].items())
            raise DatasetError(
                f"{where}.root: {named[:200]!r} is not a folder the dataset's config names for "
                f"users' {_PLURAL[kind]} ({allowed or 'it names none'}); nothing of it was read"
            )
        inner = _real(os.path.join(real, path)) if path and not os.path.isabs(path) else None
        if inner is None or inner == real or not Path(inner).is_relative_to(real):
            raise DatasetError(
                f"{where}.path: {path[:200]!r} leads outside its folder {named[:200]!r}; "
                "nothing of it was read"
            )
