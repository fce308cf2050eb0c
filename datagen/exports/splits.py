"""The train/validation split of the exports that write one (robomimic's masks, YOLO's folders):
decided by the sample key alone, so a sample lands in the same split in every export, every
rebuild and every machine, whatever else the dataset holds.

A sample is in validation when the first 8 bytes of SHA-256 of its key, read as a big-endian
integer, are below ``VALID_PERCENT`` modulo 100: about 10 % of the samples, none of a tiny dataset.
"""

from __future__ import annotations

import hashlib

VALID_PERCENT = 10


def is_valid(key: str) -> bool:
    """Whether the sample ``key`` belongs to the validation split."""
    digest = hashlib.sha256(key.encode("utf-8")).digest()
    return int.from_bytes(digest[:8], "big") % 100 < VALID_PERCENT


def split_of(key: str) -> str:
    """``"val"`` or ``"train"``."""
    return "val" if is_valid(key) else "train"
