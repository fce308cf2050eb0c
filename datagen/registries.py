"""Every name a user can choose, in one place: scene families, grasp samplers, export formats,
executors, navigation layouts and robots.

Each table maps a name to a record whose code is referenced as ``"module:attribute"`` and
imported only when used, so that reading a config (or a dataset) never imports the simulator.
Config validation, CLI choices and the code that runs a choice all ask these tables; nothing
else lists the names. Adding a plug-in is one module plus one line here (docs/extending.md).

Installed packages may add entries through entry points in the groups ``datagen.families``,
``datagen.samplers``, ``datagen.exports``, ``datagen.executors``, ``datagen.layouts`` and
``datagen.robots``: an
entry point's object is the record itself (for example a :class:`SceneFamily`). They are
loaded the first time a table is read. A plug-in that cannot be used (its import fails, its
object is not a record of the table's kind, it has no name, or its name is a built-in's or an
earlier plug-in's) is skipped and reported once on the ``datagen.plugins`` logger; the table
stays usable, and choosing its name is an error that says why it failed to load.
"""

from __future__ import annotations

import importlib
import logging
import re
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from importlib import metadata
from typing import Any, Generic, Protocol, TypeVar

from datagen.errors import ConfigError
from datagen.records import ExportFunction


class _Named(Protocol):
    @property
    def name(self) -> str: ...


T = TypeVar("T", bound=_Named)
PLUGIN_LOG = logging.getLogger("datagen.plugins")  # one warning per plug-in skipped


def resolve(ref: str) -> Any:
    """``"package.module:attribute"`` -> the attribute, imported on first use."""
    module, _, attribute = ref.partition(":")
    return getattr(importlib.import_module(module), attribute)


@dataclass(frozen=True)
class SceneFamily:
    """A kind of sample a build makes (``scene:`` in the config)."""

    name: str
    summary: str  # one line, shown by `datagen build --help`
    produce: str  # (config, seed, index, attempt) -> datagen.sample.Sample
    classes: str  # (config) -> tuple of class names; a class's id is its position
    section: str | None = None  # the config section holding its own settings, if any
    metadata_format: str = "datagen.sample/1"  # how its samples describe their views
    world: str | None = None  # the world its scenes are built in, for exports that need it
    finish: str | None = None  # (out_dir, made, seconds) -> dict merged into the manifest
    episodes: bool = False  # its samples are episodes over time (datagen.exports.episodes)

    def produce_sample(self, config, seed: int, index: int, attempt: int = 0):
        return resolve(self.produce)(config, seed, index, attempt)

    def class_names(self, config) -> tuple[str, ...]:
        return tuple(resolve(self.classes)(config))


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


@dataclass(frozen=True)
class PluginFailure:
    """An entry point that was skipped: its name, its distribution and why."""

    name: str
    distribution: str  # "name version"
    reason: str

    def __str__(self) -> str:
        return _plugin(self.name, self.distribution)


def _plugin(entry_name: str, distribution: str) -> str:
    return f"plug-in {entry_name!r} (from distribution {distribution})"


class Registry(Mapping[str, T], Generic[T]):
    """A read-only name -> record table with the error message every chooser shares."""

    def __init__(self, kind: str, group: str, records: list[T]):
        self.kind, self.group = kind, group
        self.record_type = type(records[0])
        names = [r.name for r in records]
        if twice := sorted({n for n in names if names.count(n) > 1}):
            raise ValueError(f"{kind} registry: {', '.join(twice)} listed more than once")
        self._records = dict(zip(names, records, strict=True))
        self._builtins = frozenset(self._records)
        self._plugins_loaded = False
        self.failures: dict[str, PluginFailure] = {}  # entry point name -> why it was skipped

    def _load_plugins(self) -> None:
        if self._plugins_loaded:
            return
        self._plugins_loaded = True
        owners: dict[str, str] = {}  # a plug-in's record name -> its entry point's description
        for entry in _entry_points(self.group):
            distribution = _distribution(entry)
            try:
                record = self._plugin_record(entry, owners)
            except _Unusable as exc:
                failure = PluginFailure(entry.name, distribution, str(exc))
                self.failures.setdefault(entry.name, failure)
                PLUGIN_LOG.warning("%s skipped: %s", failure, failure.reason)
                continue
            self._records[record.name] = record
            owners[record.name] = _plugin(entry.name, distribution)

    def _plugin_record(self, entry: metadata.EntryPoint, owners: dict[str, str]) -> T:
        try:
            record = entry.load()
        except (Exception, SystemExit) as exc:  # a plug-in's import may raise anything
            raise _Unusable(f"loading {entry.value} raised {_one_line(exc)}") from None
        expected = self.record_type.__name__
        if not isinstance(record, self.record_type):
            raise _Unusable(f"{entry.value} is not a {expected} but a {type(record).__name__}")
        name = record.name
        if not isinstance(name, str) or not name.strip():
            raise _Unusable(f"{entry.value}: its {expected} has no name")
        if name in self._builtins:
            raise _Unusable(f"{entry.value} registers {self.kind} {name!r}, a built-in {self.kind}")
        if name in owners:
            raise _Unusable(
                f"{entry.value} registers {self.kind} {name!r}, already registered by {owners[name]}"
            )
        return record

    def __getitem__(self, name: str) -> T:
        self._load_plugins()
        return self._records[name]

    def __iter__(self) -> Iterator[str]:
        self._load_plugins()
        return iter(self._records)

    def __len__(self) -> int:
        self._load_plugins()
        return len(self._records)

    def names(self) -> list[str]:
        return list(self)

    def unknown(self, name: str) -> str:
        """Why ``name`` is not a choice: the choices, and the failure of a plug-in by that name."""
        text = f"expected one of {self.names()} ({self.kind}), got {name!r}"
        failure = self.failures.get(name)
        return f"{text}; {failure} failed to load: {failure.reason}" if failure else text

    def check(self, name: str, where: str) -> T:
        """The record of ``name``, or a ConfigError naming ``where`` and the choices."""
        if name not in self:
            raise ConfigError(f"{where}: {self.unknown(name)}")
        return self[name]


