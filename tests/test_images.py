"""The one bounded picture decoder (datagen/images.py): sizes read from headers before decoding,
only PNG and JPEG, files read only when regular, bounded and not reached through a link."""

from __future__ import annotations

import os
import struct
import zlib

import cv2
import numpy as np
import pytest

from datagen.images import (
    ImageInputError,
    decode_image,
    header_size,
    read_image_file,
    read_regular_file,
)


def _png(width: int, height: int, depth: int = 8, colour: int = 2) -> bytes:
    """A PNG whose IHDR declares ``width`` x ``height``, with one tiny (wrong-sized) IDAT."""

    def chunk(kind: bytes, body: bytes) -> bytes:
        return (
            struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))
        )

    ihdr = struct.pack(">IIBBBBB", width, height, depth, colour, 0, 0, 0)
    return (
        b"\x89PNG\r\n\x1a\n"
        + chunk(b"IHDR", ihdr)
        + chunk(b"IDAT", zlib.compress(b"\0" * 64))
        + chunk(b"IEND", b"")
    )


def _jpeg_claiming(width: int, height: int) -> bytes:
    """A few hundred bytes: SOI, an APP0, a baseline frame header declaring the size, EOI."""
    app0 = b"\xff\xe0" + struct.pack(">H", 16) + b"JFIF\0\x01\x01\0\0\x01\0\x01\0\0"
    sof = b"\xff\xc0" + struct.pack(">HBHHB", 11, 8, height, width, 1) + b"\x01\x11\x00"
    return b"\xff\xd8" + app0 + sof + b"\0" * 600 + b"\xff\xd9"


@pytest.mark.parametrize("suffix", [".png", ".jpg"])
def test_a_real_picture_decodes_and_its_header_gives_its_size(suffix):
    image = np.random.default_rng(0).integers(0, 255, (37, 53, 3), np.uint8)
    data = cv2.imencode(suffix, image)[1].tobytes()
    assert header_size(data) == (53, 37)
    decoded = decode_image(data, what="part")
    assert decoded.shape == (37, 53, 3)
    if suffix == ".png":
        assert np.array_equal(decoded, image)


@pytest.mark.parametrize(
    "data",
    [_png(32000, 32000, depth=16), _jpeg_claiming(32000, 32000)],
    ids=["png-bomb", "jpeg-bomb"],
)
def test_a_bomb_is_refused_from_its_header_before_decoding(data):
    with pytest.raises(ImageInputError, match="32000x32000 pixels, more than"):
        decode_image(data, what="seg.png")


@pytest.mark.parametrize(
    "data",
    [b"", b"not an image", b"BM" + b"\0" * 60, b"\xff\xd8\xff\xd9"],
    ids=["empty", "text", "bmp", "jpeg-without-frame"],
)
def test_anything_but_a_sized_png_or_jpeg_is_refused(data):
    with pytest.raises(ImageInputError, match="what: not a PNG or JPEG"):
        decode_image(data, what="what")


def test_a_picture_cut_short_is_refused_in_one_error():
    data = cv2.imencode(".png", np.zeros((64, 64, 3), np.uint8))[1].tobytes()
    with pytest.raises(ImageInputError, match="part: not a decodable picture"):
        decode_image(data[: len(data) // 2], what="part")


def test_files_are_read_only_when_regular_bounded_and_not_links(tmp_path):
    picture = tmp_path / "a.png"
    picture.write_bytes(cv2.imencode(".png", np.zeros((8, 8, 3), np.uint8))[1].tobytes())
    assert read_image_file(picture).shape == (8, 8, 3)
    link = tmp_path / "link.png"
    link.symlink_to(picture)
    with pytest.raises(ImageInputError, match="a link"):
        read_image_file(link)
    zero = tmp_path / "zero.png"
    zero.symlink_to("/dev/zero")
    with pytest.raises(ImageInputError, match="a link"):
        read_image_file(zero)
    with pytest.raises(ImageInputError, match="not a regular file"):
        read_regular_file("/dev/zero", max_bytes=10)
    fifo = tmp_path / "fifo.png"
    os.mkfifo(fifo)
    with pytest.raises(ImageInputError, match="not a regular file"):
        read_image_file(fifo)  # returns at once: opened non-blocking
    with pytest.raises(ImageInputError, match="86 bytes, more than the 10 allowed"):
        read_regular_file(picture, max_bytes=10)
