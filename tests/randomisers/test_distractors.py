"""Distractors (datagen/randomisers/distractors.py): placed where the config says, drawn from their
own stream, rendered and labelled with class ``distractor`` and role ``distractor`` in a real
SAPIEN scene, never changing the targets' physics, and never chosen as a grasp target."""

from __future__ import annotations

import dataclasses
import json
import re

import numpy as np
import pytest

from datagen.assets.shapes import build_geometry
from datagen.assets.tabletop_layout import (
    TABLE_HALF,
    TABLE_TOP,
    TRAY_CENTRE,
    TRAY_INNER_HALF,
    TRAY_WALL,
)
from datagen.config import BuildConfig
from datagen.config.appearance import DistractorsConfig
from datagen.config.sections import CameraConfig, MaterialsConfig, ObjectsConfig, RenderConfig
from datagen.families.grasp_tabletop.values import draw_scene
from datagen.randomisers.camera import draw_camera
from datagen.randomisers.distractors import AIR_FRACTION, draw_distractors
from datagen.scene_values.bundles import distractor_values
from datagen.scene_values.checks import as_json
from datagen.seeding import sample_rng

MANY = DistractorsConfig(on_table=(3, 3), in_air=(2, 2), background=(3, 3))


def _sampled(seed: int, cfg: DistractorsConfig = MANY) -> tuple[dict, list[dict]]:
    camera = draw_camera(np.random.default_rng(seed), CameraConfig())
    return camera, draw_distractors(np.random.default_rng(seed), cfg, MaterialsConfig(), camera)


def _lowest_z(spec: dict) -> float:
    """Lowest point of the distractor's mesh in the world (its pose is yaw-only or any)."""
    from transforms3d.quaternions import quat2mat

    vertices = np.asarray(build_geometry(spec["shape"]).visual.vertices)
    rotation = quat2mat(spec["pose"]["quat_wxyz"])
    return float((vertices @ rotation.T)[:, 2].min() + spec["pose"]["position"][2])


def test_each_placement_puts_its_distractors_where_it_says():
    counts = {"table": 0, "air": 0, "background": 0}
    for seed in range(20):
        camera, distractors = _sampled(seed)
        stored = as_json(distractors)  # JSON values, materials typed
        assert distractor_values(json.loads(json.dumps(stored)), "distractors") == distractors
        for spec in distractors:
            counts[spec["placement"]] += 1
            x, y, z = spec["pose"]["position"]
            half_size = float(np.max(build_geometry(spec["shape"]).obb_extents)) / 2
            if spec["placement"] == "table":
                assert _lowest_z(spec) == pytest.approx(TABLE_TOP, abs=1e-5)  # stands on it
                assert abs(x) < TABLE_HALF[0] and abs(y) < TABLE_HALF[1]
                outside_x = abs(x - TRAY_CENTRE[0]) > TRAY_INNER_HALF[0] + TRAY_WALL[0]
                outside_y = abs(y - TRAY_CENTRE[1]) > TRAY_INNER_HALF[1] + TRAY_WALL[0]
                assert outside_x or outside_y
            elif spec["placement"] == "background":
                assert _lowest_z(spec) == pytest.approx(0.0, abs=1e-5)  # on the floor
                assert abs(x) > TABLE_HALF[0] or abs(y) > TABLE_HALF[1]
            else:
                eye, target = np.asarray(camera.eye), np.asarray(camera.target)
                along = np.dot(np.subtract([x, y, z], eye), target - eye) / np.linalg.norm(
                    target - eye
                )
                fraction = along / np.linalg.norm(target - eye)
                assert AIR_FRACTION[0] - 0.01 <= fraction <= AIR_FRACTION[1] + 0.01
                assert along - half_size > RenderConfig().near  # clear of the near plane
                assert _lowest_z(spec) > TABLE_TOP  # floats above the table
    assert counts["table"] >= 57 and counts["air"] == 40  # air ones always find a place
    assert counts["background"] > 30  # the default view sees floor beyond the table


def test_sizes_follow_the_config():
    for seed in range(10):
        for spec in _sampled(seed)[1]:
            extent = float(np.max(build_geometry(spec["shape"]).obb_extents))
            lo, hi = MANY.background_size if spec["placement"] == "background" else MANY.size
            assert 0.5 * lo <= extent <= 1.05 * hi


