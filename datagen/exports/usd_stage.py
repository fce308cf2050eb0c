"""A grasp sample's randomised scene as a USD stage (usd-core), from its stored metadata alone.

``/World`` (z up, metres; ``customData.datagen``: key, seed, scene, and every randomised value as
JSON) holds ``Looks/`` (UsdPreviewSurface materials with the sampled colour, roughness and
metallic; a textured look reads its tile from ``textures/<key>/<look>.png`` beside the stage:
:mod:`datagen.exports.usd_looks`), ``Floor``, ``Table/top``, ``Table/leg_<k>``, ``Tray`` (the
static geometry the simulator builds, from the one description
:func:`datagen.assets.tabletop_layout.static_parts`: an Xform per part, a Mesh ``part_<j>`` per
box), ``Objects/object_<k>`` (an Xform at the object's world pose, one Mesh per convex part,
class and physical values in customData), ``Background/`` (backdrop walls, ceiling and room lights, when the sample has a
room), ``Distractors/distractor_<k>`` (when it has distractors: its visual Mesh at its static
pose), ``Robot`` (an Xform at
the base pose, the articulation: a link Xform per URDF link at the sample's joint positions with
its decimated visual meshes, UsdPhysics joints; description file and joint positions in
customData: :mod:`datagen.exports.usd_robot`), ``Lights/`` (a DomeLight
for the ambient level, a DistantLight for the key light, SphereLights shaped as spots) and
``Cameras/<name>`` (one Camera per view: workspace, view1, ... of ``render.views``, wrist; its
transform and apertures reproduce the stored K and extrinsics, the exact matrices are also in
customData).
"""

from __future__ import annotations

import json
from functools import singledispatch
from pathlib import Path
from typing import Any

import numpy as np
import trimesh
from pxr import Gf, Usd, UsdGeom, UsdLux, UsdValidation

from datagen.assets.backdrop import wall_boxes
from datagen.assets.shapes import build_geometry
from datagen.assets.tabletop_layout import DEFAULT_WORKSPACE, Workspace, static_parts
from datagen.exports import usd_looks, usd_robot
from datagen.scene_values.bundles import tabletop_values
from datagen.scene_values.lighting import Lighting
from datagen.scene_values.material import Material

APERTURE_PER_PIXEL = 0.01  # USD camera aperture units per image pixel (only ratios matter)
_CV_TO_USD_CAMERA = np.diag(
    [1.0, -1.0, -1.0, 1.0]
)  # OpenCV (x right, y down, z fwd) -> USD (-z fwd, y up)


def _matrix(m: np.ndarray) -> Gf.Matrix4d:
    return Gf.Matrix4d(np.asarray(m, float).T.tolist())  # USD uses row vectors


def _xform(stage, path: str, pose: np.ndarray | None = None) -> UsdGeom.Xform:
    xform = UsdGeom.Xform.Define(stage, path)
    if pose is not None:
        xform.AddTransformOp().Set(_matrix(pose))
    return xform


@singledispatch
def add_to_stage(value: object, stage: Usd.Stage, **options: Any) -> None:
    """Makes the scene value ``value`` prims of ``stage``, chosen by the value's type; a type
    without a USD realiser is an error (the SAPIEN side: ``datagen.worlds.realise.realise``)."""
    raise TypeError(f"no USD realiser for scene values of type {type(value).__name__}")


@add_to_stage.register
def _lights(lighting: Lighting, stage: Usd.Stage) -> None:
    dome = UsdLux.DomeLight.Define(stage, "/World/Lights/ambient")
    dome.CreateIntensityAttr(float(lighting.ambient))
    for i, light in enumerate(lighting.lights):
        colour = Gf.Vec3f(*map(float, light.colour))
        pose = np.eye(4)
        if light.direction is not None:
            direction = np.asarray(light.direction, float)
            # a rotation taking the light's -z axis onto its direction of travel
            z = -direction / np.linalg.norm(direction)
            x = np.cross([0.0, 1.0, 0.0] if abs(z[1]) < 0.9 else [1.0, 0.0, 0.0], z)
            x /= np.linalg.norm(x)
            pose[:3, :3] = np.stack([x, np.cross(z, x), z], axis=1)
        if light.kind == "directional":
            usd_light = UsdLux.DistantLight.Define(stage, f"/World/Lights/key_{i}")
        else:
            pose[:3, 3] = light.position
            usd_light = UsdLux.SphereLight.Define(stage, f"/World/Lights/{light.kind}_{i}")
            usd_light.CreateRadiusAttr(0.02)
            if light.outer_fov_deg is not None:
                shaping = UsdLux.ShapingAPI.Apply(usd_light.GetPrim())
                shaping.CreateShapingConeAngleAttr(float(light.outer_fov_deg) / 2)
        usd_light.CreateIntensityAttr(float(light.intensity))
        usd_light.CreateColorAttr(colour)
        usd_light.AddTransformOp().Set(_matrix(pose))
        usd_light.GetPrim().SetCustomDataByKey("datagen:shadow", bool(light.shadow))


