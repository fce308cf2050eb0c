"""Annotation arithmetic on hand-made buffers (no renderer)."""

import numpy as np

from datagen.engines.sim.annotate import LabelledObject, label_maps, object_view_records
from datagen.engines.sim.render import Frame
from datagen.geometry import look_at, project, world_to_cv_camera


def frame_looking_down(width=64, height=48, f=50.0):
    intrinsics = np.array([[f, 0, width / 2], [0, f, height / 2], [0, 0, 1.0]])
    extrinsics = world_to_cv_camera(look_at([0, 0, 1.0], [0, 0, 0], up=[1, 0, 0]))
    ids = np.zeros((height, width), np.uint32)
    return Frame(
        np.zeros((height, width, 3), np.uint8),
        np.zeros((height, width), np.uint16),
        ids,
        intrinsics,
        extrinsics,
    )


def cube(instance_id, entity_id, centre, half=0.05):
    pose = np.eye(4)
    pose[:3, 3] = centre
    corners = np.array(
        [[x, y, z] for x in (-half, half) for y in (-half, half) for z in (-half, half)]
    )
    return LabelledObject(
        instance_id, "box", 5, entity_id, pose, [corners], np.eye(4), np.full(3, 2 * half)
    )


def test_camera_centre_projects_to_principal_point():
    frame = frame_looking_down()
    uv, z = project(np.array([[0.0, 0.0, 0.0]]), frame.intrinsics, frame.extrinsics)
    assert np.allclose(uv[0], [31.5, 23.5]) and np.isclose(z[0], 1.0)


def test_boxes_come_from_the_mask_and_visibility_from_the_silhouette():
    frame = frame_looking_down()
    a, b = cube(1, 40, [0, 0, 0]), cube(2, 41, [0.0, 0.2, 0])
    frame.entity_ids[10:20, 5:15] = 40  # a drawn where it is not: the box must follow the mask
    frame.entity_ids[0, 0] = 7  # a stuff entity (say the table)
    instance, semantic = label_maps(frame, [a, b], {7: 2})
    assert (
        instance[12, 6] == 1
        and semantic[12, 6] == 5
        and semantic[0, 0] == 2
        and instance[0, 0] == 0
    )
    records = {r["instance_id"]: r for r in object_view_records(frame, instance, [a, b], near=0.01)}
    assert records[1]["bbox_xyxy"] == [5, 10, 14, 19]
    assert records[1]["visible_pixels"] == 100
    assert records[2]["visible"] is False and records[2]["bbox_xyxy"] is None
    # cube a: 0.1 m wide at 0.95-1.05 m -> about 5 px wide silhouette, fully inside the frame
    assert records[1]["in_frame_fraction"] == 1.0
    assert 0 < records[1]["visible_fraction"] <= 1.0
    assert np.allclose(records[1]["pose_camera"]["position"], [0, 0, 1.0], atol=1e-6)


def test_an_object_far_outside_the_image_is_not_visible_and_not_in_frame():
    frame = frame_looking_down()
    far = cube(1, 40, [10.0, 10.0, 0.0])  # ~500 px off the 64x48 image, beyond the amodal canvas
    instance, _ = label_maps(frame, [far], {})
    (record,) = object_view_records(frame, instance, [far], near=0.01)
    assert record["visible"] is False and record["bbox_xyxy"] is None
    assert record["visible_fraction"] == 0.0 and record["in_frame_fraction"] == 0.0
