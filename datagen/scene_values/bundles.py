"""Each world's drawn values by name, read back from a sample's stored ``randomisation``: the
entries with a value type become that type (checked as they are made), the others stay the
JSON they were stored as."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

from datagen.scene_values.arm import ArmPose
from datagen.scene_values.camera import CameraPose
from datagen.scene_values.checks import SceneValueError, fields
from datagen.scene_values.lighting import Lighting
from datagen.scene_values.material import Material

FromJson = Callable[[Any, str], Any]

SURFACES = ("table", "tray", "floor")  # the tabletop's surfaces in its materials, after objects
MAX_ITEMS = 10_000  # objects or distractors in one stored scene


def tabletop_values(stored: Any, where: str = "randomisation") -> dict[str, Any]:
    """A grasp scene's stored values with its typed entries made their types; its extra views
    (``extra_views``, name -> camera pose) too, and every material: the objects' and surfaces',
    the room's walls (``background.walls``) and each distractor's."""
    values = typed_values(stored, TABLETOP_TYPES, where)
    if "background" in values:
        values["background"] = room_values(values["background"], f"{where}.background")
    if "distractors" in values:
        values["distractors"] = distractor_values(values["distractors"], f"{where}.distractors")
    if "extra_views" in values:
        views = values["extra_views"]
        if not isinstance(views, Mapping) or len(views) > 64:
            raise SceneValueError(f"{where}.extra_views: expected an object of at most 64 views")
        values["extra_views"] = {
            name: CameraPose.from_json(view, f"{where}.extra_views.{str(name)[:40]}")
            for name, view in views.items()
        }
    return values


def tabletop_materials(stored: Any, where: str = "randomisation.materials") -> dict[str, Any]:
    """The tabletop's materials (``objects``: a list; ``table``, ``tray``, ``floor``) as
    :class:`Material` values."""
    f = fields(where, stored, {"objects", *SURFACES}, set())
    objects = f["objects"]
    if not isinstance(objects, list) or len(objects) > MAX_ITEMS:
        raise SceneValueError(f"{where}.objects: expected a list of at most {MAX_ITEMS}")
    return {
        name: (
            [Material.from_json(m, f"{where}.objects[{i}]") for i, m in enumerate(objects)]
            if name == "objects"
            else Material.from_json(value, f"{where}.{name}")
        )
        for name, value in f.items()
    }


def room_values(stored: Any, where: str) -> dict[str, Any]:
    """The background's stored values with each wall's material typed."""
    if not isinstance(stored, Mapping) or not isinstance(stored.get("walls"), Mapping):
        raise SceneValueError(f"{where}: expected an object with walls")
    walls = stored["walls"]
    if len(walls) > 8:
        raise SceneValueError(f"{where}.walls: expected at most 8 walls")
    typed = {
        name: Material.from_json(m, f"{where}.walls.{str(name)[:40]}") for name, m in walls.items()
    }
    return {**stored, "walls": typed}


def distractor_values(stored: Any, where: str) -> list[Any]:
    """The distractors' stored values with each one's material typed."""
    if not isinstance(stored, list) or len(stored) > MAX_ITEMS:
        raise SceneValueError(f"{where}: expected a list of at most {MAX_ITEMS}")
    typed = []
    for k, spec in enumerate(stored):
        if not isinstance(spec, Mapping) or "material" not in spec:
            raise SceneValueError(f"{where}[{k}]: expected an object with a material")
        typed.append({**spec, "material": Material.from_json(spec["material"], f"{where}[{k}]")})
    return typed


def typed_values(stored: Any, types: Mapping[str, FromJson], where: str) -> dict[str, Any]:
    """``stored`` (a JSON object) with each entry named in ``types`` read as its type."""
    if not isinstance(stored, Mapping):
        raise SceneValueError(f"{where}: expected an object, got {type(stored).__name__}")
    values = dict(stored)
    for name, from_json in types.items():
        if name not in values:
            raise SceneValueError(f"{where}: missing {name}")
        values[name] = from_json(values[name], f"{where}.{name}")
    return values


# name in randomisation -> its type's reader, for each world that stores typed values
TABLETOP_TYPES: dict[str, FromJson] = {
    "lighting": Lighting.from_json,
    "camera": CameraPose.from_json,
    "robot": ArmPose.from_json,
    "materials": tabletop_materials,
}
