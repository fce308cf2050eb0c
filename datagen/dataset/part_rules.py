"""How one sample's parts become arrays: a :class:`PartRule` per kind of part (a name pattern
and what a matching part adds to the item), and the :class:`Decoding` a sample's rules fill.
The rules every sample shares are in ``datagen.dataset.parts``; a metadata format declares the
parts of its own (``PARTS`` in its module, ``datagen.formats``), so no reader names a family."""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

# the image parts of one camera: part name -> item field (depth_sensor.png: the sensor model's
# depth, rgb_clean.png: colour before the camera effects; only where the build made them)
IMAGE_PARTS = {
    "rgb.png": "rgb",
    "depth.png": "depth",
    "seg.png": "seg",
    "semantic.png": "semantic",
    "depth_sensor.png": "depth_sensor",
    "rgb_clean.png": "rgb_clean",
}
IMAGE_KINDS = "rgb|rgb_clean|depth|depth_sensor|seg|semantic"
CAMERA_NAME = r"[A-Za-z][\w-]*"


@dataclass
class Decoding:
    """One sample's parts being decoded: the item, and what its rules collect for the end
    (frames over time, other cameras, a grasp attempt's film); the PNGs are decoded together
    at the end (``jobs``: (dict it goes into, field, image kind, bytes))."""

    item: dict[str, Any] = field(default_factory=dict)
    frames: dict[int, dict[str, Any]] = field(default_factory=dict)
    cameras: dict[str, dict[str, Any]] = field(default_factory=dict)
    film: dict[int, dict[str, Any]] = field(default_factory=dict)
    jobs: list[tuple[dict[str, Any], str, str, bytes]] = field(default_factory=list)

    def image(self, into: dict[str, Any], field: str, kind: str, data: bytes) -> None:
        """PNG ``data`` of image kind ``kind`` (``rgb.png``, ``flow.png``, ...) to decode into
        ``into[field]``."""
        self.jobs.append((into, field, kind, data))

    def frame(self, k: int) -> dict[str, Any]:
        return self.frames.setdefault(k, {})


@dataclass(frozen=True)
class PartRule:
    """Parts named like ``pattern`` (matched whole) are given to ``take(decoding, match,
    data)``."""

    pattern: re.Pattern[str]
    take: Callable[[Decoding, re.Match[str], bytes], None]

    def apply(self, decoding: Decoding, name: str, data: bytes) -> bool:
        if (match := self.pattern.fullmatch(name)) is None:
            return False
        self.take(decoding, match, data)
        return True


def image_rule(pattern: str, into: Callable[[Decoding, re.Match[str]], dict[str, Any]]) -> PartRule:
    """A rule for image parts whose last group is the image kind (``rgb``, ``depth``, ...):
    decoded into the field of that kind of the dict ``into(decoding, match)``."""

    def take(decoding: Decoding, match: re.Match[str], data: bytes) -> None:
        kind = f"{match[match.lastindex or 0]}.png"
        decoding.image(into(decoding, match), IMAGE_PARTS.get(kind, kind[:-4]), kind, data)

    return PartRule(re.compile(pattern), take)
