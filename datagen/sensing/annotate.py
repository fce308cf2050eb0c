"""Labels from the rendered buffers: instance and semantic maps, boxes, visibility, poses.

Pixel convention: a 2D box is ``[x_min, y_min, x_max, y_max]`` in pixel indices, inclusive,
taken from the instance mask. Projected points (``obb_corners_px``) are image-plane coordinates
as the intrinsics define them: pixel (col, row) has its centre at (col + 0.5, row + 0.5).
Visibility compares the visible mask with the object's amodal silhouette: its convex parts (or,
for a user's mesh, the rendered mesh's triangles) projected through the same camera and
rasterised by the renderer's rule (see ``silhouette``), so a fully visible object has
``visible_fraction`` 1.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from scipy import ndimage

from datagen.geometry import image_points, pose_record
from datagen.records import ObjectViewRecord, ObjectWorldRecord
from datagen.sensing.silhouette import convex_outlines, front_facing, silhouette_pixels

if TYPE_CHECKING:  # only for annotations: drawing and tests need no simulator
    from datagen.sensing.render import Frame

# beyond this many row spans (a detailed mesh filling much of the view) the convex parts'
# silhouette stands in for the triangles': milliseconds instead of seconds
MAX_TRIANGLE_SPANS = 2_000_000
UNIT_BOX_CORNERS = np.array(
    [[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)]
)


@dataclass
class LabelledObject:
    instance_id: int
    class_name: str
    class_id: int
    entity_id: int  # SAPIEN per-scene id, as in the Segmentation buffer
    pose_world: np.ndarray  # (4, 4) object -> world
    parts: list[np.ndarray]  # convex parts' vertices, object frame, (N_i, 3) each
    obb_transform: np.ndarray  # (4, 4) box frame -> object frame
    obb_extents: np.ndarray  # (3,) metres
    # (F, 3, 3) object frame: the rendered mesh's triangles where the union of the convex parts
    # is not what the renderer draws (a user's mesh); the silhouette then comes from them
    visual_triangles: np.ndarray | None = None
    role: str = "target"  # or "distractor" (not a grasp target)


def label_maps(
    frame: Frame,
    objects: list[LabelledObject],
    stuff_class_ids: dict[int, int],
    stuff_instances: dict[int, int] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Instance map (uint16, 0 = no instance) and semantic class map (uint8, 0 = background).
    ``stuff_instances``: entity id -> instance id of stuff that is also an instance (the robot's
    links, ``datagen.sensing.robot_labels``)."""
    stuff_instances = stuff_instances or {}
    ids = [0, int(frame.entity_ids.max()), *stuff_class_ids, *(o.entity_id for o in objects)]
    instance_lut = np.zeros(max(ids) + 1, np.uint16)
    class_lut = np.zeros(max(ids) + 1, np.uint8)
    for entity_id, class_id in stuff_class_ids.items():
        class_lut[entity_id] = class_id
        instance_lut[entity_id] = stuff_instances.get(entity_id, 0)
    for obj in objects:
        instance_lut[obj.entity_id] = obj.instance_id
        class_lut[obj.entity_id] = obj.class_id
    return instance_lut[frame.entity_ids], class_lut[frame.entity_ids]


def _amodal_pixels(obj: LabelledObject, frame: Frame, near: float) -> tuple[int, int]:
    """(pixels of the whole silhouette, of which inside the image), ignoring occluders."""
    height, width = frame.depth.shape
    if obj.visual_triangles is not None:
        uv, z = _image_points(obj, obj.visual_triangles.reshape(-1, 3), frame)
        if (z <= near).any():
            return 0, 0  # crosses the camera plane: no meaningful silhouette
        triangles = uv.reshape(-1, 3, 2)
        # no margin: neighbouring triangles share edges, which must not lose their pixels
        counts = silhouette_pixels(
            triangles[front_facing(triangles)], width, height, 0.0, MAX_TRIANGLE_SPANS
        )
        if counts is not None:
            return counts
    projected = []
    for part in obj.parts:
        uv, z = _image_points(obj, part, frame)
        if (z <= near).any():
            return 0, 0
        projected.append(uv)
    counts = silhouette_pixels(convex_outlines(projected), width, height)
    assert counts is not None  # no span limit: always counted
    return counts


def _image_points(
    obj: LabelledObject, points: np.ndarray, frame: Frame
) -> tuple[np.ndarray, np.ndarray]:
    world = points @ obj.pose_world[:3, :3].T + obj.pose_world[:3, 3]
    return image_points(world, frame.intrinsics, frame.extrinsics)


def visible_pixels_and_boxes(
    instance_map: np.ndarray, instance_ids: list[int]
) -> list[tuple[int, list[int] | None]]:
    """Per instance id, its visible pixels in ``instance_map`` and their box ``[x0, y0, x1, y1]``
    (None: no pixel visible)."""
    max_id = max(instance_ids, default=0)
    counts = np.bincount(instance_map.ravel(), minlength=max_id + 1)
    # every instance's bounding slices in one pass over the map (7x faster than a mask each)
    extents = ndimage.find_objects(instance_map, max_label=max_id) if max_id else []
    out = []
    for instance_id in instance_ids:
        visible, bbox = int(counts[instance_id]), None
        if visible:
            rows, cols = extents[instance_id - 1]
            bbox = [cols.start, rows.start, cols.stop - 1, rows.stop - 1]
        out.append((visible, bbox))
    return out


def object_view_records(
    frame: Frame, instance_map: np.ndarray, objects: list[LabelledObject], near: float
) -> list[ObjectViewRecord]:
    """Per object, what this camera sees of it. Objects with no visible pixel have ``bbox: None``."""
    pixels = visible_pixels_and_boxes(instance_map, [o.instance_id for o in objects])
    records: list[ObjectViewRecord] = []
    for obj, (visible, bbox) in zip(objects, pixels, strict=True):
        amodal, amodal_inside = _amodal_pixels(obj, frame, near)
        obb_world = obj.pose_world @ obj.obb_transform
        corners = (UNIT_BOX_CORNERS * obj.obb_extents) @ obb_world[:3, :3].T + obb_world[:3, 3]
        corners_px, _ = image_points(corners, frame.intrinsics, frame.extrinsics)
        records.append(
            {
                "instance_id": obj.instance_id,
                "class": obj.class_name,
                "class_id": obj.class_id,
                "role": obj.role,
                "visible": visible > 0,
                "visible_pixels": visible,
                "bbox_xyxy": bbox,
                # visible / whole silhouette (occlusion and truncation); 1.0 = fully visible
                "visible_fraction": round(min(1.0, visible / amodal), 6) if amodal else 0.0,
                "in_frame_fraction": round(amodal_inside / amodal, 6) if amodal else 0.0,
                "pose_camera": pose_record(frame.extrinsics @ obj.pose_world),
                "obb_corners_px": np.round(corners_px, 3).tolist(),
            }
        )
    return records


def object_world_record(obj: LabelledObject) -> ObjectWorldRecord:
    return {
        "instance_id": obj.instance_id,
        "class": obj.class_name,
        "class_id": obj.class_id,
        "pose_world": pose_record(obj.pose_world),
        "obb": {
            "pose_world": pose_record(obj.pose_world @ obj.obb_transform),
            "extents": np.round(obj.obb_extents, 7).tolist(),
        },
    }
