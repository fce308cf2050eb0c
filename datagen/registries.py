"""Every name a user can choose, in one place: scene families, the metadata formats their
samples are written in, grasp samplers, export formats, executors, navigation layouts and robots.

Each table maps a name to a record whose code is referenced as ``"module:attribute"`` and
imported only when used, so that reading a config (or a dataset) never imports the simulator.
Config validation, CLI choices and the code that runs a choice all ask these tables; nothing
else lists the names. Adding a plug-in is one module plus one line here (docs/extending.md).

Installed packages may add entries through entry points in the groups ``datagen.families``,
``datagen.metadata_formats``, ``datagen.samplers``, ``datagen.exports``, ``datagen.executors``, ``datagen.layouts`` and
``datagen.robots``: an
entry point's object is the record itself (for example a :class:`SceneFamily`). They are
loaded the first time a table is read. A plug-in that cannot be used (its import fails, its
object is not a record of the table's kind, it has no name, or its name is a built-in's or an
earlier plug-in's) is skipped and reported once on the ``datagen.plugins`` logger; the table
stays usable, and choosing its name is an error that says why it failed to load.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from typing import Any

from datagen.errors import DatasetError
from datagen.records import ExportFunction
from datagen.registry import Registry, resolve


@dataclass(frozen=True)
class SceneFamily:
    """A kind of sample a build makes (``scene:`` in the config)."""

    name: str
    summary: str  # one line, shown by `datagen build --help`
    produce: str  # (config, seed, index, attempt) -> datagen.sample.Sample
    classes: str  # (config) -> tuple of class names; a class's id is its position
    section: str | None = None  # the config section holding its own settings, if any
    # the metadata formats its samples are written in (METADATA_FORMATS)
    metadata_formats: tuple[str, ...] = ("datagen.sample/1",)
    world: str | None = None  # the world its scenes are built in, for exports that need it
    finish: str | None = None  # (out_dir, made, seconds) -> dict merged into the manifest
    episodes: bool = False  # its samples are episodes over time (datagen.exports.episodes)

    def produce_sample(self, config, seed: int, index: int, attempt: int = 0):
        return resolve(self.produce)(config, seed, index, attempt)

    def class_names(self, config) -> tuple[str, ...]:
        return tuple(resolve(self.classes)(config))


# what a metadata format's module defines (datagen/formats/__init__.py says what each does)
FORMAT_FUNCTIONS = ("views", "summary", "distributions", "summary_fields", "tile", "episodes")


@dataclass(frozen=True)
class MetadataFormat:
    """How the samples of one metadata format (``meta["format"]``) are read, summarised, drawn
    and turned into episodes: ``module`` defines :data:`FORMAT_FUNCTIONS` (and may define
    ``check`` and ``pictures``), imported on first use. Readers, tools and exports ask the
    format of a sample's metadata; none of them names a family."""

    name: str  # the value of meta["format"], with its version: "datagen.sample/1"
    summary: str  # one line, shown in docs/extending.md
    module: str  # "package.module"
    noun: str = "samples"  # what one sample is called in inspect's plot titles

    def function(self, name: str) -> Any:
        """The module's ``name``; DatasetError naming the module where it defines none."""
        if (found := self.optional(name)) is None:
            raise DatasetError(
                f"metadata format {self.name!r}: its module {self.module} defines no {name}()"
            )
        return found

    def optional(self, name: str) -> Any:
        """The module's ``name`` if it defines one as a function, else None."""
        found = getattr(importlib.import_module(self.module), name, None)
        return found if callable(found) else None


def metadata_format(meta: Any, where: str) -> MetadataFormat:
    """The format of a sample's metadata (``meta["format"]``); DatasetError naming ``where``
    (the sample) and the formats known otherwise."""
    name = meta.get("format") if isinstance(meta, dict) else None
    if not isinstance(name, str) or name not in METADATA_FORMATS:
        raise DatasetError(
            f"{where}: unknown metadata format {repr(name)[:80]}; "
            f"expected one of {METADATA_FORMATS.names()}"
        )
    return METADATA_FORMATS[name]


@dataclass(frozen=True)
class ExportFormat:
    """A format exported from a finished dataset's shards (``output.sinks``, ``--to``)."""

    name: str
    path: str  # file or folder in the dataset directory
    export: str  # a datagen.records.ExportFunction
    worlds: tuple[str, ...] | None = None  # the scene worlds it can describe; None: any
    episodes: bool = False  # describes episodes only (datagen.exports.episodes)

    def load(self) -> ExportFunction:
        return resolve(self.export)


