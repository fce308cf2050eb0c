"""The loader reads each part by the rules of the metadata formats (``PARTS``), never by a
family's name: a format's own rule reads its parts, the built-in formats' rules read theirs,
and a part no rule claims stays bytes."""

from __future__ import annotations

import re
import sys

import cv2
import numpy as np
import pytest

from datagen.dataset import parts
from datagen.dataset.part_rules import Decoding, PartRule
from datagen.plugin_records import MetadataFormat
from datagen.registries import METADATA_FORMATS


def _png(image: np.ndarray) -> bytes:
    return cv2.imencode(".png", image)[1].tobytes()


def _ball_track(decoding: Decoding, match: re.Match[str], data: bytes) -> None:
    decoding.item["ball_track"] = np.array(
        [[float(v) for v in line.split(",")] for line in data.decode().splitlines()]
    )


PARTS = (PartRule(re.compile(r"ball\.csv"), _ball_track),)


@pytest.fixture
def a_format_with_a_part_of_its_own(monkeypatch):
    sys.modules["ball_format"] = sys.modules[__name__]
    record = MetadataFormat("example.ball/1", "a ball's track", "ball_format")
    formats = [*METADATA_FORMATS.values(), record]
    monkeypatch.setattr(type(METADATA_FORMATS), "values", lambda self: formats)
    parts.part_rules.cache_clear()
    yield
    parts.part_rules.cache_clear()
    del sys.modules["ball_format"]


def test_a_format_reads_the_parts_of_its_own_by_its_rules(a_format_with_a_part_of_its_own):
    item = parts.decode_parts({"ball.csv": b"0,0\n1,0.5\n", "rgb.png": _png(np.zeros((4, 6, 3)))})
    np.testing.assert_array_equal(item["ball_track"], [[0, 0], [1, 0.5]])
    assert item["rgb"].shape == (4, 6, 3)


def test_without_its_format_a_part_stays_bytes_and_the_built_in_rules_still_read():
    parts.part_rules.cache_clear()
    grey = _png(np.full((4, 6), 7, np.uint8))
    item = parts.decode_parts(
        {
            "ball.csv": b"0,0\n",
            "f0002.depth.png": grey,  # one camera over time (navigation)
            "f0002.d1.seg.png": grey,  # several cameras over time (aerial, fleet)
            "wrist.depth.png": grey,  # another camera of one scene
            "poses.head.txt": b"0 0 0 0 0 0 1\n1 0 0 0 0 0 1\n",
        }
    )
    assert item["ball.csv"] == b"0,0\n"
    assert item["frames"][0]["depth"].shape == (4, 6)
    assert item["frames"][0]["cameras"]["d1"]["seg"].shape == (4, 6)
    assert item["views"]["wrist"]["depth"].shape == (4, 6)
    assert item["poses"]["head"].shape == (2, 7)
