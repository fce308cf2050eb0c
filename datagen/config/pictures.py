"""Checks of the texture and backdrop settings: texture families by name, and the users'
picture folders (``materials.textures_dir``, ``background.images_dir``), resolved relative to
the config file and scanned once: a folder with no usable picture is a config error naming
the key; single unusable files are skipped with a reason (:mod:`datagen.assets.image_library`)."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

from datagen.assets.family_names import TEXTURE_FAMILIES
from datagen.assets.image_library import ImageFolderError, load_library
from datagen.errors import ConfigError
from datagen.library.catalogue import LibraryMissing, pictures, verify_pictures
from datagen.registries import FAMILIES, LIBRARY_SOURCES

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
            raise ConfigError(
                f"{source}: {name}: expected a folder of PNG/JPEG pictures, got {folder!r}"
            )
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
    if uses_photos(config):  # attribution travels with the data
        keys = ("path", "source", "sha256", "licence", "copyright", "url")
        report["photos"] = {
            "sources": list(config.photos.sources),
            "held_out": list(config.photos.held_out),
            "files": [{k: e[k] for k in keys} for e in pictures(config.photos.sources)],
        }
    return {"pictures": report} if report else {}


def uses_photos(config: Any) -> bool:
    return config.photos.enabled and FAMILIES[config.scene].world == "tabletop"


def check_photos(config: Any, source: str) -> None:
    """``photos``: known sources, none both drawn and held out, and (when a tabletop scene
    draws them) installed, every picture as installed (a regular file inside the library, its
    digest and header those of the manifest): a missing or damaged library is a config error
    saying what to run, before any worker could read it."""
    photos = config.photos
    for key in ("sources", "held_out"):
        for name in getattr(photos, key):
            LIBRARY_SOURCES.check(name, f"{source}: photos.{key}")
    if both := sorted(set(photos.sources) & set(photos.held_out)):
        raise ConfigError(
            f"{source}: photos.held_out: {both} also in photos.sources: a held-out source is never drawn"
        )
    FAMILIES.check(config.scene, f"{source}: scene")
    if not uses_photos(config):
        return
    if not photos.sources:
        raise ConfigError(
            f"{source}: photos.sources: expected at least one source of {list(LIBRARY_SOURCES)} (or photos.enabled: false)"
        )
    try:
        if not pictures(photos.sources):
            raise ConfigError(f"{source}: photos.sources: {list(photos.sources)} hold no picture")
        verify_pictures(photos.sources)
    except LibraryMissing as exc:
        raise ConfigError(f"{source}: photos: {exc}") from None
