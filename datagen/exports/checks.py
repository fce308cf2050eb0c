"""What every export checks of the values it writes: the rules of :mod:`datagen.dataset.values`
(the ones ``inspect`` and ``preview`` apply), applied to the keys the export reads.

An export refuses the dataset at the first sample that breaks a rule: ``BadSample`` names the
key, the runner adds the dataset, the sample and the format, and nothing is kept (an export
holds every sample or none; docs/exports.md). JSON is written by :func:`strict_json`, which
names the key of a number that is not finite instead of writing ``NaN`` or ``Infinity``.
"""

from __future__ import annotations

import json
import math
from typing import Any

import numpy as np

from datagen.dataset.values import (
    FLOAT32_MAX,
    MAX_METRES,
    BadSample,
    finite_matrix,
    image_box,
    intrinsics,
    non_finite,
    pose_matrix,
    shown,
)
from datagen.dataset.views import LabelledView
from datagen.records import ExportedDataset, SampleMetadata

MAX_FPS = 1000.0  # frames a second: datagen renders at most a few tens
MAX_DISTORTION = 100.0  # a lens coefficient; drawn ones are within +-1


def view_name(view: LabelledView) -> str:
    """How a message names a view: ``view workspace``, ``view wrist``, ``view f0003``."""
    return f"view {view.name or 'workspace'}"


def view_boxes(view: LabelledView, size: tuple[int, int]) -> list[tuple[int, int, int, int]]:
    """Each instance's ``bbox_xyxy`` in the view, checked to lie in an image of ``size``."""
    boxes = []
    for inst in view.instances:
        where = f"{view_name(view)}: instance {inst['instance_id']!r} bbox_xyxy"
        boxes.append(image_box(inst["bbox_xyxy"], size, where))
    return boxes


def lens_distortion(view: LabelledView) -> tuple[float, ...]:
    """A view's drawn lens distortion (k1, k2, p1, p2, k3): finite, each within +-MAX_DISTORTION."""
    value = view.camera["distortion"]
    where = f"{view_name(view)}: camera.distortion"
    found = finite_matrix([value], (1, 5), where)[0]
    if np.abs(found).max() > MAX_DISTORTION:
        raise BadSample(
            f"{where}: expected 5 coefficients within +-{MAX_DISTORTION:g}, got {value}"
        )
    return tuple(float(v) for v in found)


def view_camera(view: LabelledView, key: str = "intrinsics") -> tuple[np.ndarray, np.ndarray]:
    """(K, world-to-camera E) of a view: its ``key`` intrinsics and its extrinsics, checked."""
    where = f"{view_name(view)}: camera"
    K = intrinsics(view.camera, where, key)
    E = pose_matrix(
        view.camera["extrinsics_world_to_camera"], f"{where}.extrinsics_world_to_camera"
    )
    return K, E


def finite_in_float32(values: np.ndarray, where: str, names: list[str] | None = None) -> None:
    """BadSample unless (T, ...) ``values`` (as a float32 format stores them) are all finite;
    the message names the frame and the column (``names``) of the first that is not."""
    if values.dtype.kind != "f":
        return
    bad = np.argwhere(~np.isfinite(values.astype(np.float32)))
    if len(bad):
        frame, column = int(bad[0][0]), (int(bad[0][1]) if values.ndim > 1 else 0)
        label = names[column] if names and column < len(names) else str(column)
        raise BadSample(
            f"{where} frame {frame} column {label!r}: {values[tuple(bad[0])]!r} is not a finite "
            f"float32 number; expected values within +-{np.finfo(np.float32).max:.3g}"
        )


def finite_rate(fps: float, where: str) -> None:
    if not (np.isfinite(fps) and 0 < fps <= MAX_FPS):
        raise BadSample(f"{where}: {fps!r} frames a second, expected a rate in (0, {MAX_FPS:g}]")


def positive_metres(value: Any, where: str) -> float:
    """A distance in metres, finite, in (0, MAX_METRES]."""
    if isinstance(value, bool) or not isinstance(value, int | float) or not 0 < value <= MAX_METRES:
        raise BadSample(f"{where}: {value!r}, expected metres in (0, {MAX_METRES:g}]")
    return float(value)


def sample_metadata(dataset: ExportedDataset, i: int) -> SampleMetadata:
    """Sample ``i``'s metadata, every number in it finite and within float32's range (as every
    format datagen writes holds it): the first that is not is named."""
    return checked_metadata(dataset.metadata(i))


def checked_metadata(meta: SampleMetadata) -> SampleMetadata:
    """``meta`` (a sample's metadata) once :func:`sample_metadata`'s rule holds for it."""
    finite_json(meta, "part json", FLOAT32_MAX)
    return meta


def finite_json(doc: Any, what: str, limit: float = math.inf) -> None:
    """BadSample naming ``what`` and the key of the first number in ``doc`` that is not finite
    (or beyond ``limit``)."""
    if (found := non_finite(doc, limit)) is not None:
        path, number = found
        within = "" if limit == math.inf else f" within +-{limit:.3g}"
        raise BadSample(f"{what}: {path} is {shown(number)}; expected a finite number{within}")


def strict_json(doc: Any, what: str, **options: Any) -> str:
    """``doc`` as JSON text (``json.dumps`` with ``options``, never ``NaN`` or ``Infinity``),
    checked by :func:`finite_json`."""
    finite_json(doc, what)
    return json.dumps(doc, allow_nan=False, **options)
