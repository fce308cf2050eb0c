"""Distractor randomiser: objects that are not grasp targets, class ``distractor``.

Three placements (``distractors`` config section), each a count range:

- ``table``: standing upright (random yaw) on the table top where the workspace camera sees
  it, outside the tray and away from the robot's base;
- ``air``: floating between the workspace camera and its target, off the image centre (a
  random direction at 40-85 % of the half field of view), at 45-75 % of the way from the
  camera, randomly oriented;
- ``background``: standing on the floor beyond the table, inside the background's room (if
  any), where the workspace camera sees its top over the table, larger (``background_size``).
  A view that sees no such spot gets none.

Flying distractors (``flying``, stream ``distractors.flying``: :func:`draw_flying`) come
after those: anywhere in the view, at a depth of ``flying_depth`` times the camera-to-target
distance (in front of, at and beyond the tray; never in the table, the tray's space or beyond
the room's walls), randomly oriented, any shape family or a thin card. A card shows a
photograph with ``photos.distractor_probability`` (its random crop, once, on each face).

Distractors are static and visual only: they never fall, never push a target, never block the
robot, so the targets' physics is the same with or without them. Their materials are drawn like
the objects' (colour, then a texture with ``materials.texture_probability``). Every value is
stored (shape, pose, material), so the scene is rebuilt from the metadata alone.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from transforms3d.quaternions import quat2mat

from datagen.assets.shapes import build_geometry
from datagen.assets.tabletop_layout import DEFAULT_WORKSPACE, Workspace
from datagen.config.appearance import DistractorsConfig, PhotosConfig
from datagen.config.sections import SHAPE_FAMILIES, MaterialsConfig
from datagen.geometry import random_quaternion
from datagen.randomisers.materials import random_material
from datagen.randomisers.objects import draw_shape
from datagen.randomisers.photos import draw_photo
from datagen.randomisers.textures import DEFAULT_PHOTOS, maybe_texture
from datagen.scene_values.camera import CameraPose
from datagen.scene_values.material import Material

PLACEMENTS = ("table", "air", "background")
ROBOT_CLEARANCE = 0.3  # metres around the robot base kept free of table distractors
TRAY_CLEARANCE = 0.02  # metres between a table distractor and the tray's outer wall
AIR_FRACTION = (0.45, 0.75)  # of the way from the camera to its target
AIR_OFF_CENTRE = (0.4, 0.85)  # of the half field of view
BACKGROUND_REACH = 4.0  # metres from the table's centre, per axis, where there is no room
BACKGROUND_TRIES = 60  # random floor spots tried per background distractor
_TRIES = 40  # rejection sampling of a free spot; a distractor with none is left out
FLYING = "flying"  # the placement of :func:`draw_flying`'s distractors
CARD = "card"  # a thin flat box, the flying distractors' extra shape family
CARD_THICKNESS = (0.001, 0.005)  # metres
CARD_ASPECT = (0.5, 1.0)  # short side / long side of a card without a photograph
FLYING_VIEW_SHARE = 0.5  # a flying distractor spans at most this share of the view's height
TRAY_HEADROOM = 0.15  # metres above the tray's floor kept free of flying distractors


@dataclass(frozen=True)
class _View:
    """The workspace camera's frame, from its stored values (world metres, unit axes)."""

    eye: np.ndarray
    forward: np.ndarray
    right: np.ndarray
    up: np.ndarray
    tan_half: float  # tangent of half the vertical field of view
    distance: float  # eye to target, metres
    ws: Workspace  # the table, tray and robot base it looks at
    aspect: float = 1.0  # width / height of the view's part used (1: a square about its centre)

    @classmethod
    def of(
        cls, camera: CameraPose, ws: Workspace = DEFAULT_WORKSPACE, aspect: float = 1.0
    ) -> _View:
        eye, target = np.asarray(camera.eye, float), np.asarray(camera.target, float)
        distance = float(np.linalg.norm(target - eye))
        forward = (target - eye) / distance
        right = np.cross(forward, [0.0, 0.0, 1.0])
        right /= np.linalg.norm(right)
        tan_half = float(np.tan(np.deg2rad(camera.fovy_deg) / 2))
        up = np.cross(right, forward)
        return cls(eye, forward, right, up, tan_half, distance, ws, aspect)

    def random_ray(self, rng: np.random.Generator) -> np.ndarray:
        """Direction through a random image point (within ``aspect`` times the half height
        across); its component along ``forward`` is 1."""
        across, above = rng.uniform(-1.0, 1.0, 2)
        return self.forward + self.tan_half * (across * self.aspect * self.right + above * self.up)

    def meets(self, ray: np.ndarray, z: float) -> np.ndarray:
        """(x, y) where the ray from the eye crosses the plane at height ``z``."""
        return self.eye[:2] + ray[:2] * ((z - self.eye[2]) / ray[2])

    def sees(self, point: np.ndarray) -> bool:
        """Whether ``point`` is in the view and not behind the table top."""
        ray = point - self.eye
        depth, limit = float(ray @ self.forward), self.tan_half * float(ray @ self.forward)
        if depth <= 0 or abs(ray @ self.right) > self.aspect * limit or abs(ray @ self.up) > limit:
            return False
        top = self.ws.table_top
        if point[2] >= top or self.eye[2] <= top:
            return True
        return bool((np.abs(self.meets(ray, top)) > self.ws.table_half).any())


