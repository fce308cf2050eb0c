"""One description of the tabletop's static geometry (datagen/assets/tabletop_layout.py), realised
by the simulator scene (datagen/families/grasp_tabletop/world.py) and by the USD export
(datagen/exports/usd_stage.py): both build exactly its boxes, so the two cannot drift (they did:
the USD floor was 5 m across where SAPIEN's is 10 m, and the table had no legs in USD)."""

from __future__ import annotations

import numpy as np
import pytest
import sapien
from pxr import Usd, UsdGeom

from datagen.assets.tabletop_layout import static_parts
from datagen.config import config_from_dict
from datagen.exports import usd_stage
from datagen.families.grasp_tabletop.values import draw_scene
from datagen.families.grasp_tabletop.world import construct_scene
from datagen.sensing.render import keep_renderer_alive

TINY = {"render": {"width": 64, "height": 48}, "objects": {"count": [1, 1]}}


def _rounded(boxes) -> list[tuple]:
    """(centre, half size) boxes in world metres, rounded to 0.1 mm and sorted."""
    return sorted(
        (tuple(round(float(x), 4) for x in c), tuple(round(float(x), 4) for x in h))
        for c, h in boxes
    )


def _described(surfaces) -> list[tuple]:
    return _rounded(
        (np.add(part.position, offset), half)
        for part in static_parts()
        if part.surface in surfaces
        for half, offset in part.boxes
    )


def _sampled(texture_probability: float) -> dict:
    config = config_from_dict(TINY | {"materials": {"texture_probability": texture_probability}})
    return config, draw_scene(config, 1, 0, (0.08, 0.0, 0.76), (0.2, 0.26))


@pytest.mark.sim
@pytest.mark.parametrize("texture_probability", [0.0, 1.0])
def test_the_simulator_builds_the_described_boxes(texture_probability):
    keep_renderer_alive()
    config, params = _sampled(texture_probability)
    built = construct_scene(config, params)
    # an untextured floor is SAPIEN's ground plane, drawn by the plane itself
    surfaces = {"floor", "table", "tray"} if texture_probability else {"table", "tray"}
    boxes = []
    for entity in built.scene.entities:
        body = entity.find_component_by_type(sapien.render.RenderBodyComponent)
        if body is None or built.stuff.get(entity.per_scene_id) not in surfaces:
            continue  # the textured floor's ground collides only: its slab is drawn
        for shape in body.render_shapes:
            centre = (entity.pose * shape.local_pose).p
            if isinstance(shape, sapien.render.RenderShapeBox):
                boxes.append((centre, shape.half_size))
            else:  # a textured box is a mesh about its centre
                vertices = shape.get_parts()[0].vertices
                boxes.append((centre, (vertices.max(0) - vertices.min(0)) / 2))
    assert _rounded(boxes) == _described(surfaces)


def test_the_usd_export_builds_the_described_boxes():
    _, params = _sampled(1.0)
    stage = Usd.Stage.CreateInMemory()
    usd_stage._static_parts(stage, "k", params["materials"], None)
    boxes = []
    for prim in stage.Traverse():
        if prim.IsA(UsdGeom.Mesh):
            box = UsdGeom.Mesh(prim).ComputeWorldBound(Usd.TimeCode.Default(), "default")
            aligned = box.ComputeAlignedRange()
            lo, hi = np.asarray(aligned.GetMin(), float), np.asarray(aligned.GetMax(), float)
            boxes.append(((lo + hi) / 2, (hi - lo) / 2))
    assert _rounded(boxes) == _described({"floor", "table", "tray"})
