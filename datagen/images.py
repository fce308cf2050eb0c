"""The one bounded decoder for every picture datagen reads: stored PNG parts, library and user
pictures, exported frames.

A picture from elsewhere is hostile input. Its size is read from the header before any pixel is
decoded (an 8 MB PNG or a 631-byte JPEG can declare 32000x32000 pixels and make OpenCV allocate
gigabytes), only PNG and JPEG are decoded (OpenCV would decode a dozen other formats, each with
its own bombs), and a file is opened without following a link and read only if it is a regular
file of bounded size (a link to ``/dev/zero`` is never read). Every refusal is an
``ImageInputError`` whose text names what was read and why.
"""

from __future__ import annotations

import os
import stat
import struct
from pathlib import Path

import cv2
import numpy as np

# 4x the largest render (render.width, render.height <= 4096)
MAX_IMAGE_PIXELS = 2**26
MAX_IMAGE_FILE_BYTES = 256 * 2**20  # a 4096x4096 16-bit RGBA PNG stored raw is 128 MiB
_PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
_JPEG_FRAME_MARKERS = {0xC0, 0xC1, 0xC2, 0xC3, 0xC5, 0xC6, 0xC7, 0xC9, 0xCA, 0xCB, 0xCD, 0xCE, 0xCF}
_JPEG_STANDALONE_MARKERS = {0x01, *range(0xD0, 0xD8)}  # TEM, RSTn: no length field


class ImageInputError(ValueError):
    """A picture is not one datagen decodes, or exceeds a bound; the text says which."""


def header_size(data: bytes) -> tuple[int, int] | None:
    """(width, height) from a PNG or JPEG header, read before decoding; None if ``data`` is not
    a PNG or a JPEG whose frame header can be found."""
    if data[:8] == _PNG_SIGNATURE and data[12:16] == b"IHDR" and len(data) >= 24:
        width, height = struct.unpack(">II", data[16:24])
        return int(width), int(height)
    if data[:2] != b"\xff\xd8":
        return None
    at = 2
    while at + 4 <= len(data):
        if data[at] != 0xFF:
            return None
        marker = data[at + 1]
        if marker == 0xFF:  # fill byte
            at += 1
            continue
        if marker in _JPEG_STANDALONE_MARKERS:
            at += 2
            continue
        if marker in _JPEG_FRAME_MARKERS:  # frame header: length, precision, height, width
            if at + 9 > len(data):
                return None
            height, width = struct.unpack(">HH", data[at + 5 : at + 9])
            return int(width), int(height)
        if marker in (0xD9, 0xDA):  # end of image, or scan data before any frame header
            return None
        at += 2 + struct.unpack(">H", data[at + 2 : at + 4])[0]
    return None


def decode_image(
    data: bytes | bytearray | memoryview,
    *,
    what: str,
    flags: int = cv2.IMREAD_UNCHANGED,
    max_pixels: int = MAX_IMAGE_PIXELS,
) -> np.ndarray:
    """``data`` (PNG or JPEG) decoded by OpenCV with ``flags``, after its header showed at most
    ``max_pixels`` pixels; ``ImageInputError`` naming ``what`` otherwise."""
    raw = bytes(data)
    size = header_size(raw)
    if size is None:
        raise ImageInputError(f"{what}: not a PNG or JPEG picture (no header giving its size)")
    width, height = size
    if width < 1 or height < 1:
        raise ImageInputError(f"{what}: its header declares {width}x{height} pixels")
    if width * height > max_pixels:
        raise ImageInputError(
            f"{what}: its header declares {width}x{height} pixels, more than the "
            f"{max_pixels} allowed"
        )
    try:
        image = cv2.imdecode(np.frombuffer(raw, np.uint8), flags)
    except cv2.error as exc:
        raise ImageInputError(f"{what}: OpenCV cannot decode it ({_first_line(exc)})") from None
    if image is None:
        raise ImageInputError(f"{what}: not a decodable picture (corrupt or cut short)")
    # a flag other than IMREAD_UNCHANGED turns a JPEG upright by its EXIF orientation
    turned = flags != cv2.IMREAD_UNCHANGED and not flags & cv2.IMREAD_IGNORE_ORIENTATION
    sizes = {(height, width), (width, height)} if turned else {(height, width)}
    if image.shape[:2] not in sizes:
        raise ImageInputError(
            f"{what}: decoded to {image.shape[1]}x{image.shape[0]} pixels where its header "
            f"declares {width}x{height}"
        )
    return image


def read_regular_file(
    path: str | os.PathLike[str], *, what: str | None = None, max_bytes: int
) -> bytes:
    """The bytes of ``path``, opened without following a link at its last component, if it is a
    regular file of at most ``max_bytes``; ``ImageInputError`` naming ``what`` (default the
    path) otherwise. A FIFO or device is never read (it is opened non-blocking, then checked)."""
    name = what or str(path)
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK | os.O_CLOEXEC)
    except OSError as exc:
        reason = "a link" if Path(path).is_symlink() else exc.strerror
        raise ImageInputError(f"{name}: cannot read it: {reason}") from None
    try:
        info = os.fstat(fd)
        if not stat.S_ISREG(info.st_mode):
            raise ImageInputError(f"{name}: not a regular file")
        if info.st_size > max_bytes:
            raise ImageInputError(
                f"{name}: {info.st_size} bytes, more than the {max_bytes} allowed"
            )
        chunks = []
        left = max_bytes + 1  # a file that grows while read is caught too
        while left > 0 and (chunk := os.read(fd, min(left, 2**20))):
            chunks.append(chunk)
            left -= len(chunk)
    except OSError as exc:
        raise ImageInputError(f"{name}: cannot read it: {exc.strerror}") from None
    finally:
        os.close(fd)
    data = b"".join(chunks)
    if len(data) > max_bytes:
        raise ImageInputError(f"{name}: more than the {max_bytes} bytes allowed")
    return data


def read_image_file(
    path: str | os.PathLike[str],
    *,
    what: str | None = None,
    flags: int = cv2.IMREAD_UNCHANGED,
    max_bytes: int = MAX_IMAGE_FILE_BYTES,
    max_pixels: int = MAX_IMAGE_PIXELS,
) -> np.ndarray:
    """A PNG or JPEG file decoded with both bounds (a regular file, not through a link)."""
    name = what or str(path)
    data = read_regular_file(path, what=name, max_bytes=max_bytes)
    return decode_image(data, what=name, flags=flags, max_pixels=max_pixels)


def _first_line(exc: BaseException) -> str:
    lines = [line.strip() for line in str(exc).splitlines() if line.strip()]
    return (lines[-1] if lines else type(exc).__name__)[:200]