@dataclass(frozen=True)
class Plugin:
    """A grasp sampler (a class) or an executor (a class): a name and what it refers to."""

    name: str
    target: str

    def load(self) -> Any:
        return resolve(self.target)


@dataclass(frozen=True)
class LayoutKind:
    """A navigation floor-plan generator: ``make(rng, params) -> Layout`` and its parameters."""

    name: str
    make: str
    params: str  # a dataclass of the generator's parameters


@dataclass(frozen=True)
class RobotKind:
    """An arm for tabletop scenes (``robot.name``): its record, a
    :class:`datagen.robot_specs.RobotSpec`, referenced as ``"module:attribute"``."""

    name: str
    summary: str  # one line, shown in docs/robots.md
    spec: str

    def load(self):
        return resolve(self.spec)


@dataclass(frozen=True)
class LibrarySource:
    """A source of the library of real appearance (``photos.sources``, ``datagen library``):
    its record, a :class:`datagen.library.sources.Source`, referenced as ``"module:attribute"``."""

    name: str
    summary: str  # one line, shown by `datagen library list` and in docs/photo-library.md
    spec: str

    def load(self):
        return resolve(self.spec)


FAMILIES: Registry[SceneFamily] = Registry(
    "scene family",
    "datagen.families",
    [
        SceneFamily(
            "grasp_tabletop",
            "annotated frames of a Panda before a tray of objects",
            produce="datagen.scenes.grasp_tabletop:produce",
            classes="datagen.worlds.class_names:grasp_classes",
            world="tabletop",
        ),
        SceneFamily(
            "grasp_attempts",
            "physically executed grasps with success labels",
            produce="datagen.scenes.grasp_attempts:produce",
            classes="datagen.worlds.class_names:grasp_classes",
            section="campaign",
            world="tabletop",
            finish="datagen.scenes.grasp_attempts:campaign_summary",
            episodes=True,
        ),
        SceneFamily(
            "navigation",
            "Fetch driving expert paths through rooms, corridors and mazes",
            produce="datagen.scenes.navigation_fleet:produce",
            classes="datagen.worlds.class_names:navigation_classes",
            section="navigation",
            metadata_formats=("datagen.nav_episode/1", "datagen.nav_fleet/1"),
            world="floorplan",
            episodes=True,
        ),
        SceneFamily(
            "aerial",
            "quadrotors flying minimum-snap expert trajectories through 3-D corridors, mazes and rooms",
            produce="datagen.scenes.aerial_episodes:produce",
            classes="datagen.worlds.class_names:aerial_classes",
            section="aerial",
            metadata_formats=("datagen.aerial_episode/1",),
            world="volume",
            episodes=True,
        ),
    ],
)

METADATA_FORMATS: Registry[MetadataFormat] = Registry(
    "metadata format",
    "datagen.metadata_formats",
    [
        MetadataFormat(
            "datagen.sample/1",
            "the cameras of one scene, each a labelled view; a grasp attempt's record and film",
            "datagen.formats.frames",
        ),
        MetadataFormat(
            "datagen.nav_episode/1",
            "a ground robot's episode: its camera's frames over time, its path and map",
            "datagen.formats.nav_episode",
            noun="episodes",
        ),
        MetadataFormat(
            "datagen.nav_fleet/1",
            "ground robots sharing a floor plan: each robot's camera over time",
            "datagen.formats.nav_fleet",
            noun="episodes",
        ),
        MetadataFormat(
            "datagen.aerial_episode/1",
            "quadrotors flying one volume: each drone's cameras over time, flow, IMU and poses",
            "datagen.formats.aerial_episode",
            noun="episodes",
        ),
    ],
)

SAMPLERS: Registry[Plugin] = Registry(
    "grasp sampler",
    "datagen.samplers",
    [
        Plugin("antipodal", "datagen.grasping.samplers.antipodal:AntipodalSampler"),
        Plugin("random", "datagen.grasping.samplers.random_pose:RandomSampler"),
        Plugin("learned", "datagen.grasping.samplers.learned:LearnedSampler"),
    ],
)

