"""Camera effects and lens distortion: the image effects alone (pure functions), then a tiny
real render whose annotations must stay consistent with the distorted image."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from datagen.config import BuildConfig
from datagen.config.appearance import CameraEffectsConfig, DepthSensorConfig
from datagen.config.sections import RenderConfig
from datagen.dataset.pointcloud import view_points
from datagen.sensing.camera_effects import (
    LINEAR_FROM_BYTE,
    apply_camera_effects,
    disc_kernel,
    draw_camera_effects,
    motion_kernel,
)
from datagen.sensing.lens import distort, lens_for, project_distorted

K = np.array([[110.0, 0, 64.0], [0, 110.0, 48.0], [0, 0, 1]])
STRONG = [-0.3, 0.05, 0.002, -0.002, 0.0]  # barrel
GREY = np.full((96, 128, 3), 140, np.uint8)


def test_no_effect_and_zero_values_keep_the_image():
    rgb = np.random.default_rng(0).integers(0, 256, (96, 128, 3), dtype=np.uint8)
    np.testing.assert_array_equal(apply_camera_effects(rgb, {}), rgb)
    unchanged = {"exposure_ev": 0.0, "white_balance": [1.0, 1.0, 1.0], "gamma": 1.0}
    np.testing.assert_array_equal(apply_camera_effects(rgb, unchanged), rgb)


def test_probabilities_decide_which_effects_are_drawn():
    off = CameraEffectsConfig(**{f.name: 0.0 for f in dataclasses.fields(CameraEffectsConfig) if f.name.endswith("_probability")})  # fmt: skip
    assert draw_camera_effects(np.random.default_rng(1), off) == {}
    on = CameraEffectsConfig(**{f.name: 1.0 for f in dataclasses.fields(CameraEffectsConfig) if f.name.endswith("_probability")})  # fmt: skip
    effects = draw_camera_effects(np.random.default_rng(1), on)
    assert set(effects) == {
        "exposure_ev", "white_balance", "gamma", "motion_blur", "defocus_blur", "noise",
        "vignetting", "jpeg_quality", "distortion",
    }  # fmt: skip
    # another effect's probability does not move the values of the others
    fewer = dataclasses.replace(on, gamma_probability=0.0)
    assert draw_camera_effects(np.random.default_rng(1), fewer) == {
        k: v for k, v in effects.items() if k != "gamma"
    }
    assert json.loads(json.dumps(effects)) == effects  # plain JSON values


def test_exposure_and_white_balance_scale_linear_intensity():
    out = apply_camera_effects(GREY, {"exposure_ev": 1.0})
    assert LINEAR_FROM_BYTE[out[0, 0, 0]] == pytest.approx(2 * LINEAR_FROM_BYTE[140], rel=0.01)
    red, green, blue = apply_camera_effects(GREY, {"white_balance": [1.2, 1.0, 0.8]})[0, 0]
    assert green == 140
    assert LINEAR_FROM_BYTE[red] / LINEAR_FROM_BYTE[140] == pytest.approx(1.2, rel=0.01)
    assert LINEAR_FROM_BYTE[blue] / LINEAR_FROM_BYTE[140] == pytest.approx(0.8, rel=0.01)


def test_noise_matches_its_model_and_replays_from_its_seed():
    noise = {"shot": 0.002, "read": 0.01, "seed": 12}
    out = apply_camera_effects(GREY, {"noise": noise})
    np.testing.assert_array_equal(out, apply_camera_effects(GREY, {"noise": noise}))
    assert not np.array_equal(out, apply_camera_effects(GREY, {"noise": noise | {"seed": 13}}))
    intensity = LINEAR_FROM_BYTE[140]
    measured = LINEAR_FROM_BYTE[out].std()
    assert measured == pytest.approx(np.sqrt(0.002 * intensity + 0.01**2), rel=0.1)


def test_blur_kernels_and_vignetting():
    line = motion_kernel(7.0, 0.0)
    assert line.sum() == pytest.approx(1.0) and np.count_nonzero(line.sum(axis=1)) == 1
    upright = motion_kernel(7.0, 90.0)
    assert np.count_nonzero(upright.sum(axis=0)) == 1
    disc = disc_kernel(2.0)
    assert disc.sum() == pytest.approx(1.0) and disc[2, 2] > disc[0, 0]
    edges = np.zeros((96, 128, 3), np.uint8)
    edges[:, 64:] = 255
    blurred = apply_camera_effects(edges, {"motion_blur": {"length_px": 9, "angle_deg": 0}})
    assert 0 < blurred[50, 62, 0] < 255 and blurred[50, 10, 0] == 0
    dark = apply_camera_effects(GREY, {"vignetting": 0.4})
    assert abs(int(dark[48, 64, 0]) - 140) <= 1  # the centre keeps its intensity
    ratio = LINEAR_FROM_BYTE[dark[0, 0, 0]] / LINEAR_FROM_BYTE[140]
    assert ratio == pytest.approx(0.6, abs=0.03)


def test_jpeg_round_trip_changes_detail_but_not_the_picture():
    rgb = np.random.default_rng(0).integers(0, 256, (96, 128, 3), dtype=np.uint8)
    out = apply_camera_effects(rgb, {"jpeg_quality": 30})
    assert not np.array_equal(out, rgb)
    flat = apply_camera_effects(GREY, {"jpeg_quality": 30})
    assert np.abs(flat.astype(int) - 140).max() <= 2


def test_distortion_map_agrees_with_projecting_points():
    lens = lens_for(K, STRONG, 128, 96)
    assert lens.zoom > 1.0  # barrel distortion: zoomed so no corner is empty
    assert (lens.map_x >= -0.5).all() and (lens.map_x <= 127.5).all()
    rng = np.random.default_rng(0)
    points = np.column_stack([rng.uniform(-0.5, 0.5, (200, 2)), np.ones(200)]) * rng.uniform(0.5, 2, (200, 1))  # fmt: skip
    distorted = project_distorted(points, lens)
    inside = (distorted > 1).all(1) & (distorted[:, 0] < 127) & (distorted[:, 1] < 95)
    pinhole = points @ K.T
    pinhole = pinhole[:, :2] / pinhole[:, 2:]
    # the render pixel the distorted pixel samples is where the pinhole camera saw the point
    cols, rows = distorted[inside].T - 0.5
    sampled_x = lens.map_x[np.rint(rows).astype(int), np.rint(cols).astype(int)]
    sampled_y = lens.map_y[np.rint(rows).astype(int), np.rint(cols).astype(int)]
    np.testing.assert_allclose(sampled_x + 0.5, pinhole[inside, 0], atol=1.0)
    np.testing.assert_allclose(sampled_y + 0.5, pinhole[inside, 1], atol=1.0)


def test_point_cloud_of_a_distorted_plane_stays_metric():
    cols = np.mgrid[0:96, 0:128][1]
    # a tilted plane z = 1 + 0.3 x in the camera frame, rendered by the pinhole camera
    x_over_z = (cols + 0.5 - K[0, 2]) / K[0, 0]
    depth = np.rint(1000 / (1 - 0.3 * x_over_z)).astype(np.uint16)
    lens = lens_for(K, STRONG, 128, 96)
    warped = distort(depth, lens, nearest=True)
    extrinsics = np.eye(4)
    points, _, _ = view_points(warped, lens.intrinsics, extrinsics, distortion=STRONG)
    residual = points[:, 2] - (1 + 0.3 * points[:, 0])
    assert np.abs(residual).max() < 0.004  # nearest-neighbour sampling: half a render pixel
    naive, _, _ = view_points(warped, lens.intrinsics, extrinsics)
    assert np.abs(naive[:, 2] - (1 + 0.3 * naive[:, 0])).max() > 0.02  # without undistortion


# --- a real render: annotations under distortion ----------------------------------------------

_OFF = {f.name: 0.0 for f in dataclasses.fields(CameraEffectsConfig) if f.name.endswith("_probability")}  # fmt: skip
TINY = BuildConfig(render=RenderConfig(width=128, height=96, views=2))
CLEAN = dataclasses.replace(
    TINY,
    camera_effects=CameraEffectsConfig(enabled=False),
    depth_sensor=DepthSensorConfig(enabled=False),
)
DISTORTED = dataclasses.replace(
    TINY,
    camera_effects=CameraEffectsConfig(
        **_OFF | {"distortion_probability": 1.0, "noise_probability": 1.0},
        keep_clean=True,
        distortion_k1=(STRONG[0], STRONG[0]),
        distortion_k2=(STRONG[1], STRONG[1]),
        distortion_k3=(0.0, 0.0),
    ),
)


@pytest.fixture(scope="module")
def renders():
    from datagen.families.grasp_tabletop.produce import render_annotated

    return render_annotated(CLEAN, 5, 2), render_annotated(DISTORTED, 5, 2)


@pytest.mark.sim
def test_switched_off_the_sample_has_only_todays_parts_and_keys(renders):
    from datagen.families.grasp_tabletop.produce import to_sample

    clean, _ = renders
    parts = set(to_sample(clean).parts)
    cameras = ("", "view1.", "wrist.")
    kinds = ("rgb", "depth", "seg", "semantic")
    assert parts == {f"{p}{n}.png" for p in cameras for n in kinds} | {"json"}
    for view in clean.metadata["views"].values():
        assert not {"camera_effects", "depth_sensor"} & set(view)
        assert "distortion" not in view["camera"]


@pytest.mark.sim
def test_every_pixel_annotation_is_distorted_with_the_colour(renders):
    clean, distorted = renders
    for name, view in distorted.views.items():
        camera = distorted.metadata["views"][name]["camera"]
        clean_camera = clean.metadata["views"][name]["camera"]
        assert camera["distortion_model"] == "opencv" and camera["render_intrinsics"] == clean_camera["intrinsics"]  # fmt: skip
        lens = lens_for(np.asarray(clean_camera["intrinsics"]), camera["distortion"], 128, 96)
        np.testing.assert_allclose(camera["intrinsics"], lens.intrinsics, atol=1e-6)
        before = clean.views[name]
        np.testing.assert_array_equal(view.instance, distort(before.instance, lens, nearest=True))
        np.testing.assert_array_equal(view.semantic, distort(before.semantic, lens, nearest=True))
        np.testing.assert_array_equal(view.depth, distort(before.depth, lens, nearest=True))
        np.testing.assert_array_equal(view.rgb_clean, distort(before.rgb, lens, nearest=False))
        # the stored values make the stored image again from the clean one
        effects = distorted.metadata["views"][name]["camera_effects"]
        np.testing.assert_array_equal(view.rgb, apply_camera_effects(view.rgb_clean, effects))


@pytest.mark.sim
def test_points_boxes_and_corners_land_where_the_distorted_image_shows_them(renders):
    import cv2

    clean, distorted = renders
    for name, view in distorted.views.items():
        meta, clean_meta = distorted.metadata["views"][name], clean.metadata["views"][name]
        K_d, D = np.asarray(meta["camera"]["intrinsics"]), np.asarray(meta["camera"]["distortion"])
        E = np.asarray(meta["camera"]["extrinsics_world_to_camera"])
        before = clean.views[name]
        checked = 0
        for record, clean_record in zip(meta["objects"], clean_meta["objects"], strict=True):
            ids = view.instance == record["instance_id"]
            if ids.any():
                rows, cols = np.nonzero(ids)
                assert record["bbox_xyxy"] == [cols.min(), rows.min(), cols.max(), rows.max()]
            assert record["visible_pixels"] == int(ids.sum())
            # corners: from the stored calibration alone
            obb = next(o for o in distorted.metadata["objects"] if o["instance_id"] == record["instance_id"]) if record["role"] == "target" else None  # fmt: skip
            if obb is not None and np.all(np.asarray(record["pose_camera"]["matrix"])[2, 3] > 0.1):
                pose = E @ np.asarray(obb["obb"]["pose_world"]["matrix"])
                corners = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)]) * obb["obb"]["extents"]  # fmt: skip
                camera_points = corners @ pose[:3, :3].T + pose[:3, 3]
                if (camera_points[:, 2] > 0.05).all():
                    uv, _ = cv2.projectPoints(camera_points, np.zeros(3), np.zeros(3), K_d, D)
                    np.testing.assert_allclose(
                        record["obb_corners_px"], uv.reshape(-1, 2), atol=2e-3
                    )
            # the object's surface points, seen by the pinhole render, projected with distortion
            mask = before.instance == clean_record["instance_id"]
            if mask.sum() < 30:
                continue
            points, _, _ = view_points(np.where(mask, before.depth, 0), clean_meta["camera"]["intrinsics"], np.eye(4))  # fmt: skip
            uv = project_distorted(points, lens_for(np.asarray(clean_meta["camera"]["intrinsics"]), D, 128, 96))  # fmt: skip
            cols, rows = np.floor(uv).astype(int).T
            inside = (cols >= 0) & (cols < 128) & (rows >= 0) & (rows < 96)
            hits = view.instance[rows[inside], cols[inside]] == record["instance_id"]
            assert hits.mean() > 0.9, (name, record["instance_id"], hits.mean())
            checked += 1
        assert checked > 0


@pytest.mark.sim
def test_point_clouds_of_the_distorted_and_clean_samples_agree(renders):
    from scipy.spatial import cKDTree

    from datagen.dataset.pointcloud import sample_point_cloud
    from datagen.families.grasp_tabletop.produce import to_sample

    clean, distorted = renders
    a = sample_point_cloud(to_sample(clean).parts, clean.metadata, fuse=False)
    b = sample_point_cloud(to_sample(distorted).parts, distorted.metadata, fuse=False)
    for before, after, view in zip(a, b, clean.metadata["views"].values(), strict=True):
        distance, nearest = cKDTree(before["positions"]).query(after["positions"])
        # in units of the clean cloud's point spacing there (one render pixel at that depth)
        eye = np.linalg.inv(np.asarray(view["camera"]["extrinsics_world_to_camera"]))[:3, 3]
        spacing = np.linalg.norm(after["positions"] - eye, axis=1) / view["camera"]["intrinsics"][0][0]  # fmt: skip
        pixels = distance / spacing
        assert np.median(pixels) < 0.5 and np.quantile(pixels, 0.95) < 1.0, np.quantile(pixels, [0.5, 0.95])  # fmt: skip
        same_label = before["instance"][nearest] == after["instance"]
        assert same_label.mean() > 0.97


@pytest.mark.sim
def test_loader_and_hdf5_export_carry_the_new_images(renders, tmp_path, make_dataset):
    import h5py

    from datagen.dataset.loader import load, read_manifest
    from datagen.exports.hdf5 import export
    from datagen.families.grasp_tabletop.produce import to_sample

    _, distorted = renders
    root = make_dataset(tmp_path / "ds", [to_sample(distorted)])
    item = load(root)[0]
    views = distorted.views
    np.testing.assert_array_equal(item["depth_sensor"], views["workspace"].depth_sensor)
    np.testing.assert_array_equal(item["rgb_clean"], views["workspace"].rgb_clean)
    np.testing.assert_array_equal(item["views"]["view1"]["depth_sensor"], views["view1"].depth_sensor)  # fmt: skip
    np.testing.assert_array_equal(item["views"]["view1"]["rgb_clean"], views["view1"].rgb_clean)
    assert (views["workspace"].depth_sensor == 0).any()  # the sensor misses some pixels
    export(load(root), read_manifest(root), tmp_path / "episodes.h5")
    with h5py.File(tmp_path / "episodes.h5") as f:
        group = f[f"samples/{item['key']}"]
        np.testing.assert_array_equal(group["depth_sensor"][()], views["workspace"].depth_sensor)
        np.testing.assert_array_equal(group["view1/rgb_clean"][()], views["view1"].rgb_clean)


@pytest.mark.sim
def test_the_stored_image_is_made_again_from_the_render_and_the_metadata(renders):
    from datagen.sensing.view_effects import stored_colour

    clean, distorted = renders
    for name, view in distorted.views.items():
        again = stored_colour(clean.views[name].rgb, distorted.metadata["views"][name])
        np.testing.assert_array_equal(again, view.rgb)


@pytest.mark.sim
def test_usd_stage_carries_each_views_lens_effects_and_sensor_values(renders, tmp_path):
    from datagen.exports.usd_stage import scene_stage

    _, distorted = renders
    stage = scene_stage(distorted.metadata, tmp_path)
    for name, view in distorted.metadata["views"].items():
        prim = stage.GetPrimAtPath(f"/World/Cameras/{name}")
        for part in ("camera_effects", "depth_sensor"):
            assert json.loads(prim.GetCustomDataByKey(f"datagen:{part}")) == view[part]
        assert json.loads(prim.GetCustomDataByKey("datagen:distortion")) == view["camera"]["distortion"]  # fmt: skip
        assert json.loads(prim.GetCustomDataByKey("datagen:render_intrinsics")) == view["camera"]["render_intrinsics"]  # fmt: skip
