"""Sampled scene values made SAPIEN things, in one place: objects and distractors, a room's
walls and lights, the lighting, cameras and the robot's joints. The randomisers only sample
(:mod:`datagen.randomisers`); the worlds call these to build what was sampled, so a scene is
rebuilt from its stored values alone. Materials, textures and boxes: :mod:`datagen.worlds.surfaces`.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import singledispatch
from typing import Any

import numpy as np
import sapien

from datagen.assets.backdrop import wall_boxes
from datagen.assets.shapes import ObjectGeometry, build_geometry
from datagen.geometry import look_at
from datagen.robot_specs import HOLD_DAMPING, HOLD_STIFFNESS
from datagen.scene_values.arm import ArmPose
from datagen.scene_values.camera import CameraPose
from datagen.scene_values.lighting import Light, Lighting
from datagen.scene_values.material import Material
from datagen.worlds.surfaces import render_shape, surface_entity

SHADOW_CENTRE = [0, 0, 1]  # metres: the key light's shadow volume centre, unless the values say
SHADOW_HALF_EXTENT = 1.5  # metres: it covers the table, the tray and the robot
CEILING_SHADOW_GAP = 0.05  # metres below a room's ceiling where the key light's shadows begin
POINT_LIGHT_REFERENCE_SQ = 4.0  # squared metres: a point light's intensity means the same at 2 m
SOFT_LIGHT_SPOTS = 3  # shadowed spot lights on a disc standing in for a soft key light
SOFT_SHADOW_MAP_SCALE = 2  # their shadow maps are this much smaller: a penumbra needs no detail
SOFT_LIGHT_DISTANCE = 1.0  # metres from the target: inside the smallest room (1.5 m half size)
SOFT_LIGHT_FOV_DEG = 140.0  # the spots' outer cone, covering the table and the tray
MAX_SPOT_SHADOWS = 10  # SAPIEN's default shader: shadowed spot lights it reads
# SAPIEN's default shader: the lights of each kind it reads
MAX_LIGHTS = {"directional": 3, "point": 10, "spot": 10}
UNLIT_PLACE = [0.0, 0.0, 100.0]  # metres: where a padding light stands, far from any surface
_LIGHT_KIND = {
    sapien.render.RenderDirectionalLightComponent: "directional",
    sapien.render.RenderPointLightComponent: "point",
    sapien.render.RenderSpotLightComponent: "spot",
}


def _radiance_at(position, colour, intensity: float, target) -> list[float]:
    """A light's colour times its intensity, scaled by the squared distance from ``position``
    to ``target``: radiance falls off with it, so intensity means the same at the target."""
    distance_sq = float(np.sum((np.asarray(position) - np.asarray(target)) ** 2))
    return (np.asarray(colour) * intensity * distance_sq).tolist()


def _shadow_near(lighting: Lighting) -> float:
    """Where the key light's shadow casters begin, metres along the light from its centre."""
    if lighting.shadow_near is not None:
        return lighting.shadow_near
    half = lighting.shadow_half_extent
    return -2.0 * (SHADOW_HALF_EXTENT if half is None else half)


def add_objects(
    scene: sapien.Scene,
    objects: list[dict[str, Any]],
    poses: list[dict[str, Any]],
    materials: list[Material],
) -> list[tuple[sapien.Entity, ObjectGeometry]]:
    """One dynamic actor per object, convex collision parts, its own material."""
    added = []
    for i, (obj, pose, material) in enumerate(zip(objects, poses, materials, strict=True)):
        geometry = build_geometry(obj["shape"])
        physx_material = sapien.physx.PhysxMaterial(
            obj["friction"], obj["friction"], obj["restitution"]
        )
        body = sapien.physx.PhysxRigidDynamicComponent()
        for part in geometry.parts:
            shape = sapien.physx.PhysxCollisionShapeConvexMesh(
                np.asarray(part.vertices, np.float32), np.ones(3, np.float32), physx_material
            )
            shape.set_density(obj["density"])
            body.attach(shape)
        render_body = sapien.render.RenderBodyComponent()
        render_body.attach(render_shape(geometry.visual, material))
        entity = sapien.Entity()
        entity.name = f"object_{i + 1}"
        entity.add_component(body)
        entity.add_component(render_body)
        entity.set_pose(sapien.Pose(pose["position"], pose["quat_wxyz"]))
        scene.add_entity(entity)
        added.append((entity, geometry))
    return added


