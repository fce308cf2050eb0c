"""Encoding rendered views into a sample's named parts: PNG images, compact sorted JSON."""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np

from datagen.engines.sim.stage_clock import timed


@dataclass
class View:
    rgb: np.ndarray  # (H, W, 3) uint8, RGB
    depth: np.ndarray  # (H, W) uint16 millimetres
    instance: np.ndarray  # (H, W) uint16
    semantic: np.ndarray  # (H, W) uint8


def png_bytes(image: np.ndarray) -> bytes:
    with timed("encode"):
        ok, encoded = cv2.imencode(".png", image)
    if not ok:
        raise RuntimeError(f"PNG encoding failed for an image of shape {image.shape}")
    return encoded.tobytes()


def encode_view(view: View, prefix: str = "") -> dict[str, bytes]:
    """``<prefix>rgb.png depth.png seg.png semantic.png`` of one rendered view."""
    return {
        f"{prefix}rgb.png": png_bytes(cv2.cvtColor(view.rgb, cv2.COLOR_RGB2BGR)),
        f"{prefix}depth.png": png_bytes(view.depth),
        f"{prefix}seg.png": png_bytes(view.instance),
        f"{prefix}semantic.png": png_bytes(view.semantic),
    }


def metadata_bytes(metadata: dict[str, Any]) -> bytes:
    with timed("encode"):
        return json.dumps(metadata, sort_keys=True, separators=(",", ":")).encode()