def _yaw_quaternion(rng: np.random.Generator) -> list[float]:
    yaw = rng.uniform(0, 2 * np.pi)
    return [round(float(np.cos(yaw / 2)), 6), 0.0, 0.0, round(float(np.sin(yaw / 2)), 6)]


def _standing(xy: np.ndarray, surface_z: float, lowest: float) -> list[float]:
    """Position of an upright (yaw-only) shape whose lowest point is ``lowest`` (object frame)
    resting on the plane z = ``surface_z``."""
    return np.round([xy[0], xy[1], surface_z - lowest], 6).tolist()


def _free_on_table(xy: np.ndarray, radius: float, ws: Workspace) -> bool:
    (ix, iy), wall = ws.tray_inner_half, ws.tray_wall[0] + TRAY_CLEARANCE * ws.scale + radius
    (cx, cy, _), (bx, by, _) = ws.tray_centre, ws.robot_base
    in_tray = abs(xy[0] - cx) < ix + wall and abs(xy[1] - cy) < iy + wall
    near_robot = np.hypot(xy[0] - bx, xy[1] - by) < ROBOT_CLEARANCE * ws.scale + radius
    return not in_tray and not near_robot


def _table_position(rng, view: _View, bounds: np.ndarray, radius: float) -> list[float] | None:
    """Where the ray through a random point of the view meets the table top, if that is on the
    table and free (a view may see none of the table outside the tray)."""
    limit = np.asarray(view.ws.table_half) - radius
    for _ in range(_TRIES):
        ray = view.random_ray(rng)
        if ray[2] >= 0:
            continue
        xy = view.meets(ray, view.ws.table_top)
        if (np.abs(xy) <= limit).all() and _free_on_table(xy, radius, view.ws):
            return _standing(xy, view.ws.table_top, bounds[0][2])
    return None


def _air_position(rng, view: _View, radius: float) -> list[float]:
    distance = rng.uniform(*AIR_FRACTION) * view.distance
    angle, off = rng.uniform(0, 2 * np.pi), rng.uniform(*AIR_OFF_CENTRE) * view.tan_half
    sideways = off * distance * (np.cos(angle) * view.right + np.sin(angle) * view.up)
    point = view.eye + distance * view.forward + sideways
    point[2] = max(point[2], view.ws.table_top + radius + 0.02)  # above the table, never in it
    return np.round(point, 6).tolist()


def _background_position(rng, view: _View, bounds, radius, room) -> list[float] | None:
    """A floor point in view, beyond the table and inside the room (else within
    BACKGROUND_REACH of the table's centre), from which the shape's top is seen over the table
    (a view may see no such spot)."""
    height = float(bounds[1][2] - bounds[0][2])
    if room is not None:
        lo = np.array([room["x"][0], room["y"][0]]) + radius
        hi = np.array([room["x"][1], room["y"][1]]) - radius
    else:
        lo, hi = np.full(2, -BACKGROUND_REACH), np.full(2, BACKGROUND_REACH)
    for _ in range(BACKGROUND_TRIES):
        ray = view.random_ray(rng)
        if ray[2] >= 0:
            continue
        xy = view.meets(ray, 0.0)
        inside = (xy >= lo).all() and (xy <= hi).all()
        beyond_table = (np.abs(xy) > np.asarray(view.ws.table_half) + radius).any()
        if inside and beyond_table and view.sees(np.array([*xy, 0.9 * height])):
            return _standing(xy, 0.0, bounds[0][2])
    return None