def _camera(stage, name: str, camera: dict[str, Any]) -> None:
    K, E = np.asarray(camera["intrinsics"]), np.asarray(camera["extrinsics_world_to_camera"])
    usd_camera = UsdGeom.Camera.Define(stage, f"/World/Cameras/{name}")
    usd_camera.AddTransformOp().Set(_matrix(np.linalg.inv(E) @ _CV_TO_USD_CAMERA))
    w, h = camera["width"], camera["height"]
    usd_camera.CreateHorizontalApertureAttr(w * APERTURE_PER_PIXEL)
    usd_camera.CreateVerticalApertureAttr(h * APERTURE_PER_PIXEL)
    usd_camera.CreateFocalLengthAttr(float(K[0, 0]) * APERTURE_PER_PIXEL)
    usd_camera.CreateHorizontalApertureOffsetAttr((float(K[0, 2]) - w / 2) * APERTURE_PER_PIXEL)
    usd_camera.CreateVerticalApertureOffsetAttr((h / 2 - float(K[1, 2])) * APERTURE_PER_PIXEL)
    usd_camera.CreateClippingRangeAttr(Gf.Vec2f(camera["near"], camera["far"]))
    prim = usd_camera.GetPrim()
    prim.SetCustomDataByKey("datagen:intrinsics", json.dumps(camera["intrinsics"], allow_nan=False))
    prim.SetCustomDataByKey(
        "datagen:extrinsics_world_to_camera",
        json.dumps(camera["extrinsics_world_to_camera"], allow_nan=False),
    )
    prim.SetCustomDataByKey("datagen:resolution", Gf.Vec2i(w, h))
    for key in ("distortion", "distortion_model", "render_intrinsics"):
        if key in camera:
            prim.SetCustomDataByKey(f"datagen:{key}", json.dumps(camera[key], allow_nan=False))


def _box_mesh(half, centre) -> trimesh.Trimesh:
    return trimesh.creation.box(
        extents=2 * np.asarray(half), transform=trimesh.transformations.translation_matrix(centre)
    )


def _centred(centre) -> np.ndarray:
    """The frame SAPIEN maps a box's texture in: its centre (boxes are drawn about it)."""
    return trimesh.transformations.translation_matrix(-np.asarray(centre, float))


def _static_parts(
    stage,
    key: str,
    materials: dict[str, Material],
    out_dir: Path | None,
    ws: Workspace = DEFAULT_WORKSPACE,
) -> None:
    """The floor, table and tray as the simulator builds them: ``/World/<Surface>[/<part>]``,
    an Xform at the part's position with one box Mesh per box, the surface's look on each."""
    looks = {}
    for part in static_parts(ws):
        if part.surface not in looks:
            looks[part.surface] = usd_looks.material(
                stage, key, part.surface, materials[part.surface], out_dir
            )
        path = f"/World/{part.surface.capitalize()}"
        if part.name:
            _xform(stage, path)
            path = f"{path}/{part.name}"
        _xform(stage, path, trimesh.transformations.translation_matrix(part.position))
        for j, (half, offset) in enumerate(part.boxes):
            usd_looks.mesh(
                stage,
                f"{path}/part_{j}",
                _box_mesh(half, offset),
                looks[part.surface],
                materials[part.surface],
                _centred(offset),
            )


def _background(stage, key: str, values: dict[str, Any], out_dir: Path | None) -> None:
    """Backdrop walls (and ceiling) as meshes, room lights as SphereLights."""
    _xform(stage, "/World/Background")
    for name, (half, centre) in wall_boxes(values).items():
        look = usd_looks.material(stage, key, f"wall_{name}", values["walls"][name], out_dir)
        box = _box_mesh(half, centre)
        usd_looks.mesh(
            stage,
            f"/World/Background/wall_{name}",
            box,
            look,
            values["walls"][name],
            _centred(centre),
        )
    for i, light in enumerate(values["lights"]):
        usd_light = UsdLux.SphereLight.Define(stage, f"/World/Background/light_{i}")
        usd_light.CreateRadiusAttr(0.05)
        usd_light.CreateIntensityAttr(float(light["intensity"]))
        usd_light.CreateColorAttr(Gf.Vec3f(*map(float, light["colour"])))
        usd_light.AddTranslateOp().Set(Gf.Vec3d(*map(float, light["position"])))


