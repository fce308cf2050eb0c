"""Users' pictures: ``materials.textures_dir`` (textures) and ``background.images_dir``
(backdrop pictures), read with OpenCV.

Every PNG or JPEG file under the folder (sorted, subfolders included) is a candidate. A file
that cannot be used is skipped with its reason and listed in the manifest, never fatal: not a
PNG/JPEG file, undecodable, smaller than :data:`MIN_SIDE` or larger than :data:`MAX_SIDE`
pixels on a side. Grey pictures are used as grey RGB, an alpha channel is dropped, 16-bit
pictures are scaled to 8 bits. A folder with no usable picture is a config error. Pictures are
drawn at most :data:`DRAWN_SIDE` pixels on a side (downscaled once per process), as sRGB. A
folder of more than :data:`MAX_FILES` files is refused (someone named the wrong folder).

Every file is read by the one bounded decoder (:mod:`datagen.images`): a regular file opened
without following a link, bounded in bytes, its size read from its header before any pixel is
decoded. A reason holds no path of the machine (:func:`machine_free`): the manifest lists it.
"""

from __future__ import annotations

import functools
import hashlib
import logging
import re
from dataclasses import dataclass, field
from pathlib import Path, PurePosixPath

import cv2
import numpy as np

from datagen.images import (
    MAX_IMAGE_FILE_BYTES,
    ImageInputError,
    decode_image,
    header_size,
    read_image_file,
    read_regular_file,
)

log = logging.getLogger(__name__)
IMAGE_SUFFIXES = {".png", ".jpg", ".jpeg"}
MIN_SIDE = 8  # pixels: smaller pictures carry no pattern worth drawing
MAX_SIDE = 4096  # pixels: bigger pictures cost seconds and GiBs to decode in every worker
DRAWN_SIDE = 512  # pixels: what a surface shows at the image sizes we render
MAX_FILES = 10_000  # files under a picture folder: more means the wrong folder was named
_WHAT = "the file"  # how a reason names the file it is listed with
# an absolute path inside a message: "/" not after a name, "." or "-" (so "a/b" stays)
_ABSOLUTE_PATH = re.compile(r"(?<![\w./-])/[^\s'\"<>:,;()]*[^\s'\"<>:,;().]")


class ImageFolderError(ValueError):
    """No usable picture in the folder; the text says what was found and why it was skipped."""


@dataclass(frozen=True)
class Picture:
    path: str  # relative to the folder
    sha256: str
    width: int
    height: int


@dataclass
class ImageLibrary:
    root: Path
    pictures: list[Picture] = field(default_factory=list)
    skipped: list[tuple[str, str]] = field(default_factory=list)  # (relative path, reason)

    def report(self) -> dict:
        return {
            "root": str(self.root),
            "images": [{"path": p.path, "sha256": p.sha256} for p in self.pictures],
            "skipped": [{"path": p, "reason": r} for p, r in self.skipped],
        }


def machine_free(text: str, base: Path) -> str:
    """``text`` (an error about a file of the folder ``base``) as one line that holds no path
    of the machine: paths in ``base`` relative to it, any other absolute path by its name."""
    for prefix in {f"{base}/", f"{base.resolve()}/"}:
        text = text.replace(prefix, "")
    text = _ABSOLUTE_PATH.sub(lambda m: PurePosixPath(m.group()).name, text)
    return " ".join(text.split())[:300]


def _reason(exc: BaseException) -> str:
    return str(exc).removeprefix(f"{_WHAT}: ")


def _rgb8(image: np.ndarray) -> np.ndarray:
    """Any decoded picture (grey, BGR, BGRA; 8 or 16 bits) as (H, W, 3) uint8 RGB."""
    if image.dtype == np.uint16:
        image = (image // 257).astype(np.uint8)
    elif image.dtype != np.uint8:
        raise ValueError(f"unsupported pixel type {image.dtype}")
    if image.ndim == 2:
        return cv2.cvtColor(image, cv2.COLOR_GRAY2RGB)
    if image.shape[2] == 4:
        return cv2.cvtColor(image, cv2.COLOR_BGRA2RGB)
    return cv2.cvtColor(image, cv2.COLOR_BGR2RGB)


def check_picture(path: Path) -> tuple[str, int, int]:
    """(sha256, width, height) of a usable picture; raises ValueError saying why it is not."""
    if path.suffix.lower() not in IMAGE_SUFFIXES:
        raise ValueError(f"not a PNG or JPEG file ({path.suffix or 'no suffix'})")
    data = read_regular_file(path, what=_WHAT, max_bytes=MAX_IMAGE_FILE_BYTES)
    size = header_size(data)
    if size is not None and max(size) > MAX_SIDE:
        raise ValueError(f"{size[0]}x{size[1]} px, larger than {MAX_SIDE} px: downscale it")
    try:
        image = decode_image(data, what=_WHAT, max_pixels=MAX_SIDE**2)
    except ImageInputError as exc:
        raise ValueError(f"unreadable: cannot decode it: {_reason(exc)}") from None
    height, width = image.shape[:2]
    if min(width, height) < MIN_SIDE:
        raise ValueError(f"{width}x{height} px, smaller than {MIN_SIDE} px on a side")
    if max(width, height) > MAX_SIDE:
        raise ValueError(f"{width}x{height} px, larger than {MAX_SIDE} px: downscale it")
    _rgb8(image)
    return hashlib.sha256(data).hexdigest(), width, height


@functools.lru_cache(maxsize=8)
def load_library(root: str) -> ImageLibrary:
    """Scans ``root`` once per process (sorted, so every worker sees the same library)."""
    base = Path(root)
    library = ImageLibrary(base)
    paths = []
    for path in base.rglob("*"):
        if path.is_file() or path.is_symlink():  # a link is listed, then skipped: never read
            paths.append(path)
        if len(paths) > MAX_FILES:
            raise ImageFolderError(
                f"{base}: more than {MAX_FILES} files; name a folder of pictures"
            )
    for path in sorted(paths):
        relative = path.relative_to(base).as_posix()
        try:
            digest, width, height = check_picture(path)
        except (OSError, ValueError, cv2.error) as exc:
            library.skipped.append((relative, machine_free(_reason(exc), base)))
            continue
        library.pictures.append(Picture(relative, digest, width, height))
    if not library.pictures:  # the error names what was skipped: no warnings besides
        found = "; ".join(f"{p}: {r}" for p, r in library.skipped[:5]) or "the folder is empty"
        raise ImageFolderError(f"{base}: no usable PNG or JPEG picture ({found})")
    for relative, reason in library.skipped:
        log.warning("picture %s skipped: %s", relative, reason)
    return library


@functools.lru_cache(maxsize=256)
def file_sha256(root: str, path: str) -> str:
    data = read_regular_file(Path(root) / path, max_bytes=MAX_IMAGE_FILE_BYTES)
    return hashlib.sha256(data).hexdigest()


@functools.lru_cache(maxsize=64)
def load_image(root: str, path: str) -> np.ndarray:
    """The picture ``root/path`` as drawn: (H, W, 3) uint8 RGB, at most DRAWN_SIDE a side."""
    image = _rgb8(read_image_file(Path(root) / path, max_pixels=MAX_SIDE**2))
    scale = DRAWN_SIDE / max(image.shape[:2])
    if scale < 1:
        size = (max(1, round(image.shape[1] * scale)), max(1, round(image.shape[0] * scale)))
        image = cv2.resize(image, size, interpolation=cv2.INTER_AREA)
    return image
