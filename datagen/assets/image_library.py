"""Users' pictures: ``materials.textures_dir`` (textures) and ``background.images_dir``
(backdrop pictures), read with OpenCV.

Every PNG or JPEG file under the folder (sorted, subfolders included) is a candidate. A file
that cannot be used is skipped with its reason and listed in the manifest, never fatal: not a
PNG/JPEG file, undecodable, smaller than :data:`MIN_SIDE` or larger than :data:`MAX_SIDE`
pixels on a side. Grey pictures are used as grey RGB, an alpha channel is dropped, 16-bit
pictures are scaled to 8 bits. A folder with no usable picture is a config error. Pictures are
drawn at most :data:`DRAWN_SIDE` pixels on a side (downscaled once per process), as sRGB. A
folder of more than :data:`MAX_FILES` files is refused (someone named the wrong folder).
"""

from __future__ import annotations

import functools
import hashlib
import logging
import struct
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

log = logging.getLogger(__name__)
IMAGE_SUFFIXES = {".png", ".jpg", ".jpeg"}
MIN_SIDE = 8  # pixels: smaller pictures carry no pattern worth drawing
MAX_SIDE = 4096  # pixels: bigger pictures cost seconds and GiBs to decode in every worker
DRAWN_SIDE = 512  # pixels: what a surface shows at the image sizes we render
MAX_FILES = 10_000  # files under a picture folder: more means the wrong folder was named


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


_JPEG_FRAME_MARKERS = {0xC0, 0xC1, 0xC2, 0xC3, 0xC5, 0xC6, 0xC7, 0xC9, 0xCA, 0xCB, 0xCD, 0xCE, 0xCF}


def header_size(data: bytes) -> tuple[int, int] | None:
    """(width, height) from a PNG or JPEG header, read before decoding (a huge picture is
    refused without allocating its pixels); None if the header does not say."""
    if data[:8] == b"\x89PNG\r\n\x1a\n" and data[12:16] == b"IHDR":
        return struct.unpack(">II", data[16:24])
    if data[:2] != b"\xff\xd8":
        return None
    at = 2
    while at + 9 <= len(data) and data[at] == 0xFF:
        marker, length = data[at + 1], struct.unpack(">H", data[at + 2 : at + 4])[0]
        if marker in _JPEG_FRAME_MARKERS:  # frame header: precision, height, width
            height, width = struct.unpack(">HH", data[at + 5 : at + 9])
            return width, height
        at += 2 + length
    return None


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
    data = path.read_bytes()
    size = header_size(data)
    if size is not None and max(size) > MAX_SIDE:
        raise ValueError(f"{size[0]}x{size[1]} px, larger than {MAX_SIDE} px: downscale it")
    image = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED)
    if image is None:
        raise ValueError("unreadable: OpenCV cannot decode it (corrupt or not an image)")
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
        if path.is_file():
            paths.append(path)
        if len(paths) > MAX_FILES:
            raise ImageFolderError(f"{base}: more than {MAX_FILES} files; name a folder of pictures")  # fmt: skip
    for path in sorted(paths):
        relative = path.relative_to(base).as_posix()
        try:
            digest, width, height = check_picture(path)
        except (OSError, ValueError, cv2.error) as exc:
            library.skipped.append((relative, str(exc)[:300]))
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
    return hashlib.sha256((Path(root) / path).read_bytes()).hexdigest()


@functools.lru_cache(maxsize=64)
def load_image(root: str, path: str) -> np.ndarray:
    """The picture ``root/path`` as drawn: (H, W, 3) uint8 RGB, at most DRAWN_SIDE a side."""
    image = cv2.imread(str(Path(root) / path), cv2.IMREAD_UNCHANGED)
    if image is None:
        raise ValueError(f"{Path(root) / path}: unreadable picture")
    image = _rgb8(image)
    scale = DRAWN_SIDE / max(image.shape[:2])
    if scale < 1:
        size = (max(1, round(image.shape[1] * scale)), max(1, round(image.shape[0] * scale)))
        image = cv2.resize(image, size, interpolation=cv2.INTER_AREA)
    return image
