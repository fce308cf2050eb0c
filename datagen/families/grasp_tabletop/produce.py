"""Sample ``index`` of a build: build the scene, render every camera, annotate, encode.

``render_annotated`` is the simulator-side work (arrays + metadata); ``to_sample`` encodes it
into the named parts of a :class:`~datagen.sample.Sample`. The benchmark's plain render loop
calls the first alone.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import sapien

from datagen.config import BuildConfig
from datagen.config.robot import robot_spec
from datagen.families.grasp_tabletop.values import draw_values
from datagen.families.grasp_tabletop.world import GraspScene, build_scene
from datagen.geometry import pose_record
from datagen.sample import Sample, sample_key
from datagen.scene_values.checks import as_json
from datagen.scene_values.rounding import rounded
from datagen.seeding import sample_rng
from datagen.sensing.annotate import (
    LabelledObject,
    label_maps,
    object_view_records,
    object_world_record,
)
from datagen.sensing.camera_effects import draw_camera_effects
from datagen.sensing.camera_record import camera_record
from datagen.sensing.depth_sensor import draw_depth_sensor, specular
from datagen.sensing.encode import DEFAULT_PNG_LEVEL, View, encode_view, metadata_bytes
from datagen.sensing.path_tracing import path_tracing_of, view_is_path_traced
from datagen.sensing.render import capture, keep_renderer_alive
from datagen.sensing.robot_labels import part_instance_ids, part_view_records, robot_parts
from datagen.sensing.view_effects import apply_view_effects
from datagen.worlds.class_names import grasp_classes

METADATA_FORMAT = "datagen.sample/1"


@dataclass
class AnnotatedSample:
    index: int
    views: dict[str, View]
    metadata: dict[str, Any]


def _labelled_objects(scene: GraspScene, class_id: dict[str, int]) -> list[LabelledObject]:
    return [
        LabelledObject(
            instance_id=o.instance_id,
            class_name=o.class_name,
            class_id=class_id[o.class_name],
            entity_id=o.entity.per_scene_id,
            pose_world=np.asarray(o.entity.pose.to_transformation_matrix(), float),
            parts=[np.asarray(p.vertices, float) for p in o.geometry.parts],
            obb_transform=o.geometry.obb_transform,
            obb_extents=o.geometry.obb_extents,
            # a user's mesh or a smooth household shape is drawn as itself, not as its parts
            visual_triangles=(
                np.asarray(o.geometry.visual.triangles, float)
                if "asset" in o.spec["shape"] or not o.geometry.visual_is_parts
                else None
            ),
            role=o.role,
        )
        for o in [*scene.objects, *scene.distractors]
    ]


def _effects(config: BuildConfig, seed: int, index: int, attempt: int, camera: str):
    if not config.camera_effects.enabled:
        return None
    rng = sample_rng(seed, index, f"camera_effects.{camera}", attempt)
    return draw_camera_effects(rng, config.camera_effects)


def _sensor(config, seed: int, index: int, attempt: int, camera: str, shiny: list[int]):
    if not config.depth_sensor.enabled:
        return None
    rng = sample_rng(seed, index, f"depth_sensor.{camera}", attempt)
    return draw_depth_sensor(rng, config.depth_sensor, shiny)


def _specular_instances(scene: GraspScene, config: BuildConfig) -> list[int]:
    """Instance ids of the objects and distractors whose material a depth sensor cannot read."""
    materials = [
        *scene.params["materials"]["objects"],
        *(o.spec["material"] for o in scene.distractors),
    ]
    things = [*scene.objects, *scene.distractors]
    return [
        o.instance_id
        for o, material in zip(things, materials, strict=True)
        if specular(material, config.depth_sensor)
    ]


def render_annotated(
    config: BuildConfig, seed: int, index: int, attempt: int = 0
) -> AnnotatedSample:
    """The simulator-side steps of :func:`produce`: arrays and metadata, not yet encoded."""
    keep_renderer_alive()
    arm = robot_spec(config.robot)  # resolved once for the sample, passed down
    values = draw_values(config, seed, index, attempt, arm)
    scene = build_scene(config, seed, index, attempt, values, arm)
    return annotate_scene(scene, config, seed, index, attempt=attempt)


def annotate_scene(
    scene: GraspScene,
    config: BuildConfig,
    seed: int,
    index: int,
    cameras: tuple[str, ...] | None = None,
    attempt: int = 0,
) -> AnnotatedSample:
    """Renders every camera of a built (settled) scene (only those named in ``cameras`` if
    given) and annotates what they see; then each view's camera effects and sensor depth, drawn
    from the streams ``camera_effects.<camera>`` and ``depth_sensor.<camera>``."""
    scene.scene.update_render()
    classes = grasp_classes(config)
    class_id = {name: i for i, name in enumerate(classes)}
    objects = _labelled_objects(scene, class_id)
    stuff_class_ids = {entity_id: class_id[name] for entity_id, name in scene.stuff.items()}
    # the arm and the gripper: instances after the objects and distractors
    parts = robot_parts(scene.robot.get_links(), scene.stuff, class_id, len(objects) + 1)
    part_instances = part_instance_ids(parts)

    shiny = _specular_instances(scene, config)
    views, view_meta = {}, {}
    for name, camera in scene.cameras.items():
        if cameras is not None and name not in cameras:
            continue
        traced = view_is_path_traced(config.render, seed, index, name, attempt)
        frame = capture(camera, path_tracing_of(config.render) if traced else None)
        instance, semantic = label_maps(frame, objects, stuff_class_ids, part_instances)
        meta = {
            "camera": camera_record(
                camera.width,
                camera.height,
                camera.fovy,
                camera.near,
                camera.far,
                frame.intrinsics,
                {"extrinsics_world_to_camera": rounded(frame.extrinsics, 7)},
            ),
            "objects": object_view_records(frame, instance, objects, float(camera.near)),
            "robot_parts": part_view_records(frame, instance, parts, float(camera.near)),
        }
        if config.render.shader != "rasterized":  # which views of the build are path-traced
            meta["shader"] = "raytraced" if traced else "rasterized"
        views[name], view_meta[name] = apply_view_effects(
            View(frame.rgb, frame.depth, instance, semantic),
            frame.intrinsics,
            frame.extrinsics,
            meta,
            objects,
            _effects(config, seed, index, attempt, name),
            _sensor(config, seed, index, attempt, name, shiny),
            config.camera_effects.keep_clean,
            parts,
        )

    objects_meta = []
    targets = objects[: len(scene.objects)]  # the distractors follow, in randomisation only
    for obj, record in zip(scene.objects, map(object_world_record, targets), strict=True):
        spec = obj.spec
        body = obj.entity.find_component_by_type(sapien.physx.PhysxRigidDynamicComponent)
        objects_meta.append(
            record
            | {
                "shape": spec["shape"],
                "density": spec["density"],
                "mass": round(float(body.mass), 7),
                "friction": spec["friction"],
                "restitution": spec["restitution"],
            }
        )
    metadata = {
        "format": METADATA_FORMAT,
        "key": sample_key(index),
        "index": index,
        "seed": seed,
        "scene": config.scene,
        "classes": list(classes),
        "objects": objects_meta,
        "views": view_meta,
        "robot": {
            "name": scene.spec.name,
            "description": scene.spec.description_path,
            "base_pose": pose_record(
                np.asarray(scene.robot.root_pose.to_transformation_matrix(), float)
            ),
            "joint_names": [joint.name for joint in scene.robot.get_active_joints()],
            "qpos": np.round(scene.robot.get_qpos(), 6).tolist(),  # radians or metres
        }
        # a small arm's table, tray and objects, scaled (absent: 1, the Panda's workspace)
        | ({"workspace_scale": scene.workspace.scale} if scene.workspace.scale != 1.0 else {})
        | (
            {"object_scale": scene.workspace.object_scale}
            if scene.workspace.object_scale != 1.0
            else {}
        ),
        "randomisation": as_json(scene.params),
    }
    return AnnotatedSample(index, views, metadata)


def to_sample(annotated: AnnotatedSample, png_level: int = DEFAULT_PNG_LEVEL) -> Sample:
    """Parts: ``rgb.png depth.png seg.png semantic.png`` for the workspace camera, the same
    names prefixed ``<camera>.`` for any other camera (``view1.rgb.png``, ``wrist.rgb.png``),
    and ``json`` for the metadata."""
    parts: dict[str, bytes] = {}
    for name, view in annotated.views.items():
        parts |= encode_view(view, "" if name == "workspace" else f"{name}.", png_level)
    parts["json"] = metadata_bytes(annotated.metadata)
    return Sample(annotated.index, parts)


def produce(config: BuildConfig, seed: int, index: int, attempt: int = 0) -> Sample:
    """Sample ``index``: one settled tray scene, every camera rendered and annotated, in named
    steps as a ManiSkill task names its hooks: draw every value (:func:`draw_values`), build
    and settle the world (:func:`build_scene`), render and label each camera
    (:func:`annotate_scene`), record the sample (:func:`to_sample`). ``attempt`` > 0 re-draws
    every random value from fresh streams (a retry after a failure)."""
    return to_sample(render_annotated(config, seed, index, attempt), config.output.png_level)