class _Unusable(Exception):
    """An entry point that cannot be registered; the text says why."""


def _one_line(exc: BaseException) -> str:
    text = " ".join(f"{type(exc).__name__}: {exc}".split())
    return text if len(text) <= 300 else text[:297] + "..."


def _distribution(entry: metadata.EntryPoint) -> str:
    dist = getattr(entry, "dist", None)
    return f"{dist.name} {dist.version}" if dist is not None else "unknown"


_reported_distributions: set[str] = set()


def _entry_points(group: str) -> list[metadata.EntryPoint]:
    """The group's entry points. Where one installed distribution's entry_points.txt cannot be
    parsed (``importlib.metadata`` then fails for all), that distribution is reported once and
    the others' are read one by one."""
    try:
        return list(metadata.entry_points(group=group))
    except Exception:  # a malformed entry_points.txt anywhere; found below
        pass
    found, seen = [], set()
    for dist in metadata.distributions():
        name = dist.metadata["Name"] or "(no name)"
        if (normalised := re.sub(r"[-_.]+", "-", name).lower()) in seen:
            continue  # the first on sys.path wins, as in importlib.metadata.entry_points
        seen.add(normalised)
        try:
            found += list(dist.entry_points.select(group=group))
        except Exception as exc:  # the distribution's own metadata is broken
            if name not in _reported_distributions:
                _reported_distributions.add(name)
                PLUGIN_LOG.warning(
                    "plug-ins of distribution %s skipped: its entry_points.txt cannot be read (%s)",
                    name,
                    _one_line(exc),
                )
    return found


def choices(registry: Registry) -> Callable[[str], str]:
    """An argparse ``type`` that accepts the registry's names."""

    def parse(text: str) -> str:
        import argparse

        if text not in registry:
            raise argparse.ArgumentTypeError(registry.unknown(text))
        return text

    return parse


# --- the tables ----------------------------------------------------------------------------------
FAMILIES: Registry[SceneFamily] = Registry("scene family", "datagen.families", [
    SceneFamily(
        "grasp_tabletop", "annotated frames of a Panda before a tray of objects",
        produce="datagen.scenes.grasp_tabletop:produce", classes="datagen.worlds.class_names:grasp_classes",
        world="tabletop",
    ),
    SceneFamily(
        "grasp_attempts", "physically executed grasps with success labels",
        produce="datagen.scenes.grasp_attempts:produce", classes="datagen.worlds.class_names:grasp_classes",
        section="campaign", world="tabletop", finish="datagen.scenes.grasp_attempts:campaign_summary",
        episodes=True,
    ),
    SceneFamily(
        "navigation", "Fetch driving expert paths through rooms, corridors and mazes",
        produce="datagen.scenes.navigation_fleet:produce", classes="datagen.worlds.class_names:navigation_classes",
        section="navigation", metadata_format="datagen.nav_episode/1", world="floorplan",
        episodes=True,
    ),
    SceneFamily(
        "aerial", "quadrotors flying minimum-snap expert trajectories through 3-D corridors, mazes and rooms",
        produce="datagen.scenes.aerial_episodes:produce", classes="datagen.worlds.class_names:aerial_classes",
        section="aerial", metadata_format="datagen.aerial_episode/1", world="volume", episodes=True,
    ),
])  # fmt: skip

