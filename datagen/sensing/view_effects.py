"""The camera effects and the depth sensor of one rendered view, annotations kept consistent.

Lens distortion is applied to the colour image and to every pixel annotation with one map
(depth, sensor depth, instance and semantic maps by nearest neighbour), so masks, boxes and
visible pixels are those of the distorted image; ``obb_corners_px`` are projected through the
distortion; the calibration gets the distorted images' intrinsics and the coefficients.
``visible_fraction`` and ``in_frame_fraction`` are ratios measured in the pinhole render (the
distortion moves pixels, not what is hidden). The sensor depth is made from the pinhole render
(its projector geometry is a pinhole's) and then distorted like the clean depth.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np
from scipy import ndimage

from datagen.sensing.annotate import UNIT_BOX_CORNERS, LabelledObject
from datagen.sensing.camera_effects import apply_camera_effects
from datagen.sensing.depth_sensor import sensor_depth
from datagen.sensing.encode import View
from datagen.sensing.lens import DISTORTION_MODEL, Lens, distort, lens_for, project_distorted
from datagen.sensing.robot_labels import LabelledPart, distorted_part_records
from datagen.sensing.stage_clock import timed


def distorted_records(
    records: list[dict[str, Any]],
    instance: np.ndarray,
    objects: list[LabelledObject],
    extrinsics: np.ndarray,
    lens: Lens,
) -> list[dict[str, Any]]:
    """The view's object records with the pixel labels of the distorted images."""
    max_id = max((o.instance_id for o in objects), default=0)
    counts = np.bincount(instance.ravel(), minlength=max_id + 1)
    extents = ndimage.find_objects(instance, max_label=max_id) if max_id else []
    out = []
    for obj, record in zip(objects, records, strict=True):
        visible = int(counts[obj.instance_id])
        bbox = None
        if visible:
            rows, cols = extents[obj.instance_id - 1]
            bbox = [cols.start, rows.start, cols.stop - 1, rows.stop - 1]
        box_camera = extrinsics @ obj.pose_world @ obj.obb_transform
        corners = (UNIT_BOX_CORNERS * obj.obb_extents) @ box_camera[:3, :3].T + box_camera[:3, 3]
        out.append(
            record
            | {
                "visible": visible > 0,
                "visible_pixels": visible,
                "bbox_xyxy": bbox,
                "obb_corners_px": np.round(project_distorted(corners, lens), 3).tolist(),
            }
        )
    return out


def apply_view_effects(
    view: View,
    intrinsics: np.ndarray,
    extrinsics: np.ndarray,
    view_meta: dict[str, Any],
    objects: list[LabelledObject],
    effects: dict[str, Any] | None,
    sensor: dict[str, Any] | None,
    keep_clean: bool,
    parts: list[LabelledPart] | None = None,
) -> tuple[View, dict[str, Any]]:
    """(the view's stored images, its metadata) after the effects. ``effects`` / ``sensor``:
    the drawn values (None: that part is off); they are stored in the metadata as given.
    ``parts``: the robot's labelled parts, whose records are ``robot_parts``."""
    meta = dict(view_meta)
    with timed("effects"):
        if sensor is not None:
            depth = sensor_depth(
                view.depth,
                view.rgb,
                view.instance,
                intrinsics,
                sensor,
                view_meta["camera"]["depth_scale"],
            )
            view = replace(view, depth_sensor=depth)
            meta["depth_sensor"] = sensor
        if effects is None:
            return view, meta
        effects = dict(effects)
        coefficients = effects.pop("distortion", None)
        if coefficients is not None:
            camera = meta["camera"]
            lens = lens_for(intrinsics, coefficients, camera["width"], camera["height"])
            view = View(
                distort(view.rgb, lens, nearest=False),
                distort(view.depth, lens, nearest=True),
                distort(view.instance, lens, nearest=True),
                distort(view.semantic, lens, nearest=True),
                None if view.depth_sensor is None else distort(view.depth_sensor, lens, True),
            )
            meta["camera"] = camera | {
                "intrinsics": np.round(lens.intrinsics, 6).tolist(),
                "render_intrinsics": camera["intrinsics"],
                "distortion": coefficients,
                "distortion_model": DISTORTION_MODEL,
            }
            meta["objects"] = distorted_records(
                meta["objects"], view.instance, objects, extrinsics, lens
            )
            if parts:
                meta["robot_parts"] = distorted_part_records(
                    meta["robot_parts"], view.instance, parts
                )
        clean = view.rgb if keep_clean else None
        view = replace(view, rgb=apply_camera_effects(view.rgb, effects), rgb_clean=clean)
        meta["camera_effects"] = effects
    return view, meta


def stored_colour(render_rgb: np.ndarray, view_meta: dict[str, Any]) -> np.ndarray:
    """A view's stored colour image made again from its pinhole render and its metadata alone
    (replay): the lens of ``camera.distortion``, then the ``camera_effects``."""
    camera, rgb = view_meta["camera"], render_rgb
    if "distortion" in camera:
        render_k = np.asarray(camera["render_intrinsics"], float)
        lens = lens_for(render_k, camera["distortion"], camera["width"], camera["height"])
        rgb = distort(rgb, lens, nearest=False)
    if "camera_effects" in view_meta:
        rgb = apply_camera_effects(rgb, view_meta["camera_effects"])
    return rgb