def add_distractors(
    scene: sapien.Scene, distractors: list[dict[str, Any]]
) -> list[tuple[sapien.Entity, ObjectGeometry]]:
    """One static, visual-only entity per distractor (no collision shape)."""
    added = []
    for i, spec in enumerate(distractors):
        geometry = build_geometry(spec["shape"])
        render_body = sapien.render.RenderBodyComponent()
        render_body.attach(render_shape(geometry.visual, spec["material"]))
        entity = sapien.Entity()
        entity.name = f"distractor_{i + 1}"
        entity.add_component(render_body)
        entity.set_pose(sapien.Pose(spec["pose"]["position"], spec["pose"]["quat_wxyz"]))
        scene.add_entity(entity)
        added.append((entity, geometry))
    return added


def add_background(scene: sapien.Scene, values: dict[str, Any] | None) -> list[sapien.Entity]:
    """A room's walls (and ceiling) as drawn-only entities, and its lights; nothing for
    ``None`` (background off)."""
    entities: list[sapien.Entity] = []
    if values is None:
        return entities
    for name, (half_size, centre) in wall_boxes(values).items():
        entity = surface_entity(
            scene, f"wall_{name}", [(half_size, [0, 0, 0])], values["walls"][name], collide=False
        )
        entity.set_pose(sapien.Pose(centre))
        entities.append(entity)
    for light in values["lights"]:
        scene.add_point_light(
            light["position"],
            _radiance_at(light["position"], light["colour"], light["intensity"], values["target"]),
            shadow=False,
        )
    return entities


def lit_by_room(lighting: Lighting, room: dict[str, Any] | None) -> Lighting:
    """The lighting to apply under this room (``randomisation.background``): with a ceiling,
    the key light's shadow casters stop ``CEILING_SHADOW_GAP`` below it, so the ceiling does
    not shade the whole scene; unchanged without one."""
    if not room or not room["ceiling"]:
        return lighting
    centre_z = (lighting.shadow_centre or SHADOW_CENTRE)[2]
    near = max(-(room["room"]["height"] - centre_z - CEILING_SHADOW_GAP), _shadow_near(lighting))
    return replace(lighting, shadow_near=near)


@dataclass(frozen=True)
class _Spot:
    """A spot light as SAPIEN gets it: a fill light, or one of a soft key light's cluster."""

    position: np.ndarray  # metres
    direction: np.ndarray
    colour: tuple[float, ...]
    intensity: float
    outer_fov_deg: float
    shadow: bool
    soft: bool = False  # of a soft key light: a smaller shadow map

    @classmethod
    def of(cls, light: Light) -> _Spot:
        assert light.position is not None and light.direction is not None
        assert light.outer_fov_deg is not None
        return cls(
            np.asarray(light.position, float),
            np.asarray(light.direction, float),
            light.colour,
            light.intensity,
            light.outer_fov_deg,
            light.shadow,
        )


def soft_key_spots(light: Light, target) -> list[_Spot]:
    """A soft key light as ``SOFT_LIGHT_SPOTS`` spot lights on a disc of radius
    ``light.area_radius_m`` facing the target from ``SOFT_LIGHT_DISTANCE`` back along the
    light's direction (a sunflower pattern), sharing its radiance at the target: their shadows
    overlap into a penumbra that widens with the occluder's height, as under an area light."""
    assert light.direction is not None and light.area_radius_m is not None
    direction = np.asarray(light.direction, float)
    side = np.cross(direction, [0.0, 0.0, 1.0])
    side = side / np.linalg.norm(side) if np.linalg.norm(side) > 1e-6 else np.array([1.0, 0, 0])
    up = np.cross(direction, side)
    centre = np.asarray(target, float) - direction * SOFT_LIGHT_DISTANCE
    spots = []
    for i in range(SOFT_LIGHT_SPOTS):
        radius = light.area_radius_m * np.sqrt((i + 0.5) / SOFT_LIGHT_SPOTS)
        angle = i * np.pi * (3 - np.sqrt(5))  # radians: the golden angle
        position = centre + radius * (np.cos(angle) * side + np.sin(angle) * up)
        spots.append(
            _Spot(
                position,
                np.asarray(target) - position,
                light.colour,
                light.intensity / SOFT_LIGHT_SPOTS,
                SOFT_LIGHT_FOV_DEG,
                shadow=True,
                soft=True,
            )
        )
    return spots


def _add_spot(scene: sapien.Scene, spot: _Spot, target, shadow_map_size: int) -> None:
    outer = np.deg2rad(spot.outer_fov_deg)
    scene.add_spot_light(
        spot.position.tolist(),
        spot.direction.tolist(),
        inner_fov=outer * 0.6,
        outer_fov=outer,
        color=_radiance_at(spot.position, spot.colour, spot.intensity, target),
        shadow=spot.shadow,
        shadow_near=0.1,
        shadow_far=5.0,
        shadow_map_size=shadow_map_size,
    )


@singledispatch
def realise(value: object, into: Any, **options: Any) -> None:
    """Makes the scene value ``value`` SAPIEN things in ``into`` (a scene, a camera, an arm),
    chosen by the value's type; a type without a SAPIEN realiser is an error."""
    raise TypeError(f"no SAPIEN realiser for scene values of type {type(value).__name__}")


