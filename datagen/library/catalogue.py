"""Reading the installed library: where it is, what its manifest lists, and the pictures of
chosen sources, each opened only if the manifest lists it with the same SHA-256.

The library lives in ``$DATAGEN_LIBRARY``, else ``~/.cache/datagen/library`` (a machine's
cache, never the repository, never a dataset): ``manifest.json`` and one folder per source.
A sample's metadata names a picture by its path in the library and its SHA-256, not by a
machine path, so the same seed gives the same bytes on every machine.
"""

from __future__ import annotations

import functools
import hashlib
import json
import os
from pathlib import Path
from typing import Any

import cv2
import numpy as np

MANIFEST = "manifest.json"
INSTALL_COMMAND = "datagen library install"
DRAWN_SIDE = 512  # pixels: a picture is drawn at most this size a side (as user pictures are)


class LibraryMissing(ValueError):
    """The library, or a source of it, is not installed; the text says what to run."""


def library_root() -> Path:
    env = os.environ.get("DATAGEN_LIBRARY")
    return Path(env) if env else Path.home() / ".cache" / "datagen" / "library"


@functools.lru_cache(maxsize=4)
def _manifest(root: str, stamp: float) -> dict[str, Any]:
    return json.loads((Path(root) / MANIFEST).read_text())


def read_manifest(root: Path | None = None) -> dict[str, Any]:
    """The installed manifest (cached while the file is unchanged); LibraryMissing if none."""
    root = root or library_root()
    path = root / MANIFEST
    try:
        stamp = path.stat().st_mtime_ns
    except OSError:
        raise LibraryMissing(
            f"the picture library is not installed ({path} does not exist): run "
            f"`{INSTALL_COMMAND}` (bash scripts/install.sh does it too)"
        ) from None
    return _manifest(str(root), stamp)


def entries(sources: tuple[str, ...] | list[str], root: Path | None = None) -> list[dict]:
    """The manifest's files of ``sources``, in the manifest's order (sorted by path), or
    LibraryMissing naming the sources that are not installed."""
    manifest = read_manifest(root)
    missing = [s for s in sources if s not in manifest.get("sources", {})]
    if missing:
        raise LibraryMissing(
            f"library source(s) {missing} not installed in {root or library_root()}: run "
            f"`{INSTALL_COMMAND} --sources {' '.join(missing)}`"
        )
    chosen = set(sources)
    return [e for e in manifest["files"] if e["source"] in chosen]


def pictures(sources: tuple[str, ...] | list[str]) -> list[dict]:
    return [e for e in entries(sources) if e["kind"] != "mesh"]


@functools.lru_cache(maxsize=128)
def load_picture(path: str, sha256: str) -> np.ndarray:
    """The library picture ``path`` as drawn: (H, W, 3) uint8 RGB, at most DRAWN_SIDE a side.
    Only a file the manifest lists with this SHA-256 is read (a dataset is untrusted input)."""
    listed = {e["path"]: e["sha256"] for e in read_manifest()["files"]}
    if listed.get(path) != sha256:
        raise LibraryMissing(
            f"picture {path!r} (sha256 {sha256[:12]}...) is not in the installed library "
            f"{library_root()}: run `{INSTALL_COMMAND}`"
            + (" (its file differs from the one the sample used)" if path in listed else "")
        )
    data = (library_root() / path).read_bytes()
    if hashlib.sha256(data).hexdigest() != sha256:
        raise LibraryMissing(f"{library_root() / path}: changed since installed: run `{INSTALL_COMMAND} --force`")  # fmt: skip
    image = cv2.cvtColor(cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR), cv2.COLOR_BGR2RGB)  # fmt: skip
    scale = DRAWN_SIDE / max(image.shape[:2])
    if scale < 1:
        size = (max(1, round(image.shape[1] * scale)), max(1, round(image.shape[0] * scale)))
        image = cv2.resize(image, size, interpolation=cv2.INTER_AREA)
    return image