def _material(
    rng: np.random.Generator, cfg: MaterialsConfig, photos: PhotosConfig | None
) -> Material:
    """A colour like an object's, textured with ``materials.texture_probability`` (a picture of
    ``textures_dir`` cropped and jittered within the ``photos`` section's ranges)."""
    material = random_material(rng, cfg, cfg.saturation, cfg.value)
    return maybe_texture(rng, material, cfg, photos or DEFAULT_PHOTOS)


def draw_distractors(
    rng: np.random.Generator,
    cfg: DistractorsConfig,
    materials: MaterialsConfig,
    camera: CameraPose,
    room: dict[str, Any] | None = None,
    ws: Workspace = DEFAULT_WORKSPACE,
    photos: PhotosConfig | None = None,
) -> list[dict[str, Any]]:
    """Distractors of one scene, by placement; ``camera`` is the workspace camera's values,
    ``photos`` the section whose ranges crop and jitter a picture of ``textures_dir``,
    ``room`` the background's room (``{"x": [lo, hi], "y": [lo, hi], ...}``) if there is one."""
    counts = {"table": cfg.on_table, "air": cfg.in_air, "background": cfg.background}
    view = _View.of(camera, ws)
    distractors = []
    for placement in PLACEMENTS:
        low, high = counts[placement]
        for _ in range(int(rng.integers(low, high + 1))):
            size_range = cfg.background_size if placement == "background" else cfg.size
            size = float(rng.uniform(*size_range))
            shape = draw_shape(rng, str(rng.choice(SHAPE_FAMILIES)), size)
            material = _material(rng, materials, photos)
            radius = size / 2
            position: list[float] | None
            if placement == "air":
                quat, position = random_quaternion(rng), _air_position(rng, view, radius)
            else:
                quat, bounds = _yaw_quaternion(rng), build_geometry(shape).visual.bounds
                if placement == "table":
                    position = _table_position(rng, view, bounds, radius)
                else:
                    position = _background_position(rng, view, bounds, radius, room)
            if position is None:
                continue
            distractors.append(
                {
                    "placement": placement,
                    "shape": shape,
                    "pose": {"position": position, "quat_wxyz": quat},
                    "material": material,
                }
            )
    return distractors


def _clear_in_air(
    point: np.ndarray, radius: float, view: _View, room, wrist_view: bool = False
) -> bool:
    """Whether a flying distractor of ``radius`` about ``point`` is seen (not behind the table
    top), above the floor, inside the room (else within BACKGROUND_REACH of the table's centre)
    and clear of the table and of the space above the tray where the targets lie (with
    ``wrist_view``, of the whole column above the tray, which the wrist camera looks down)."""
    ws, (x, y, z) = view.ws, point
    if room is not None:
        lo = np.array([room["x"][0], room["y"][0], 0.0]) + radius
        hi = np.array([room["x"][1], room["y"][1], room["height"]]) - radius
    else:
        lo = np.array([-BACKGROUND_REACH, -BACKGROUND_REACH, radius])
        hi = np.array([BACKGROUND_REACH, BACKGROUND_REACH, np.inf])
    if not ((point >= lo).all() and (point <= hi).all() and view.sees(point)):
        return False
    (hx, hy), (cx, cy, cz) = ws.table_half, ws.tray_centre
    in_table = abs(x) < hx + radius and abs(y) < hy + radius and z < ws.table_top + radius
    (ix, iy), wall = ws.tray_inner_half, ws.tray_wall[0] + radius
    over_tray = abs(x - cx) < ix + wall and abs(y - cy) < iy + wall
    headroom = np.inf if wrist_view else TRAY_HEADROOM * ws.scale + radius
    return not in_table and not (over_tray and z < cz + headroom)


