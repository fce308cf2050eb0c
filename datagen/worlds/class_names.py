"""Each world's semantic classes, apart from the worlds that draw them: the coordinator writes
them into the manifest without importing SAPIEN, trimesh or the planner (2 s of a build's end).

Class 0 is background (nothing rendered). In the grasp world the object classes are the shape
families, then the distractors (objects that are not grasp targets), whatever their shape, then
the backdrop walls and ceiling (background.enabled). The new classes come last so the ids of
the earlier ones stay what they were; both are classes whether or not a build has any, so ids
are the same across configs (docs/dataset-format.md). The robot's gripper links (its spec's
``gripper.links``) are class ``gripper``, its other links class ``robot``."""

from __future__ import annotations

from datagen.config import BuildConfig
from datagen.config.sections import SHAPE_FAMILIES

STUFF_CLASSES = ("background", "floor", "table", "tray", "robot")
DISTRACTOR_CLASS = "distractor"
WALL_CLASS = "wall"
GRIPPER_CLASS = "gripper"
LAST_CLASSES = (DISTRACTOR_CLASS, WALL_CLASS, GRIPPER_CLASS)
CLASSES = (*STUFF_CLASSES, *SHAPE_FAMILIES, *LAST_CLASSES)
NAV_CLASSES = ("background", "floor", "wall", "door", "obstacle", "goal_marker", "robot", "car")
AERIAL_CLASSES = ("background", "floor", "wall", "ceiling", "obstacle", "goal_marker", "drone")


def grasp_classes(config: BuildConfig) -> tuple[str, ...]:
    """Semantic classes of a grasp build: the shape families, or the class folders of the
    user's meshes (``objects.source: folder``), after the surfaces."""
    if config.objects.source == "folder":
        from datagen.assets.mesh_library import load_library

        meshes = load_library(config.objects.assets_dir).classes
        return (*STUFF_CLASSES, *meshes, *LAST_CLASSES)
    return CLASSES


def navigation_classes(config: BuildConfig) -> tuple[str, ...]:
    return NAV_CLASSES


def aerial_classes(config: BuildConfig) -> tuple[str, ...]:
    return AERIAL_CLASSES
