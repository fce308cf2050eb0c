"""SAPIEN's float pictures -> the stored integer images, in one pass each and bit-exact.

Every function reproduces, operation by operation in float32, the straightforward reference
(``rgb_reference`` / ``depth_reference``): ``floor(f32(f32(x * 255) + 0.5))`` clipped to
[0, 255] for colour, and ``rint(f32(-z / f32(0.001)))`` clipped to [0, 65535] on surfaces (w < 1)
for depth, 0 elsewhere. Same IEEE operations in the same order give the same bits; only the
whole-image temporaries (float64, fancy ``np.where`` copies) are gone. The torch variants run
the same operations on any device, so the GPU read-back path stores the same bytes.
"""

from __future__ import annotations

from typing import Any

import cv2
import numpy as np

DEPTH_SCALE = 0.001  # metres per depth unit: depth PNGs hold uint16 millimetres
DEPTH_MAX_UNITS = int(np.iinfo(np.uint16).max)
_SCALE32 = np.float32(DEPTH_SCALE)


def rgb_reference(rgba: np.ndarray) -> np.ndarray:
    """The conversion datagen used until issue 15, kept as the definition of the bytes."""
    return np.clip(rgba[..., :3] * 255.0 + 0.5, 0, 255).astype(np.uint8)


def depth_reference(position: np.ndarray) -> np.ndarray:
    on_surface = position[..., 3] < 1.0
    depth_m = np.where(on_surface, -position[..., 2], 0.0)
    return np.clip(np.rint(depth_m / DEPTH_SCALE), 0, DEPTH_MAX_UNITS).astype(np.uint16)


class Scratch:
    """Float32 work buffers reused across frames of one shape (one per process and camera
    size); what is returned is always a fresh array."""

    def __init__(self) -> None:
        self._buffers: dict[tuple, np.ndarray] = {}

    def get(self, name: str, shape: tuple[int, ...], dtype: Any = np.float32) -> np.ndarray:
        key = (name, shape, np.dtype(dtype).str)
        buffer = self._buffers.get(key)
        if buffer is None:
            buffer = self._buffers[key] = np.empty(shape, dtype)
        return buffer


_scratch = Scratch()


def rgb_from_colour(rgba: np.ndarray, scratch: Scratch = _scratch) -> np.ndarray:
    """(H, W, 4) float32 in [0, 1] -> (H, W, 3) uint8, equal to :func:`rgb_reference`.
    All four channels are worked on: contiguous passes are faster than strided ones."""
    work = scratch.get("rgba", rgba.shape)
    rgba8 = scratch.get("rgba8", rgba.shape, np.uint8)
    np.multiply(rgba, np.float32(255.0), out=work)
    np.add(work, np.float32(0.5), out=work)
    np.minimum(work, np.float32(255.0), out=work)  # min then max = np.clip, NaN included
    np.maximum(work, np.float32(0.0), out=work)
    np.copyto(rgba8, work, casting="unsafe")  # truncation = floor on [0, 255]
    return cv2.cvtColor(rgba8, cv2.COLOR_RGBA2RGB)


def depth_from_position(position: np.ndarray, scratch: Scratch = _scratch) -> np.ndarray:
    """(H, W, 4) float32 OpenGL camera xyzw -> (H, W) uint16 millimetres, 0 off surfaces;
    equal to :func:`depth_reference`."""
    work = scratch.get("depth", position.shape[:-1])
    off_surface = scratch.get("off", position.shape[:-1], np.bool_)
    np.less(position[..., 3], np.float32(1.0), out=off_surface)
    np.logical_not(off_surface, out=off_surface)  # NaN w is off the surface, as in "w < 1"
    np.divide(position[..., 2], -_SCALE32, out=work)  # IEEE: z / -s == -z / s, bit for bit
    np.rint(work, out=work)
    np.minimum(work, np.float32(DEPTH_MAX_UNITS), out=work)
    np.maximum(work, np.float32(0.0), out=work)
    np.copyto(work, np.float32(0.0), where=off_surface)
    depth = np.empty(work.shape, np.uint16)
    np.copyto(depth, work, casting="unsafe")
    return depth


def ids_from_segmentation(segmentation: np.ndarray) -> np.ndarray:
    """(H, W, 4) uint32 -> (H, W) uint32 per-scene entity id (channel 1)."""
    return np.ascontiguousarray(segmentation[..., 1])


# ------------------------------------------------------------------ torch (any device, GPU path)


def rgb_from_colour_torch(rgba):
    """:func:`rgb_from_colour` on a torch float32 tensor of any device; same bits."""
    import torch

    work = rgba[..., :3] * torch.tensor(255.0, dtype=torch.float32, device=rgba.device)
    work = work + torch.tensor(0.5, dtype=torch.float32, device=rgba.device)
    return work.clamp_(0, 255).to(torch.uint8)


def depth_from_position_torch(position):
    """:func:`depth_from_position` on a torch float32 tensor of any device; same bits.
    The scale is a device tensor, not a Python number: CUDA kernels turn division by a host
    scalar into multiplication by its reciprocal, which rounds differently."""
    import torch

    scale = torch.tensor(DEPTH_SCALE, dtype=torch.float32, device=position.device)
    work = torch.div(-position[..., 2], scale)
    work = torch.round(work).clamp_(0, DEPTH_MAX_UNITS)  # round = half to even, like np.rint
    work = torch.where(position[..., 3] < 1.0, work, torch.zeros_like(work))
    return work.to(torch.int32)  # exact in [0, 65535]; stored as uint16 after the copy back


def ids_from_segmentation_torch(segmentation):
    return segmentation[..., 1].contiguous()
