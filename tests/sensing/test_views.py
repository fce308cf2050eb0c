"""Several randomised views per settled scene (``render.views``): each a complete annotated view
of the sample, consistent with its own image; view 0 is the one-view sample's workspace camera,
byte for byte. Exports of a multi-view dataset are checked in tests/exports/test_multiview_exports.py."""

from __future__ import annotations

import json

import numpy as np
import pytest

from datagen.config import BuildConfig, config_from_dict
from datagen.config.sections import CameraConfig, RenderConfig
from datagen.dataset.parts import decode_parts
from datagen.dataset.pointcloud import view_points
from datagen.dataset.views import camera_order, labelled_views
from datagen.errors import ConfigError
from datagen.families.grasp_tabletop.values import draw_scene
from datagen.randomisers.camera import draw_extra_view, orbited_eye
from datagen.seeding import sample_rng

VIEWS = 4
SMALL = RenderConfig(width=96, height=72)
# the close-up camera (configs/grasp_closeup.yaml): objects many pixels wide even at 96 x 72
CLOSEUP = CameraConfig(eye=(-0.22, 0.28, 1.22), target=(0.08, 0.0, 0.76), fovy_deg=(42.0, 52.0))
CONFIG = BuildConfig(
    render=RenderConfig(width=96, height=72, views=VIEWS, wrist_camera=True), camera=CLOSEUP
)
IMAGE_PARTS = ("rgb.png", "depth.png", "seg.png", "semantic.png")


@pytest.fixture(scope="module")
def multi():
    from datagen.families.grasp_tabletop.produce import produce

    return produce(CONFIG, 5, 3)


@pytest.mark.sim
def test_every_view_is_a_complete_annotated_view_with_its_own_camera(multi):
    meta = json.loads(multi.parts["json"])
    names = ["workspace", "view1", "view2", "view3", "wrist"]
    assert sorted(meta["views"], key=camera_order) == names
    assert [v.name for v in labelled_views(meta)] == ["", *names[1:]]
    for name in names:
        prefix = "" if name == "workspace" else f"{name}."
        assert all(multi.parts[prefix + p][:4] == b"\x89PNG" for p in IMAGE_PARTS), name
    # the sampled camera of every view is stored, and is the camera its extrinsics describe
    cameras = {"workspace": meta["randomisation"]["camera"]} | meta["randomisation"]["extra_views"]
    assert sorted(cameras, key=camera_order) == names[:VIEWS]
    extrinsics = []
    for name, values in cameras.items():
        camera = meta["views"][name]["camera"]
        E = np.asarray(camera["extrinsics_world_to_camera"])
        centre = -E[:3, :3].T @ E[:3, 3]
        np.testing.assert_allclose(centre, values["eye"], atol=1e-5)
        assert camera["fovy_deg"] == pytest.approx(values["fovy_deg"], abs=1e-4)
        extrinsics.append(E)
    for a in range(VIEWS):
        for b in range(a):
            assert np.abs(extrinsics[a] - extrinsics[b]).max() > 1e-3, (a, b)


@pytest.mark.sim
def test_each_views_annotations_agree_with_its_own_images(multi):
    item = decode_parts(multi.parts)
    meta = item["meta"]
    objects = {o["instance_id"]: o for o in meta["objects"]}
    checked = 0
    for view in labelled_views(meta):
        images = item if view.name == "" else item["views"][view.name]
        seg, semantic, depth = images["seg"], images["semantic"], images["depth"]
        camera = view.camera
        # depth back-projected through this view's own K and E lands in the object's 3D box
        world, rows, cols = view_points(
            depth, camera["intrinsics"], camera["extrinsics_world_to_camera"],
            distortion=camera.get("distortion"),
        )  # fmt: skip
        for record in view.record["objects"]:
            mask = seg == record["instance_id"]
            assert record["visible_pixels"] == int(mask.sum())
            if not record["visible"]:
                continue
            ys, xs = np.nonzero(mask)
            assert record["bbox_xyxy"] == [xs.min(), ys.min(), xs.max(), ys.max()]
            assert (semantic[mask] == record["class_id"]).all()
            if record["role"] == "distractor":  # no 3D box in the metadata: not a target
                continue
            obj = objects[record["instance_id"]]
            box = np.asarray(obj["obb"]["pose_world"]["matrix"])
            points = world[seg[rows, cols] == record["instance_id"]]
            local = (points - box[:3, 3]) @ box[:3, :3]
            assert (np.abs(local) <= np.asarray(obj["obb"]["extents"]) / 2 + 0.004).all()
            E = np.asarray(camera["extrinsics_world_to_camera"])
            pose_camera = E @ np.asarray(obj["pose_world"]["matrix"])
            np.testing.assert_allclose(record["pose_camera"]["matrix"], pose_camera, atol=1e-5)
            checked += 1
    assert checked >= 2 * VIEWS


