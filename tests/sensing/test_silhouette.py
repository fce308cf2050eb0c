"""Silhouette pixel counting (pure arithmetic): the renderer's pixel-centre rule, unions of parts,
the snapping margin, the counting window and the work budget."""

import numpy as np
import pytest

from datagen.sensing import silhouette
from datagen.sensing.silhouette import (
    convex_outlines,
    silhouette_pixels,
    union_pixel_count,
)


def centres_inside(polygons, lo, hi):
    """Reference: every pixel centre of the window lo..hi (cols and rows) tested against every
    edge of every convex polygon (image-plane coordinates, pixel (c, r) centred at c+.5, r+.5)."""
    rows, cols = np.mgrid[lo:hi, lo:hi]
    q = np.stack([cols + 0.5, rows + 0.5], axis=-1)
    covered = np.zeros(rows.shape, bool)
    for p in polygons:
        turn = np.sign(np.cross(p[1] - p[0], p[2] - p[0]))
        inside = np.ones(rows.shape, bool)
        for a, b in zip(p, np.roll(p, -1, axis=0), strict=True):
            inside &= turn * np.cross(b - a, q - a) >= 0
        covered |= inside
    return covered


def test_counts_match_a_pixel_by_pixel_reference_for_random_unions_of_convex_parts():
    rng = np.random.default_rng(0)
    width, height = 40, 30
    for _ in range(150):
        parts = [
            rng.uniform(-20, 60, 2) + rng.normal(size=(rng.integers(3, 12), 2)) * rng.uniform(1, 20)
            for _ in range(rng.integers(1, 4))
        ]
        outlines = convex_outlines(parts)
        hulls = [np.unique(o, axis=0, return_index=True)[1] for o in outlines]
        polygons = [o[np.sort(i)] for o, i in zip(outlines, hulls, strict=True)]
        covered = centres_inside(polygons, -120, 150)  # the counting window: 4 images around
        expected = (int(covered.sum()), int(covered[120 : 120 + height, 120 : 120 + width].sum()))
        assert silhouette_pixels(outlines, width, height, margin=0.0) == expected


def test_pixel_centres_on_an_edge_count_without_margin_and_not_with_it():
    square = np.array([[[0.5, 0.5], [2.5, 0.5], [2.5, 2.5], [0.5, 2.5]]])  # edges through centres
    assert silhouette_pixels(square, 8, 8, margin=0.0) == (9, 9)
    assert silhouette_pixels(square, 8, 8) == (1, 1)  # the default keeps a 1/256 px margin
    # whole pixels: the square covering pixels 1..3 x 2..5 exactly
    block = np.array([[[1.0, 2.0], [4.0, 2.0], [4.0, 6.0], [1.0, 6.0]]])
    assert silhouette_pixels(block, 8, 8) == (12, 12)
    assert silhouette_pixels(block - [2.0, 0.0], 8, 8) == (12, 8)  # one column off the image


def test_overlapping_parts_count_once_and_a_flat_part_covers_nothing():
    a = np.array([[0.0, 0.0], [4.0, 0.0], [4.0, 4.0], [0.0, 4.0]])
    flat = np.array([[0.0, 0.5], [3.0, 0.5], [6.0, 0.5]])  # no area, through pixel centres
    outlines = convex_outlines([a, a + 2.0, flat])
    assert silhouette_pixels(outlines, 16, 16) == (16 + 16 - 4, 28)
    assert silhouette_pixels(convex_outlines([flat]), 16, 16) == (0, 0)


def test_spans_of_one_row_are_merged():
    row = np.array([5, 5, 5, 5, 6])
    first = np.array([0, 2, 10, 3, 0])
    last = np.array([4, 8, 12, 3, 0])
    assert union_pixel_count(row, first, last) == 9 + 3 + 1
    assert union_pixel_count(*(np.array([], np.int64),) * 3) == 0


def test_a_huge_silhouette_is_counted_within_the_window_and_the_budget_holds():
    giant = np.array([[[-1e6, -1e6], [1e6, -1e6], [1e6, 1e6], [-1e6, 1e6]]])
    assert silhouette_pixels(giant, 10, 10) == (90 * 90, 100)  # 4 images beyond each border
    assert silhouette_pixels(giant, 10, 10, max_spans=89) is None
    assert silhouette_pixels(giant, 10, 10, max_spans=90) == (8100, 100)


def test_chunks_change_nothing(monkeypatch):
    rng = np.random.default_rng(1)
    triangles = rng.uniform(0, 60, (500, 1, 2)) + rng.uniform(-3, 3, (500, 3, 2))
    whole = silhouette_pixels(triangles, 64, 48, margin=0.0)
    monkeypatch.setattr(silhouette, "CHUNK", 7)
    assert silhouette_pixels(triangles, 64, 48, margin=0.0) == whole
    assert 0 < whole[1] < whole[0]


@pytest.mark.sim
def test_the_renderer_draws_the_triangles_front_facing_names():
    """One triangle each way round, side by side before a camera: SAPIEN culls back faces, so
    only the one ``front_facing`` keeps is in the picture."""
    import sapien

    from datagen.geometry import image_points
    from datagen.sensing.cameras import add_camera
    from datagen.sensing.render import capture

    scene = sapien.Scene()
    corners = np.array([[0, -0.1, -0.1], [0, 0.1, -0.1], [0, 0, 0.1]], np.float32)
    triangles = []
    for order, side in (([0, 1, 2], 0.15), ([0, 2, 1], -0.15)):
        shape = sapien.render.RenderShapeTriangleMesh(
            corners, np.array([order], np.uint32), np.tile([1.0, 0, 0], (3, 1)).astype(np.float32),
            np.zeros((3, 2), np.float32), sapien.render.RenderMaterial(base_color=[1, 0, 0, 1]),
        )  # fmt: skip
        body = sapien.render.RenderBodyComponent()
        body.attach(shape)
        entity = sapien.Entity()
        entity.add_component(body)
        scene.add_entity(entity)
        entity.set_pose(sapien.Pose([0, side, 0]))
        triangles.append((entity.per_scene_id, corners[order] + [0, side, 0]))
    camera = add_camera(scene, "c", 64, 64, 1.0, 0.01, 10.0)
    camera.entity.set_pose(sapien.Pose([-1, 0, 0]))  # looking along +x at both
    scene.update_render()
    frame = capture(camera)
    drawn = []
    for entity_id, world in triangles:
        uv, _ = image_points(world.astype(float), frame.intrinsics, frame.extrinsics)
        pixels = int((frame.entity_ids == entity_id).sum())
        drawn.append((bool(silhouette.front_facing(uv.reshape(1, 3, 2))[0]), pixels > 0))
    assert drawn == [(False, False), (True, True)]