def scene_stage(meta: dict[str, Any], out_dir: str | Path | None = None) -> Usd.Stage:
    """An in-memory stage of the sample's scene (grasp samples and attempts). The tiles of its
    textured looks are written under ``out_dir`` (where the stage will be exported), if given."""
    if "objects" not in meta:
        raise ValueError(f"sample {meta.get('key')}: USD export covers grasp scenes only")
    out_dir = Path(out_dir) if out_dir is not None else None
    key = meta["key"]
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    world = _xform(stage, "/World")
    stage.SetDefaultPrim(world.GetPrim())
    world.GetPrim().SetCustomDataByKey("datagen:key", key)
    world.GetPrim().SetCustomDataByKey("datagen:seed", int(meta["seed"]))
    world.GetPrim().SetCustomDataByKey("datagen:scene", meta["scene"])
    world.GetPrim().SetCustomDataByKey(
        "datagen:randomisation", json.dumps(meta["randomisation"], sort_keys=True, allow_nan=False)
    )
    values = tabletop_values(meta["randomisation"], f"sample {key}: randomisation")  # typed
    materials = values["materials"]
    robot = meta["robot"]
    ws = Workspace(float(robot.get("workspace_scale", 1.0)), float(robot.get("object_scale", 1.0)))
    _static_parts(stage, key, materials, out_dir, ws)
    _xform(stage, "/World/Objects")
    for obj, material in zip(meta["objects"], materials["objects"], strict=True):
        path = f"/World/Objects/object_{obj['instance_id']}"
        xform = _xform(stage, path, np.asarray(obj["pose_world"]["matrix"]))
        look = usd_looks.material(stage, key, f"object_{obj['instance_id']}", material, out_dir)
        for j, part in enumerate(build_geometry(obj["shape"]).parts):
            usd_looks.mesh(stage, f"{path}/part_{j}", part, look, material)
        prim = xform.GetPrim()
        for field in ("class", "instance_id", "mass", "friction", "restitution", "density"):
            prim.SetCustomDataByKey(f"datagen:{field}", obj[field])
        prim.SetCustomDataByKey(
            "datagen:shape", json.dumps(obj["shape"], sort_keys=True, allow_nan=False)
        )
    if "background" in values:
        _background(stage, key, values["background"], out_dir)
    _distractors(stage, key, values.get("distractors", []), out_dir)
    usd_robot.define_robot(stage, "/World/Robot", meta["robot"], key)
    _xform(stage, "/World/Lights")
    add_to_stage(values["lighting"], stage)
    _xform(stage, "/World/Cameras")
    for camera, view in meta["views"].items():
        _camera(stage, camera, view["camera"])
        for effect in ("camera_effects", "depth_sensor"):  # values that make those images again
            if effect in view:
                prim = stage.GetPrimAtPath(f"/World/Cameras/{camera}")
                prim.SetCustomDataByKey(
                    f"datagen:{effect}", json.dumps(view[effect], allow_nan=False)
                )
    return stage


def validation_errors(stage: Usd.Stage) -> list[str]:
    """usd-core's validators (the rules of usdchecker) run on the stage."""
    validators = UsdValidation.ValidationRegistry().GetOrLoadAllValidators()
    errors = UsdValidation.ValidationContext(validators).Validate(stage)
    return [f"{e.GetName()}: {e.GetMessage()}" for e in errors]


def write_usd(meta: dict[str, Any], path: str | Path) -> Path:
    stage = scene_stage(meta, Path(path).parent)
    stage.GetRootLayer().Export(str(path))
    return Path(path)


def camera_matrices(stage: Usd.Stage, name: str) -> tuple[np.ndarray, np.ndarray]:
    """(K, world-to-OpenCV-camera E) rebuilt from the Camera prim's transform and apertures."""
    camera = UsdGeom.Camera(stage.GetPrimAtPath(f"/World/Cameras/{name}"))
    w, h = stage.GetPrimAtPath(f"/World/Cameras/{name}").GetCustomDataByKey("datagen:resolution")
    to_world = np.asarray(camera.ComputeLocalToWorldTransform(Usd.TimeCode.Default())).T
    E = np.linalg.inv(to_world @ _CV_TO_USD_CAMERA)
    f = camera.GetFocalLengthAttr().Get() / APERTURE_PER_PIXEL
    cx = camera.GetHorizontalApertureOffsetAttr().Get() / APERTURE_PER_PIXEL + w / 2
    cy = h / 2 - camera.GetVerticalApertureOffsetAttr().Get() / APERTURE_PER_PIXEL
    return np.array([[f, 0, cx], [0, f, cy], [0, 0, 1.0]]), E


def _distractors(stage, key: str, distractors: list[dict[str, Any]], out_dir: Path | None) -> None:
    """``Distractors/distractor_<k>`` (when the sample has any): an Xform at its static pose with
    its visual Mesh, placement and shape in customData."""
    if distractors:
        _xform(stage, "/World/Distractors")
    for k, spec in enumerate(distractors, start=1):
        path = f"/World/Distractors/distractor_{k}"
        pose = trimesh.transformations.quaternion_matrix(spec["pose"]["quat_wxyz"])
        pose[:3, 3] = spec["pose"]["position"]
        prim = _xform(stage, path, pose).GetPrim()
        look = usd_looks.material(stage, key, f"distractor_{k}", spec["material"], out_dir)
        visual = build_geometry(spec["shape"]).visual
        usd_looks.mesh(stage, f"{path}/visual", visual, look, spec["material"])
        prim.SetCustomDataByKey("datagen:placement", spec["placement"])
        prim.SetCustomDataByKey(
            "datagen:shape", json.dumps(spec["shape"], sort_keys=True, allow_nan=False)
        )