@pytest.mark.sim
def test_view_zero_keeps_the_one_view_bytes_and_samples_are_reproducible(multi):
    from datagen.families.grasp_tabletop.produce import produce

    single = produce(CONFIG.replace(render=RenderConfig(width=96, height=72, wrist_camera=True)), 5, 3)  # fmt: skip
    for name in (*IMAGE_PARTS, *(f"wrist.{p}" for p in IMAGE_PARTS)):
        assert single.parts[name] == multi.parts[name], name
    one, four = json.loads(single.parts["json"]), json.loads(multi.parts["json"])
    assert "extra_views" not in one["randomisation"]
    assert four["randomisation"] == one["randomisation"] | {"extra_views": four["randomisation"]["extra_views"]}  # fmt: skip
    produce(CONFIG, 5, 8)  # another sample in between: the same index gives the same bytes
    assert produce(CONFIG, 5, 3).parts == multi.parts


@pytest.mark.sim
def test_preview_draws_every_view_of_a_sample(multi):
    from datagen.tools.preview import camera_tile

    item = decode_parts(multi.parts) | {"key": "000000003"}
    tile = camera_tile(item)
    h, w = SMALL.height, SMALL.width
    assert tile.shape == (2 * h + h * (w // 4) // w, w, 3)  # colour, depth, a strip of 4 views
    single = {k: v for k, v in item.items() if k != "views"}
    assert camera_tile(single).shape == (2 * h, w, 3)


@pytest.mark.sim
def test_grasp_attempts_render_every_view_before_and_the_workspace_after():
    from datagen.families.grasp_attempts.produce import produce

    config = config_from_dict(
        {"scene": "grasp_attempts", "render": {"width": 64, "height": 48, "views": 2},
         "objects": {"count": [2, 3]}, "campaign": {"hold_time": 0.2}}
    )  # fmt: skip
    sample = produce(config, 1, 0)
    meta = json.loads(sample.parts["json"])
    assert sorted(meta["views"]) == ["view1", "workspace", "wrist"]
    prefixes = {n.rpartition(".")[0].rpartition(".")[0] for n in sample.parts if n.count(".") == 2}
    assert prefixes == {"view1", "wrist", "post"}
    assert meta["attempt"]["outcome"]["failure_mode"] != "error"


def test_extra_views_come_from_their_own_streams_around_the_nominal_target():
    config = BuildConfig(render=RenderConfig(views=3))
    tray = ((0.08, 0.0, 0.76), (0.2, 0.26))
    three = draw_scene(config, 0, 7, *tray)
    one = draw_scene(BuildConfig(), 0, 7, *tray)
    assert {k: v for k, v in three.items() if k != "extra_views"} == one
    assert list(three["extra_views"]) == ["view1", "view2"]
    assert three["extra_views"]["view2"] == draw_extra_view(
        sample_rng(0, 7, "camera.view2"), config.camera
    )
    still = CameraConfig(eye_jitter=0.0, target_jitter=0.0, orbit_deg=90.0)
    values = draw_extra_view(np.random.default_rng(3), still)
    assert abs(values.azimuth_deg) <= 90
    np.testing.assert_allclose(values.eye, orbited_eye(still, values.azimuth_deg), atol=1e-6)
    radius = np.hypot(*(np.subtract(still.eye, still.target)[:2]))
    assert np.hypot(*np.subtract(values.eye, still.target)[:2]) == pytest.approx(radius, abs=1e-5)
    np.testing.assert_allclose(orbited_eye(still, 0.0), still.eye)


@pytest.mark.parametrize(
    ("data", "expected"),
    [
        ({"render": {"views": 0}}, r"render.views: expected values in \[1, 16\]"),
        ({"render": {"views": 17}}, r"render.views: expected values in \[1, 16\]"),
        ({"render": {"views": 2.5}}, r"render.views: expected a whole number, got 2.5"),
        (
            {"scene": "navigation", "render": {"views": 2}},
            r"render.views: expected 1 for scene 'navigation'",
        ),
    ],
)
def test_bad_view_counts_are_config_errors(data, expected):
    with pytest.raises(ConfigError, match=expected):
        config_from_dict(data)


def test_camera_order_puts_the_workspace_first_and_views_by_number():
    names = ["wrist", "view10", "view2", "workspace", "view1"]
    assert sorted(names, key=camera_order) == ["workspace", "view1", "view2", "view10", "wrist"]


def test_the_loader_decodes_every_camera_of_a_sample_under_views():
    import cv2

    rgb = np.arange(4 * 6 * 3, dtype=np.uint8).reshape(4, 6, 3)
    seg = np.arange(24, dtype=np.uint16).reshape(4, 6)
    png = {name: cv2.imencode(".png", a)[1].tobytes() for name, a in (("rgb", rgb[:, :, ::-1]), ("seg", seg))}  # fmt: skip
    item = decode_parts({
        "rgb.png": png["rgb"], "view1.rgb.png": png["rgb"], "view1.seg.png": png["seg"],
        "wrist.seg.png": png["seg"], "labels.csv": b"a,b\n",
    })  # fmt: skip
    assert sorted(item["views"]) == ["view1", "wrist"]
    np.testing.assert_array_equal(item["views"]["view1"]["rgb"], rgb)  # RGB order, as the main one
    np.testing.assert_array_equal(item["views"]["view1"]["seg"], seg)
    np.testing.assert_array_equal(item["views"]["wrist"]["seg"], seg)
    assert item["labels.csv"] == b"a,b\n" and "views" not in decode_parts({"rgb.png": png["rgb"]})
    frames = decode_parts({"f0001.seg.png": png["seg"]})  # a sequence's frames stay frames
    assert "views" not in frames and len(frames["frames"]) == 1