@realise.register
def apply_lighting(values: Lighting, scene: sapien.Scene, shadow_map_size: int) -> None:
    """The ambient level, the directional key light (or the spots of a soft one) and the spot
    (or point) lights; spots past ``MAX_SPOT_SHADOWS`` shadowed ones lose their shadow."""
    scene.set_ambient_light([values.ambient] * 3)
    spots: list[_Spot] = []
    for light in values.lights:
        colour = np.asarray(light.colour) * light.intensity
        if light.kind == "directional" and light.soft:
            spots = soft_key_spots(light, values.target) + spots
        elif light.kind == "directional":
            # the shadow volume (metres around its centre) must cover what the cameras see
            scale = values.shadow_half_extent
            scale = SHADOW_HALF_EXTENT if scale is None else scale
            scene.add_directional_light(
                list(light.direction or ()),
                colour.tolist(),
                shadow=light.shadow,
                position=list(values.shadow_centre or SHADOW_CENTRE),
                shadow_scale=scale,
                shadow_near=_shadow_near(values),
                shadow_far=2.0 * scale,
                shadow_map_size=shadow_map_size,
            )
        elif light.kind == "point":
            colour = colour * POINT_LIGHT_REFERENCE_SQ
            scene.add_point_light(list(light.position or ()), colour.tolist(), shadow=False)
        else:
            spots.append(_Spot.of(light))
    shadowed = 0
    for spot in spots:
        shadow = spot.shadow and shadowed < MAX_SPOT_SHADOWS
        shadowed += shadow
        size = shadow_map_size // SOFT_SHADOW_MAP_SCALE if spot.soft else shadow_map_size
        _add_spot(scene, replace(spot, shadow=shadow), values.target, size)


def light_slots(spots: int, points: int) -> dict[str, int]:
    """The light counts every scene of a config is padded to (:func:`pad_lights`): one
    directional key, the most spot and point lights its scenes can have."""
    slots = {"directional": 1, "point": points, "spot": spots}
    return {kind: min(n, MAX_LIGHTS[kind]) for kind, n in slots.items()}


def pad_lights(scene: sapien.Scene, slots: dict[str, int]) -> None:
    """Adds unlit lights (zero emission, no shadow) until ``scene`` has ``slots[kind]`` lights of
    each kind. SAPIEN compiles its lighting shader for each combination of light counts it meets
    (about 50 ms of CPU per combination on lavapipe, so nearly every default scene paid it);
    padded, a config's scenes differ only in how many lights cast shadows. A light of zero
    emission adds exactly 0 to every pixel: the pictures keep their bytes
    (tests/worlds/test_lights.py)."""
    have = {kind: 0 for kind in MAX_LIGHTS}
    for light in scene.render_system.lights:
        have[_LIGHT_KIND[type(light)]] += 1
    black = [0.0, 0.0, 0.0]
    for _ in range(slots["directional"] - have["directional"]):
        scene.add_directional_light([0.0, 0.0, -1.0], black, shadow=False)
    for _ in range(slots["point"] - have["point"]):
        scene.add_point_light(UNLIT_PLACE, black, shadow=False)
    for _ in range(slots["spot"] - have["spot"]):
        scene.add_spot_light(UNLIT_PLACE, [0.0, 0.0, -1.0], 0.5, 1.0, black, shadow=False)


@realise.register
def apply_camera(values: CameraPose, camera: sapien.render.RenderCameraComponent) -> None:
    """A camera's field of view and its pose looking from ``eye`` at ``target``."""
    camera.set_fovy(np.deg2rad(values.fovy_deg), compute_x=True)
    camera.entity.set_pose(sapien.Pose(look_at(values.eye, values.target)))


@realise.register
def apply_robot(
    values: ArmPose, robot: sapien.physx.PhysxArticulation, joint_names: tuple[str, ...]
) -> None:
    """Sets the joints (``values.qpos`` in the order of ``joint_names``: the arm's, then the
    fingers') and holds them there with stiff PD drives (stiffness N·m/rad)."""
    joints = robot.get_active_joints()
    if sorted(j.name for j in joints) != sorted(joint_names):
        raise ValueError(
            f"the robot's active joints are {[j.name for j in joints]}, its record names "
            f"{list(joint_names)}"
        )
    sampled = dict(zip(joint_names, values.qpos, strict=True))
    qpos = np.asarray([sampled[j.name] for j in joints], np.float32)
    robot.set_qpos(qpos)
    for joint, target in zip(joints, qpos, strict=True):
        joint.set_drive_property(stiffness=HOLD_STIFFNESS, damping=HOLD_DAMPING)
        joint.set_drive_target(float(target))