def test_distractors_have_their_own_stream_and_off_leaves_the_scene_as_it_was():
    on = BuildConfig()
    off = dataclasses.replace(on, distractors=DistractorsConfig(enabled=False))
    for index in range(5):
        with_distractors = draw_scene(on, 7, index, TRAY_CENTRE, TRAY_INNER_HALF)
        without = draw_scene(off, 7, index, TRAY_CENTRE, TRAY_INNER_HALF)
        assert "distractors" not in without
        assert with_distractors.pop("distractors") is not None
        assert with_distractors == without
    again = draw_scene(on, 7, 0, TRAY_CENTRE, TRAY_INNER_HALF)
    assert again["distractors"] == draw_scene(on, 7, 0, TRAY_CENTRE, TRAY_INNER_HALF)["distractors"]
    rng = sample_rng(7, 0, "distractors")
    room = again["background"]["room"]  # background distractors stand inside it
    placed = [d for d in again["distractors"] if d["placement"] != "flying"]  # flying: own stream
    assert placed == draw_distractors(rng, on.distractors, on.materials, again["camera"], room)


# --- real scenes ---

TINY = BuildConfig(
    objects=ObjectsConfig(count=(3, 3)),
    render=RenderConfig(width=96, height=72),
    distractors=DistractorsConfig(on_table=(2, 2), in_air=(1, 1), background=(2, 2)),
)


@pytest.fixture(scope="module")
def annotated():
    from datagen.families.grasp_tabletop.produce import render_annotated

    return render_annotated(TINY, 11, 0)


@pytest.mark.sim
def test_distractors_are_rendered_and_labelled_with_their_class_and_role(annotated):
    meta = annotated.metadata
    classes = meta["classes"]
    distractor_id = classes.index("distractor")
    # appended: earlier class ids never move
    assert classes[-3:] == ["distractor", "wall", "gripper"]
    records = meta["views"]["workspace"]["objects"]
    targets = [r for r in records if r["role"] == "target"]
    distractors = [r for r in records if r["role"] == "distractor"]
    assert len(targets) == len(meta["objects"]) == 3
    assert len(distractors) == len(meta["randomisation"]["distractors"]) >= 3
    assert all(r["class"] == "distractor" and r["class_id"] == distractor_id for r in distractors)
    assert all(r["class"] != "distractor" for r in targets)
    # instance ids after the targets', and the maps agree with the records
    assert sorted(r["instance_id"] for r in distractors) == list(range(4, 4 + len(distractors)))
    view = annotated.views["workspace"]
    seen = [r for r in distractors if r["visible"]]
    assert seen, "the air distractor at least is in view"
    for record in seen:
        mask = view.instance == record["instance_id"]
        assert mask.sum() == record["visible_pixels"]
        assert (view.semantic[mask] == distractor_id).all()
        x0, y0, x1, y1 = record["bbox_xyxy"]
        rows, cols = np.nonzero(mask)
        assert (x0, y0, x1, y1) == (cols.min(), rows.min(), cols.max(), rows.max())
    air = next(
        r
        for r, spec in zip(distractors, meta["randomisation"]["distractors"], strict=True)
        if spec["placement"] == "air"
    )
    assert air["visible"] and air["visible_fraction"] > 0.5
    assert air["visible_pixels"] < 0.25 * view.instance.size  # off-centre, small: not a wall


@pytest.mark.sim
def test_distractors_never_move_a_target():
    """Static and visual only: the settled targets are the same to the bit without them."""
    from datagen.families.grasp_tabletop.world import build_scene

    off = dataclasses.replace(TINY, distractors=DistractorsConfig(enabled=False))
    with_distractors, without = build_scene(TINY, 11, 0), build_scene(off, 11, 0)
    assert len(with_distractors.distractors) >= 3 and not without.distractors
    for a, b in zip(with_distractors.objects, without.objects, strict=True):
        assert np.array_equal(a.entity.pose.p, b.entity.pose.p)
        assert np.array_equal(a.entity.pose.q, b.entity.pose.q)


@pytest.mark.sim
def test_a_grasp_campaign_never_targets_a_distractor():
    from datagen.families.grasp_attempts.produce import choose_target
    from datagen.families.grasp_tabletop.produce import annotate_scene
    from datagen.families.grasp_tabletop.world import build_scene

    # table distractors only, moved into the tray: visible there, yet never a target
    config = dataclasses.replace(
        TINY,
        distractors=DistractorsConfig(
            on_table=(3, 3), in_air=(0, 0), background=(0, 0), flying=(0, 0)
        ),
    )
    params = draw_scene(config, 11, 0, TRAY_CENTRE, TRAY_INNER_HALF)
    scene = build_scene(config, 11, 0)
    for k, distractor in enumerate(scene.distractors):
        distractor.entity.set_pose(
            type(distractor.entity.pose)([TRAY_CENTRE[0] + 0.1 * (k - 1), -0.15, TABLE_TOP + 0.05])
        )
    assert len(params["distractors"]) == 3
    view = annotate_scene(scene, config, 11, 0).metadata["views"]["workspace"]
    assert any(r["role"] == "distractor" and r["visible"] for r in view["objects"])
    targets = {choose_target(np.random.default_rng(k), scene, view).role for k in range(50)}
    assert targets == {"target"}


