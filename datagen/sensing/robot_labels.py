"""The robot as labelled instances: its arm and its gripper, each one instance of the links of its
semantic class (``robot``, ``gripper``), with per-view records like an object's.

A part's visible fraction compares its visible pixels with the silhouette of the meshes its links
are drawn with, projected through the same camera and rasterised by the renderer's rule
(``datagen.sensing.silhouette``), so an unoccluded arm in frame has ``visible_fraction`` 1.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import sapien

from datagen.geometry import image_points
from datagen.sensing.annotate import visible_pixels_and_boxes
from datagen.sensing.silhouette import front_facing, silhouette_pixels

if TYPE_CHECKING:
    from datagen.sensing.render import Frame

PART_CLASSES = ("robot", "gripper")  # in instance order: the arm, then the gripper


@dataclass
class LabelledPart:
    instance_id: int
    class_name: str
    class_id: int
    links: list[str]  # link names, in the articulation's order
    entity_ids: list[int]  # SAPIEN per-scene ids of the links, as in the Segmentation buffer
    triangles: np.ndarray  # (F, 3, 3) world metres: the drawn meshes of its links, posed


def _link_triangles(entity: sapien.Entity) -> list[np.ndarray]:
    """The drawn triangles of one link, world frame, each (F, 3, 3)."""
    body = entity.find_component_by_type(sapien.render.RenderBodyComponent)
    if body is None:
        return []
    out = []
    for shape in body.render_shapes:
        pose = (entity.pose * shape.local_pose).to_transformation_matrix()
        scale = np.asarray(getattr(shape, "scale", (1.0, 1.0, 1.0)), float)
        for part in shape.parts:
            vertices = np.asarray(part.vertices, float) * scale @ pose[:3, :3].T + pose[:3, 3]
            triangles = np.asarray(part.triangles, np.int64)
            # a mirroring scale turns every triangle round; SAPIEN then draws the other side
            out.append(vertices[triangles if np.prod(scale) > 0 else triangles[:, ::-1]])
    return out


def robot_parts(
    links: list[sapien.physx.PhysxArticulationLinkComponent],
    stuff: dict[int, str],
    class_id: dict[str, int],
    first_instance: int,
) -> list[LabelledPart]:
    """The arm and the gripper as instances ``first_instance`` and ``first_instance + 1``; a link
    belongs to the part its semantic class (``stuff``, per-scene id -> class) names."""
    parts = []
    for k, name in enumerate(PART_CLASSES):
        mine = [link for link in links if stuff.get(link.entity.per_scene_id) == name]
        triangles = [t for link in mine for t in _link_triangles(link.entity)]
        parts.append(
            LabelledPart(
                first_instance + k,
                name,
                class_id[name],
                [link.name for link in mine],
                [link.entity.per_scene_id for link in mine],
                np.concatenate(triangles) if triangles else np.zeros((0, 3, 3)),
            )
        )
    return parts


def part_instance_ids(parts: list[LabelledPart]) -> dict[int, int]:
    """Per-scene entity id -> instance id, for the instance map."""
    return {entity: p.instance_id for p in parts for entity in p.entity_ids}


def _amodal_pixels(part: LabelledPart, frame: Frame, near: float) -> tuple[int, int]:
    """(pixels of the whole silhouette, of which inside the image), ignoring occluders; (0, 0)
    when a mesh crosses the camera plane (the hand, seen from the wrist camera)."""
    height, width = frame.depth.shape
    uv, z = image_points(part.triangles.reshape(-1, 3), frame.intrinsics, frame.extrinsics)
    if len(z) == 0 or (z <= near).any():
        return 0, 0
    triangles = uv.reshape(-1, 3, 2)
    # no margin: neighbouring triangles share edges, which must not lose their pixels
    counts = silhouette_pixels(triangles[front_facing(triangles)], width, height, margin=0.0)
    assert counts is not None  # no span limit: always counted
    return counts


def pixel_labels(instance_map: np.ndarray, parts: list[LabelledPart]) -> list[dict[str, Any]]:
    """Per part, its visible pixels and box in ``instance_map`` (None: no pixel visible)."""
    return [
        {"visible": visible > 0, "visible_pixels": visible, "bbox_xyxy": bbox}
        for visible, bbox in visible_pixels_and_boxes(instance_map, [p.instance_id for p in parts])
    ]


def part_view_records(
    frame: Frame, instance_map: np.ndarray, parts: list[LabelledPart], near: float
) -> list[dict[str, Any]]:
    """Per part, what this camera sees of it (the view's ``robot_parts``)."""
    records = []
    for part, pixels in zip(parts, pixel_labels(instance_map, parts), strict=True):
        amodal, inside = _amodal_pixels(part, frame, near)
        visible = pixels["visible_pixels"]
        records.append(
            {
                "instance_id": part.instance_id,
                "class": part.class_name,
                "class_id": part.class_id,
                "links": part.links,
            }
            | pixels
            | {
                # visible / whole silhouette (occlusion and truncation); 1.0 = fully visible
                "visible_fraction": round(min(1.0, visible / amodal), 6) if amodal else 0.0,
                "in_frame_fraction": round(inside / amodal, 6) if amodal else 0.0,
            }
        )
    return records


def distorted_part_records(
    records: list[dict[str, Any]], instance_map: np.ndarray, parts: list[LabelledPart]
) -> list[dict[str, Any]]:
    """The parts' records with the pixel labels of the distorted images (fractions are kept:
    they are measured in the pinhole render)."""
    return [
        record | pixels
        for record, pixels in zip(records, pixel_labels(instance_map, parts), strict=True)
    ]