SAMPLERS: Registry[Plugin] = Registry("grasp sampler", "datagen.samplers", [
    Plugin("antipodal", "datagen.grasping.samplers.antipodal:AntipodalSampler"),
    Plugin("random", "datagen.grasping.samplers.random_pose:RandomSampler"),
    Plugin("learned", "datagen.grasping.samplers.learned:LearnedSampler"),
])  # fmt: skip

# webdataset shards are the store every build writes; these are exported from them
EXPORTS: Registry[ExportFormat] = Registry("export format", "datagen.exports", [
    ExportFormat("coco", "coco", "datagen.exports.coco:export"),
    ExportFormat("hdf5", "episodes.h5", "datagen.exports.hdf5:export"),
    ExportFormat("pointcloud", "pointclouds", "datagen.exports.pointcloud:export"),
    ExportFormat("usd", "usd", "datagen.exports.usd:export", worlds=("tabletop",)),
    ExportFormat("lerobot", "lerobot", "datagen.exports.lerobot:export", episodes=True),
    ExportFormat("robomimic", "robomimic", "datagen.exports.robomimic:export", episodes=True),
    ExportFormat("bop", "bop", "datagen.exports.bop:export", worlds=("tabletop",)),
    ExportFormat("yolo", "yolo", "datagen.exports.yolo:export"),
])  # fmt: skip
STORE = "webdataset"

EXECUTORS: Registry[Plugin] = Registry("executor", "datagen.executors", [
    Plugin("local", "datagen.pipeline.executors.local_processes:LocalExecutor"),
    Plugin("ray", "datagen.pipeline.executors.ray_actors:RayExecutor"),
])  # fmt: skip

LAYOUTS: Registry[LayoutKind] = Registry("layout family", "datagen.layouts", [
    LayoutKind("rooms", "datagen.navigation.layouts:rooms", "datagen.navigation.layouts:RoomsParams"),
    LayoutKind("corridor", "datagen.navigation.layouts:corridor", "datagen.navigation.layouts:CorridorParams"),
    LayoutKind("maze", "datagen.navigation.layouts:maze", "datagen.navigation.layouts:MazeParams"),
    LayoutKind("plus_maze", "datagen.navigation.layouts:plus_maze", "datagen.navigation.layouts:PlusMazeParams"),
])  # fmt: skip

ROBOTS: Registry[RobotKind] = Registry("robot", "datagen.robots", [
    RobotKind("panda", "Franka Emika Panda with its hand (ManiSkill's panda_v2)", "datagen.robot_specs.panda:PANDA"),
    RobotKind("iiwa14", "KUKA LBR iiwa 14 R820 with the Franka hand", "datagen.robot_specs.iiwa14:IIWA14"),
    RobotKind("xarm7", "UFACTORY xArm7 with the Franka hand (ManiSkill's xarm7)", "datagen.robot_specs.xarm7:XARM7"),
    RobotKind("so100", "TheRobotStudio SO-100 low-cost arm with its jaw gripper (ManiSkill's so100)", "datagen.robot_specs.so100:SO100"),
    RobotKind("koch", "Koch v1.1 low-cost arm with its jaw gripper (ManiSkill's koch-v1.1)", "datagen.robot_specs.koch:KOCH"),
])  # fmt: skip

LIBRARY_SOURCES: Registry[LibrarySource] = Registry("library source", "datagen.library_sources", [
    LibrarySource("mate-backgrounds", "12 nature photographs (Debian mate-backgrounds, GPL-2+)", "datagen.library.sources:MATE_BACKGROUNDS"),
    LibrarySource("ukui-wallpapers", "12 digital artworks (Debian ukui-wallpapers, CC-BY-SA-3.0)", "datagen.library.sources:UKUI_WALLPAPERS"),
    LibrarySource("robosuite-textures", "30 material pictures: wood, plaster, metal, brick, ... (robosuite wheel, MIT)", "datagen.library.sources:ROBOSUITE_TEXTURES"),
    LibrarySource("skimage-data", "10 photographs and material scans (scikit-image wheel, CC0 / public domain)", "datagen.library.sources:SKIMAGE_DATA"),
    LibrarySource("robosuite-objects", "6 household object meshes: bottle, bread, can, cereal, lemon, milk (robosuite wheel, MIT)", "datagen.library.sources:ROBOSUITE_OBJECTS"),
])  # fmt: skip