@pytest.mark.sim
def test_a_grasp_attempt_with_household_shapes_and_distractors_targets_a_target():
    from datagen.config.sections import HOUSEHOLD_FAMILIES, CampaignConfig
    from datagen.families.grasp_attempts.produce import produce

    config = dataclasses.replace(
        TINY,
        scene="grasp_attempts",
        objects=ObjectsConfig(count=(3, 3), families=HOUSEHOLD_FAMILIES),
        campaign=CampaignConfig(hold_time=0.5),
    )
    meta = json.loads(produce(config, 5, 1).parts["json"])
    target = meta["attempt"]["target"]
    assert target["class"] in HOUSEHOLD_FAMILIES
    assert target["instance_id"] in {o["instance_id"] for o in meta["objects"]}
    assert meta["attempt"]["outcome"]["failure_mode"] != "no_candidate"  # it was grasped at
    roles = {r["instance_id"]: r["role"] for r in meta["views"]["workspace"]["objects"]}
    assert roles[target["instance_id"]] == "target" and "distractor" in roles.values()


@pytest.mark.sim
def test_usd_export_and_a_rebuild_from_the_metadata_carry_the_distractors(annotated, tmp_path):
    from pxr import Usd, UsdGeom

    from datagen.exports.usd_stage import validation_errors, write_usd
    from datagen.families.grasp_tabletop.produce import annotate_scene
    from datagen.families.grasp_tabletop.world import construct_scene
    from datagen.scene_values.bundles import tabletop_values

    meta = annotated.metadata
    specs = meta["randomisation"]["distractors"]
    stage = Usd.Stage.Open(str(write_usd(meta, tmp_path / "sample.usda")))
    assert [e for e in validation_errors(stage) if "istractor" in e] == []
    for k, spec in enumerate(specs, start=1):
        prim = stage.GetPrimAtPath(f"/World/Distractors/distractor_{k}")
        assert prim.GetCustomDataByKey("datagen:placement") == spec["placement"]
        pose = np.asarray(UsdGeom.Xformable(prim).ComputeLocalToWorldTransform(0)).T
        np.testing.assert_allclose(pose[:3, 3], spec["pose"]["position"], atol=1e-9)
        points = np.asarray(UsdGeom.Mesh(prim.GetChild("visual")).GetPointsAttr().Get())
        np.testing.assert_allclose(points, build_geometry(spec["shape"]).visual.vertices, atol=1e-6)
    # as replay does: the stored values with the settled poses give the same label maps
    poses = [
        {"position": o["pose_world"]["position"], "quat_wxyz": o["pose_world"]["quat_wxyz"]}
        for o in meta["objects"]
    ]
    scene = construct_scene(TINY, tabletop_values(meta["randomisation"]) | {"drop_poses": poses})
    scene.robot.set_qpos(np.asarray(meta["robot"]["qpos"], np.float32))
    again = annotate_scene(scene, TINY, 11, 0)
    original = annotated.views["workspace"]
    distractor_id = meta["classes"].index("distractor")
    replayed = again.views["workspace"]
    assert (
        (replayed.semantic == distractor_id) == (original.semantic == distractor_id)
    ).mean() > 0.999
    assert [r["role"] for r in again.metadata["views"]["workspace"]["objects"]] == [
        r["role"] for r in meta["views"]["workspace"]["objects"]
    ]


@pytest.mark.parametrize(
    ("section", "expected"),
    [
        ({"in_air": [0, 9]}, "distractors.in_air: expected values in [0, 4]"),
        ({"size": [0.2, 0.1]}, "distractors.size"),
        ({"on_table": 2}, "distractors.on_table: expected"),
        ({"count": [1, 2]}, "unknown key(s) distractors.count"),
    ],
)
def test_a_wrong_distractors_key_is_named(section, expected):
    from datagen.config import config_from_dict
    from datagen.errors import ConfigError

    with pytest.raises(ConfigError, match=re.escape(expected)):
        config_from_dict({"distractors": section}, source="my.yaml")
