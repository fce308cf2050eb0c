"""The tools' policy for one bad sample: a sample whose stored content cannot be read, drawn or
summarised (JSON nested too deep or holding NaN, non-finite or zero intrinsics, a non-finite pose,
a box far outside any image, a field of the wrong type) is reported by key through ``on_skip`` and
left out; the other samples are drawn. Only when no sample is left does the tool fail, with one
line (``DatasetError``).

Stored values a drawing uses (intrinsics, poses, boxes) are checked here before they reach OpenCV,
which raises on NaN and on coordinates beyond a C ``int``; projections of valid values that fall
far off the image are simply not drawn.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterable, Mapping
from typing import Any, TypeVar, cast

import cv2
import numpy as np

from datagen.dataset.loader import DatasetError, ShardDataset

# the rules for stored values, one set for the tools and the exports; the tools import them here
from datagen.dataset.values import MAX_PIXEL as MAX_PIXEL
from datagen.dataset.values import BadSample as BadSample
from datagen.dataset.values import finite_matrix as finite_matrix
from datagen.dataset.values import intrinsics as intrinsics
from datagen.dataset.values import pixel_box as pixel_box
from datagen.dataset.values import pixels as pixels
from datagen.dataset.values import shown
from datagen.records import SampleMetadata
from datagen.safe_json import JsonInputError, loads_bounded

log = logging.getLogger(__name__)
T = TypeVar("T")
MAX_METADATA_BYTES = 64 * 2**20  # a sample's JSON part; datagen's are under 1 MiB


# what reading, drawing or summarising one sample raises when its content is not datagen's
SAMPLE_ERRORS = (
    BadSample,
    JsonInputError,
    DatasetError,
    KeyError,
    IndexError,
    TypeError,
    AttributeError,
    ValueError,
    OverflowError,
    ZeroDivisionError,
    cv2.error,
)

OnSkip = Callable[[str, str], None]  # (sample key, why) of a sample left out


def log_skip(key: str, reason: str) -> None:
    log.warning("sample %s skipped: %s", key, reason)


class Skipped(list):
    """An ``on_skip`` that keeps the (key, why) of every sample left out and passes each on."""

    def __init__(self, on_skip: OnSkip):
        super().__init__()
        self.on_skip = on_skip

    def __call__(self, key: str, reason: str) -> None:
        self.append((key, reason))
        self.on_skip(key, reason)


def describe(error: Exception) -> str:
    """One line saying what was wrong with a sample's content."""
    if isinstance(error, KeyError):
        text = f"no field {error.args[0]!r}" if error.args else "a field is missing"
    elif isinstance(error, BadSample | JsonInputError | DatasetError):
        text = str(error)
    else:
        text = f"{type(error).__name__}: {error}"
    text = " ".join(text.split())
    return text if len(text) <= 300 else text[:297] + "..."


def read_metadata(dataset: ShardDataset, i: int) -> SampleMetadata:
    """Sample ``i``'s JSON part, decoded with bounds (depth, size, no NaN)."""
    raw = dataset.raw(i, {"json"}).get("json")
    if raw is None:
        raise BadSample("no json part")
    meta = loads_bounded(raw, what="its json part", max_bytes=MAX_METADATA_BYTES)
    if not isinstance(meta, dict):
        raise BadSample(f"its json part is a JSON {type(meta).__name__}, expected an object")
    return cast(SampleMetadata, meta)  # a tool checks the keys it uses


def read_item(dataset: ShardDataset, i: int) -> dict[str, Any]:
    """Sample ``i`` decoded (``dataset[i]``), its JSON checked by :func:`read_metadata` first."""
    read_metadata(dataset, i)
    return dataset[i]


def each_sample(
    dataset: ShardDataset, indices: Iterable[int], work: Callable[[int], T], on_skip: OnSkip
) -> dict[int, T]:
    """``work(i)`` per index; a sample whose content makes it fail is reported and left out."""
    done = {}
    for i in indices:
        try:
            done[i] = work(i)
        except SAMPLE_ERRORS as exc:
            on_skip(dataset.keys[i], describe(exc))
    return done


def no_sample_left(root: Any, skipped: list[tuple[str, str]], doing: str) -> DatasetError:
    """The one-line failure of a tool that found no sample it could use; ``skipped`` holds the
    (key, why) of the samples it left out."""
    if not skipped:
        return DatasetError(f"{root}: the dataset has no samples to {doing}")
    key, reason = skipped[0]
    return DatasetError(
        f"{root}: no sample to {doing}: {len(skipped)} skipped, the first, sample {key}: {reason}"
    )


def check_plottable(value: Any, where: str) -> None:
    """BadSample unless every number in ``value`` (nested dicts and lists of a summary or a plot's
    data) is finite and every mapping key is a string, so that samples sort and plot together."""
    stack = [value]
    while stack:
        item = stack.pop()
        if isinstance(item, bool | str) or item is None:
            continue
        if isinstance(item, int | float | np.number):
            if not np.isfinite(float(item)):
                raise BadSample(f"{where}: a value is {item}, expected a finite number")
        elif isinstance(item, Mapping):
            if not all(isinstance(k, str) for k in item):
                names = shown([k for k in item if not isinstance(k, str)])
                raise BadSample(f"{where}: names {names}, expected text")
            stack.extend(item.values())
        elif isinstance(item, list | tuple):
            stack.extend(item)
        else:
            raise BadSample(f"{where}: a {type(item).__name__}, expected numbers and text")
