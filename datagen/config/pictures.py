"""Checks of the texture and backdrop settings: texture families by name, and the users'
picture folders (``materials.textures_dir``, ``background.images_dir``), resolved relative to
the config file and scanned once: a folder with no usable picture is a config error naming
the key; single unusable files are skipped with a reason (:mod:`datagen.assets.image_library`)."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

from datagen.assets.image_library import ImageFolderError, load_library
from datagen.assets.texture_tiles import TEXTURE_FAMILIES
from datagen.errors import ConfigError

# (section, key) of every folder of pictures a config may name
PICTURE_FOLDERS = (("materials", "textures_dir"), ("background", "images_dir"))


def _resolved(folder: str, source: str, key: str) -> str:
    try:
        base = Path(source).parent if Path(source).is_file() else Path.cwd()
        return str((base / folder).resolve())
    except (OSError, RuntimeError, ValueError) as exc:  # too long, a symlink loop, ...
        raise ConfigError(f"{source}: {key}: not a usable path ({exc})") from None


def resolve_picture_folders(config: Any, source: str) -> Any:
    """The config with its picture folders made absolute (relative ones from the config
    file's folder, else the working directory)."""
    for section_name, key in PICTURE_FOLDERS:
        section = getattr(config, section_name)
        folder = getattr(section, key)
        if folder and not Path(folder).is_absolute():
            resolved = _resolved(folder, source, f"{section_name}.{key}")
            config = dataclasses.replace(
                config, **{section_name: dataclasses.replace(section, **{key: resolved})}
            )
    return config


def check_pictures(config: Any, source: str) -> None:
    families = list(config.materials.texture_families)
    if not families or any(f not in TEXTURE_FAMILIES for f in families):
        raise ConfigError(
            f"{source}: materials.texture_families: expected a non-empty list from "
            f"{list(TEXTURE_FAMILIES)}, got {families}"
        )
    for section_name, key in PICTURE_FOLDERS:
        folder = getattr(getattr(config, section_name), key)
        if not folder:
            continue
        name = f"{section_name}.{key}"
        try:
            is_dir = Path(folder).is_dir()
        except (OSError, ValueError):  # a name too long, a NUL character, ...
            is_dir = False
        if not is_dir:
            raise ConfigError(f"{source}: {name}: expected a folder of PNG/JPEG pictures, got {folder!r}")  # fmt: skip
        try:
            load_library(folder)
        except ImageFolderError as exc:
            raise ConfigError(f"{source}: {name}: {exc}") from None
        except OSError as exc:  # a folder we may not list
            raise ConfigError(f"{source}: {name}: cannot read {folder!r} ({exc})") from None


def picture_report(config: Any) -> dict[str, Any]:
    """The manifest's account of the users' pictures: what is used, what was skipped and why."""
    report = {}
    for section_name, key in PICTURE_FOLDERS:
        folder = getattr(getattr(config, section_name), key)
        if folder:
            report[f"{section_name}.{key}"] = load_library(folder).report()
    return {"pictures": report} if report else {}