def _flying_spot(rng, view: _View, cfg: DistractorsConfig, size: float, room, wrist_view: bool):
    """(centre, largest extent) of a flying distractor: a random image point at a random depth
    (``flying_depth`` times the camera-to-target distance, along the view's axis), the extent
    capped so that it spans at most FLYING_VIEW_SHARE of the view's height there; None when no
    try is clear."""
    for _ in range(_TRIES):
        depth = rng.uniform(*cfg.flying_depth) * view.distance
        point = view.eye + depth * view.random_ray(rng)
        extent = min(size, FLYING_VIEW_SHARE * 2 * depth * min(view.tan_half, 1.0))
        if _clear_in_air(point, extent / 2, view, room, wrist_view):
            return point, extent
    return None


def card_shape(rng: np.random.Generator, size: float, aspect: float) -> dict[str, Any]:
    """A thin card of largest side ``size`` (metres), ``aspect`` its height / width, with a
    corner at its origin: a picture ``scale_m`` = its width (and ``aspect``) covers a face once."""
    width, height = (size, size * aspect) if aspect <= 1 else (size / aspect, size)
    extents = np.round([width, height, rng.uniform(*CARD_THICKNESS)], 6).tolist()
    corner = {"offset": [extents[0] / 2, extents[1] / 2, 0.0], "quat_wxyz": [1.0, 0.0, 0.0, 0.0]}
    return {"family": CARD, "parts": [{"kind": "box", "extents": extents, **corner}]}


def _photo_card(rng, photos: PhotosConfig, materials: MaterialsConfig, size: float):
    """(shape, material) of a card showing a photograph (``draw_photo``'s values, its
    scale set to the card's width, unrotated)."""
    photo = draw_photo(rng, photos, (size, size), rotate=False)
    shape = card_shape(rng, size, float(photo.get("aspect", 1.0)))
    photo["scale_m"] = shape["parts"][0]["extents"][0]
    material = random_material(rng, materials, materials.saturation, materials.value)
    return shape, material.with_texture(photo)


def draw_flying(
    rng: np.random.Generator,
    cfg: DistractorsConfig,
    materials: MaterialsConfig,
    photos: PhotosConfig | None,
    camera: CameraPose,
    room: dict[str, Any] | None = None,
    ws: Workspace = DEFAULT_WORKSPACE,
    aspect: float = 1.0,
    wrist_view: bool = False,
) -> list[dict[str, Any]]:
    """Flying distractors of one scene (placement ``flying``), from their own stream; none for
    ``flying`` [0, 0]. ``photos`` is the ``photos`` config section (None: no photographs),
    ``aspect`` the workspace view's width / height, ``wrist_view`` whether the wrist camera
    looks down at the tray (``robot.pose: look``: nothing flies above the tray); the rest as in
    :func:`draw_distractors`."""
    view = _View.of(camera, ws, aspect)
    photo_share = photos.distractor_probability if photos is not None and photos.enabled else 0.0
    flying = []
    for _ in range(int(rng.integers(cfg.flying[0], cfg.flying[1] + 1))):
        with_photo = rng.random() < photo_share  # always drawn: photos on or off
        size = float(rng.uniform(*cfg.flying_size))
        spot = _flying_spot(rng, view, cfg, size, room, wrist_view)
        if spot is None:
            continue
        centre, size = spot
        if with_photo:
            assert photos is not None  # a share above 0 needs photos on
            shape, material = _photo_card(rng, photos, materials, size)
        else:
            family = str(rng.choice([*SHAPE_FAMILIES, CARD]))
            if family == CARD:
                shape = card_shape(rng, size, float(rng.uniform(*CARD_ASPECT)))
            else:
                shape = draw_shape(rng, family, size)
            material = _material(rng, materials, photos)
        quat = random_quaternion(rng)
        bounds = build_geometry(shape).visual.bounds
        # the shape's bounding-box centre at the spot: its origin may be a corner or its base
        offset = quat2mat(quat) @ ((bounds[0] + bounds[1]) / 2)
        pose = {"position": np.round(centre - offset, 6).tolist(), "quat_wxyz": quat}
        flying.append({"placement": FLYING, "shape": shape, "pose": pose, "material": material})
    return flying
