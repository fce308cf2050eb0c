"""Each world's drawn values by name, read back from a sample's stored ``randomisation``: the
entries with a value type become that type (checked as they are made), the others stay the
JSON they were stored as."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

from datagen.scene_values.arm import ArmPose
from datagen.scene_values.camera import CameraPose
from datagen.scene_values.checks import SceneValueError
from datagen.scene_values.lighting import Lighting

FromJson = Callable[[Any, str], Any]

# name in randomisation -> its type's reader, for each world that stores typed values
TABLETOP_TYPES: dict[str, FromJson] = {
    "lighting": Lighting.from_json,
    "camera": CameraPose.from_json,
    "robot": ArmPose.from_json,
}


def tabletop_values(stored: Any, where: str = "randomisation") -> dict[str, Any]:
    """A grasp scene's stored values with its typed entries made their types; its extra views
    (``extra_views``, name -> camera pose) too."""
    values = typed_values(stored, TABLETOP_TYPES, where)
    if "extra_views" in values:
        views = values["extra_views"]
        if not isinstance(views, Mapping) or len(views) > 64:
            raise SceneValueError(f"{where}.extra_views: expected an object of at most 64 views")
        values["extra_views"] = {
            name: CameraPose.from_json(view, f"{where}.extra_views.{str(name)[:40]}")
            for name, view in views.items()
        }
    return values


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
