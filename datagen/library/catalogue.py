"""Reading the installed library: where it is, what its manifest lists, and the pictures of
chosen sources, each opened only if the manifest lists it with the same SHA-256.

The library lives in ``$DATAGEN_LIBRARY``, else ``~/.cache/datagen/library`` (a machine's
cache, never the repository, never a dataset): ``manifest.json`` and one folder per source.
A sample's metadata names a picture by its path in the library and its SHA-256, not by a
machine path, so the same seed gives the same bytes on every machine.

The library may be shared, so what it holds is checked like any input from elsewhere: the
manifest is bounded JSON of the schema below, every path in it stays inside the library
(:mod:`datagen.library.files`), and a picture is a regular file of bounded size whose header
matches the manifest before it is decoded (:mod:`datagen.images`). Anything else is a
:class:`LibraryDamaged` error naming the file and saying what to run.
"""

from __future__ import annotations

import functools
import hashlib
import os
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal, get_args, get_origin

import cv2
import dacite
import numpy as np

from datagen.images import ImageInputError, decode_image, header_size
from datagen.library.files import UnsafePath, parts_of, read_file
from datagen.safe_json import JsonInputError, loads_bounded

MANIFEST = "manifest.json"
INSTALL_COMMAND = "datagen library install"
STORED_SIDE = 1024  # pixels: pictures are stored at most this size a side
DRAWN_SIDE = 512  # pixels: a picture is drawn at most this size a side (as user pictures are)
MAX_FILE_BYTES = {"picture": 16 * 2**20, "mesh": 64 * 2**20}  # stored JPEGs are < 1 MiB
MAX_MANIFEST_BYTES = 16 * 2**20
_SHA256 = re.compile(r"[0-9a-f]{64}")


class LibraryMissing(ValueError):
    """The library, or a source of it, is not installed; the text says what to run."""


class LibraryDamaged(LibraryMissing):
    """The manifest or a file of the library is not what the installer wrote: ``problem``
    names it and says what is wrong; the text adds what to run (the installer mends it)."""

    def __init__(self, problem: str, source: str | None = None) -> None:
        command = INSTALL_COMMAND + (f" --sources {source}" if source else "")
        super().__init__(f"{problem}: run `{command}` (it fetches what is missing or damaged)")
        self.problem = problem


@dataclass(frozen=True)
class LibraryFile:
    """One installed file as ``manifest.json`` lists it (docs/photo-library.md)."""

    path: str
    source: str
    kind: Literal["photo", "artwork", "material", "mesh"]
    package: str
    member: str
    original_sha256: str
    sha256: str
    licence: str
    copyright: str
    url: str
    width: int = 0  # pictures only
    height: int = 0


@dataclass(frozen=True)
class InstalledSource:
    package: str
    registry: str
    kind: str
    url: str
    files: int


@dataclass(frozen=True)
class LibraryManifest:
    version: Literal[1]
    sources: dict[str, InstalledSource]
    files: list[dict]  # each a LibraryFile, checked one by one to name its index


def library_root() -> Path:
    env = os.environ.get("DATAGEN_LIBRARY")
    return Path(env) if env else Path.home() / ".cache" / "datagen" / "library"


def check_manifest(data: Any) -> None:
    """ValueError saying what of ``data`` does not follow the manifest's schema."""
    if not isinstance(data, dict):
        raise ValueError(f"expected a JSON object, got {type(data).__name__}")
    _typed(LibraryManifest, data, "")
    for index, entry in enumerate(data["files"]):
        where = f"files[{index}]"
        if not isinstance(entry, dict):
            raise ValueError(f"{where}: expected an object, got {type(entry).__name__}")
        _typed(LibraryFile, entry, f"{where}.")
        _check_entry(entry, data["sources"], where)


def _typed(schema: type, data: dict, prefix: str) -> None:
    try:
        dacite.from_dict(schema, data)
    except dacite.WrongTypeError as exc:
        choices = get_args(exc.field_type) if get_origin(exc.field_type) is Literal else ()
        expected = " or ".join(map(repr, choices)) or getattr(exc.field_type, "__name__", "?")
        raise ValueError(
            f"{prefix}{exc.field_path}: expected {expected}, got {exc.value!r:.80}"
        ) from None
    except dacite.MissingValueError as exc:
        raise ValueError(f"{prefix}{exc.field_path}: missing") from None
    except dacite.DaciteError as exc:
        raise ValueError(f"{prefix.rstrip('.') or 'manifest'}: {exc}"[:300]) from None


def _check_entry(entry: dict, sources: dict, where: str) -> None:
    try:
        parts = parts_of(entry["path"])
    except UnsafePath as exc:
        raise ValueError(f"{where}: {exc}") from None
    if parts[0] != entry["source"] or entry["source"] not in sources:
        raise ValueError(
            f"{where}: path {entry['path']!r} is not in the folder of an installed source"
        )
    for key in ("sha256", "original_sha256"):
        if not _SHA256.fullmatch(entry[key]):
            raise ValueError(f"{where}.{key}: expected 64 hex digits, got {entry[key]!r:.80}")
    for key in ("width", "height") if entry["kind"] != "mesh" else ():
        value = entry.get(key)
        if type(value) is not int or not 1 <= value <= STORED_SIDE:
            raise ValueError(
                f"{where}.{key}: expected pixels in [1, {STORED_SIDE}], got {value!r:.80}"
            )


def read_manifest(root: Path | None = None) -> dict[str, Any]:
    """The installed manifest (cached while the file is unchanged); LibraryMissing if none,
    LibraryDamaged if it is not one the installer wrote."""
    root = root or library_root()
    return _manifest(str(root), _stamp(root))