# webdataset shards are the store every build writes; these are exported from them
EXPORTS: Registry[ExportFormat] = Registry(
    "export format",
    "datagen.exports",
    [
        ExportFormat("coco", "coco", "datagen.exports.coco:export"),
        ExportFormat("hdf5", "episodes.h5", "datagen.exports.hdf5:export"),
        ExportFormat("pointcloud", "pointclouds", "datagen.exports.pointcloud:export"),
        ExportFormat("usd", "usd", "datagen.exports.usd:export", worlds=("tabletop",)),
        ExportFormat("lerobot", "lerobot", "datagen.exports.lerobot:export", episodes=True),
        ExportFormat("robomimic", "robomimic", "datagen.exports.robomimic:export", episodes=True),
        ExportFormat("bop", "bop", "datagen.exports.bop:export", worlds=("tabletop",)),
        ExportFormat("yolo", "yolo", "datagen.exports.yolo:export"),
    ],
)
STORE = "webdataset"

EXECUTORS: Registry[Plugin] = Registry(
    "executor",
    "datagen.executors",
    [
        Plugin("local", "datagen.pipeline.executors.local_processes:LocalExecutor"),
        Plugin("ray", "datagen.pipeline.executors.ray_actors:RayExecutor"),
    ],
)

LAYOUTS: Registry[LayoutKind] = Registry(
    "layout family",
    "datagen.layouts",
    [
        LayoutKind(
            "rooms", "datagen.navigation.layouts:rooms", "datagen.navigation.layouts:RoomsParams"
        ),
        LayoutKind(
            "corridor",
            "datagen.navigation.layouts:corridor",
            "datagen.navigation.layouts:CorridorParams",
        ),
        LayoutKind(
            "maze", "datagen.navigation.layouts:maze", "datagen.navigation.layouts:MazeParams"
        ),
        LayoutKind(
            "plus_maze",
            "datagen.navigation.layouts:plus_maze",
            "datagen.navigation.layouts:PlusMazeParams",
        ),
    ],
)

ROBOTS: Registry[RobotKind] = Registry(
    "robot",
    "datagen.robots",
    [
        RobotKind(
            "panda",
            "Franka Emika Panda with its hand (ManiSkill's panda_v2)",
            "datagen.robot_specs.panda:PANDA",
        ),
        RobotKind(
            "iiwa14",
            "KUKA LBR iiwa 14 R820 with the Franka hand",
            "datagen.robot_specs.iiwa14:IIWA14",
        ),
        RobotKind(
            "xarm7",
            "UFACTORY xArm7 with the Franka hand (ManiSkill's xarm7)",
            "datagen.robot_specs.xarm7:XARM7",
        ),
        RobotKind(
            "so100",
            "TheRobotStudio SO-100 low-cost arm with its jaw gripper (ManiSkill's so100)",
            "datagen.robot_specs.so100:SO100",
        ),
        RobotKind(
            "koch",
            "Koch v1.1 low-cost arm with its jaw gripper (ManiSkill's koch-v1.1)",
            "datagen.robot_specs.koch:KOCH",
        ),
    ],
)

LIBRARY_SOURCES: Registry[LibrarySource] = Registry(
    "library source",
    "datagen.library_sources",
    [
        LibrarySource(
            "mate-backgrounds",
            "12 nature photographs (Debian mate-backgrounds, GPL-2+)",
            "datagen.library.sources:MATE_BACKGROUNDS",
        ),
        LibrarySource(
            "ukui-wallpapers",
            "12 digital artworks (Debian ukui-wallpapers, CC-BY-SA-3.0)",
            "datagen.library.sources:UKUI_WALLPAPERS",
        ),
        LibrarySource(
            "robosuite-textures",
            "30 material pictures: wood, plaster, metal, brick, ... (robosuite wheel, MIT)",
            "datagen.library.sources:ROBOSUITE_TEXTURES",
        ),
        LibrarySource(
            "skimage-data",
            "10 photographs and material scans (scikit-image wheel, CC0 / public domain)",
            "datagen.library.sources:SKIMAGE_DATA",
        ),
        LibrarySource(
            "robosuite-objects",
            "6 household object meshes: bottle, bread, can, cereal, lemon, milk (robosuite wheel, MIT)",
            "datagen.library.sources:ROBOSUITE_OBJECTS",
        ),
    ],
)