def _stamp(root: Path) -> tuple[int, int, int]:
    path = root / MANIFEST
    try:
        info = os.stat(path, follow_symlinks=False)
    except OSError:
        raise LibraryMissing(
            f"the picture library is not installed ({path} does not exist): run "
            f"`{INSTALL_COMMAND}` (bash scripts/install.sh does it too)"
        ) from None
    return info.st_mtime_ns, info.st_size, info.st_ino


@functools.lru_cache(maxsize=4)
def _manifest(root: str, stamp: tuple[int, int, int]) -> dict[str, Any]:
    path = Path(root) / MANIFEST
    try:
        manifest = loads_bounded(
            read_file(Path(root), MANIFEST, max_bytes=MAX_MANIFEST_BYTES),
            what=str(path),
            max_bytes=MAX_MANIFEST_BYTES,
        )
        check_manifest(manifest)
    except (ImageInputError, JsonInputError) as exc:
        raise LibraryDamaged(f"the picture library's manifest is damaged ({exc})") from None
    except ValueError as exc:
        raise LibraryDamaged(f"the picture library's manifest is damaged ({path}: {exc})") from None
    return manifest


def entries(sources: tuple[str, ...] | list[str], root: Path | None = None) -> list[dict]:
    """The manifest's files of ``sources``, in the manifest's order (sorted by path), or
    LibraryMissing naming the sources that are not installed."""
    manifest = read_manifest(root)
    missing = [s for s in sources if s not in manifest["sources"]]
    if missing:
        raise LibraryMissing(
            f"library source(s) {missing} not installed in {root or library_root()}: run "
            f"`{INSTALL_COMMAND} --sources {' '.join(missing)}`"
        )
    chosen = set(sources)
    return [e for e in manifest["files"] if e["source"] in chosen]


def pictures(sources: tuple[str, ...] | list[str], root: Path | None = None) -> list[dict]:
    return [e for e in entries(sources, root) if e["kind"] != "mesh"]


def file_problem(root: Path, entry: dict) -> str | None:
    """Why the file of a (schema-checked) manifest ``entry`` is not the one installed, without
    decoding it: not a regular file inside the library, too large, another SHA-256, or a
    picture whose header is not a PNG or JPEG of the manifest's size; None if it is."""
    kind = "mesh" if entry["kind"] == "mesh" else "picture"
    try:
        data = read_file(root, entry["path"], max_bytes=MAX_FILE_BYTES[kind])
    except (UnsafePath, ImageInputError) as exc:
        return str(exc)
    if hashlib.sha256(data).hexdigest() != entry["sha256"]:
        return f"{root / entry['path']}: changed since installed (another SHA-256)"
    if kind == "mesh":
        return None
    size = header_size(data)
    if size is None:
        return f"{root / entry['path']}: not a PNG or JPEG picture"
    if size != (entry["width"], entry["height"]):
        return (
            f"{root / entry['path']}: its header declares {size[0]}x{size[1]} pixels, the "
            f"manifest {entry['width']}x{entry['height']}"
        )
    return None


def verify_pictures(sources: tuple[str, ...] | list[str]) -> None:
    """LibraryDamaged naming the first picture of ``sources`` whose file is not the one
    installed (:func:`file_problem`): a build refuses it before any worker starts."""
    root = library_root()
    _verified(str(root), _stamp(root), tuple(sources))


@functools.lru_cache(maxsize=8)
def _verified(root: str, stamp: tuple[int, int, int], sources: tuple[str, ...]) -> None:
    for entry in pictures(sources, Path(root)):
        if problem := file_problem(Path(root), entry):
            raise LibraryDamaged(
                f"picture {entry['path']} of the library is damaged ({problem})", entry["source"]
            )


@functools.lru_cache(maxsize=128)
def load_picture(path: str, sha256: str) -> np.ndarray:
    """The library picture ``path`` as drawn: (H, W, 3) uint8 RGB, at most DRAWN_SIDE a side.
    Only a file the manifest lists with this SHA-256 is read (a dataset is untrusted input),
    and only as a bounded regular file inside the library."""
    listed = {e["path"]: e for e in read_manifest()["files"]}
    entry = listed.get(path)
    if entry is None or entry["sha256"] != sha256:
        raise LibraryMissing(
            f"picture {path!r} (sha256 {sha256[:12]}...) is not in the installed library "
            f"{library_root()}: run `{INSTALL_COMMAND}`"
            + (" (its file differs from the one the sample used)" if entry else "")
        )
    try:
        image = _decoded(library_root(), entry)
    except (UnsafePath, ImageInputError) as exc:
        raise LibraryDamaged(str(exc), entry["source"]) from None
    scale = DRAWN_SIDE / max(image.shape[:2])
    if scale < 1:
        size = (max(1, round(image.shape[1] * scale)), max(1, round(image.shape[0] * scale)))
        image = cv2.resize(image, size, interpolation=cv2.INTER_AREA)
    return image


def _decoded(root: Path, entry: dict) -> np.ndarray:
    what = str(root / entry["path"])
    data = read_file(root, entry["path"], max_bytes=MAX_FILE_BYTES["picture"])
    if hashlib.sha256(data).hexdigest() != entry["sha256"]:
        raise ImageInputError(f"{what}: changed since installed (another SHA-256)")
    image = decode_image(data, what=what, flags=cv2.IMREAD_COLOR, max_pixels=STORED_SIDE**2)
    return cv2.cvtColor(image, cv2.COLOR_BGR2RGB)
