"""Every name a user can choose, in one place: scene families, grasp samplers, export formats,
executors and navigation layouts.

Each table maps a name to a record whose code is referenced as ``"module:attribute"`` and
imported only when used, so that reading a config (or a dataset) never imports the simulator.
Config validation, CLI choices and the code that runs a choice all ask these tables; nothing
else lists the names. Adding a plug-in is one module plus one line here (docs/extending.md).

Installed packages may add entries through entry points in the groups ``datagen.families``,
``datagen.samplers``, ``datagen.exports``, ``datagen.executors`` and ``datagen.layouts``: an
entry point's object is the record itself (for example a :class:`SceneFamily`).
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from importlib import metadata
from typing import Any, Generic, TypeVar

from datagen.errors import ConfigError

T = TypeVar("T")


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

    def produce_sample(self, config, seed: int, index: int, attempt: int = 0):
        return resolve(self.produce)(config, seed, index, attempt)

    def class_names(self, config) -> tuple[str, ...]:
        return tuple(resolve(self.classes)(config))


@dataclass(frozen=True)
class ExportFormat:
    """A format exported from a finished dataset's shards (``output.sinks``, ``--to``)."""

    name: str
    path: str  # file or folder in the dataset directory
    export: str  # (dataset, manifest, out, on_progress) -> list of files written
    worlds: tuple[str, ...] | None = None  # the scene worlds it can describe; None: any


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


class Registry(Mapping[str, T], Generic[T]):
    """A read-only name -> record table with the error message every chooser shares."""

    def __init__(self, kind: str, group: str, records: list[T]):
        self.kind, self.group = kind, group
        self._records = {r.name: r for r in records}  # type: ignore[attr-defined]
        self._plugins_loaded = False

    def _load_plugins(self) -> None:
        if self._plugins_loaded:
            return
        self._plugins_loaded = True
        for entry in metadata.entry_points(group=self.group):
            record = entry.load()
            if record.name in self._records:
                raise ConfigError(
                    f"entry point {entry.value} ({self.group}) registers {self.kind} "
                    f"{record.name!r}, which is already registered"
                )
            self._records[record.name] = record

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

    def check(self, name: str, where: str) -> T:
        """The record of ``name``, or a ConfigError naming ``where`` and the choices."""
        if name not in self:
            raise ConfigError(
                f"{where}: expected one of {self.names()} ({self.kind}), got {name!r}"
            )
        return self[name]


def choices(registry: Registry) -> Callable[[str], str]:
    """An argparse ``type`` that accepts the registry's names."""

    def parse(text: str) -> str:
        import argparse

        if text not in registry:
            raise argparse.ArgumentTypeError(
                f"expected one of {registry.names()} ({registry.kind}), got {text!r}"
            )
        return text

    return parse


# --- the tables ----------------------------------------------------------------------------------
FAMILIES: Registry[SceneFamily] = Registry("scene family", "datagen.families", [
    SceneFamily(
        "grasp_tabletop", "annotated frames of a Panda before a tray of objects",
        produce="datagen.scenes.grasp_tabletop:produce", classes="datagen.worlds.tabletop:grasp_classes",
        world="tabletop",
    ),
    SceneFamily(
        "grasp_attempts", "physically executed grasps with success labels",
        produce="datagen.scenes.grasp_attempts:produce", classes="datagen.worlds.tabletop:grasp_classes",
        section="campaign", world="tabletop", finish="datagen.scenes.grasp_attempts:campaign_summary",
    ),
    SceneFamily(
        "navigation", "Fetch driving expert paths through rooms, corridors and mazes",
        produce="datagen.scenes.navigation:produce", classes="datagen.worlds.floorplan:navigation_classes",
        section="navigation", metadata_format="datagen.nav_episode/1", world="floorplan",
    ),
])  # fmt: skip

SAMPLERS: Registry[Plugin] = Registry("grasp sampler", "datagen.samplers", [
    Plugin("antipodal", "datagen.grasping.samplers.antipodal:AntipodalSampler"),
    Plugin("random", "datagen.grasping.samplers.random_pose:RandomSampler"),
])  # fmt: skip

# webdataset shards are the store every build writes; these are exported from them
EXPORTS: Registry[ExportFormat] = Registry("export format", "datagen.exports", [
    ExportFormat("coco", "coco", "datagen.exports.coco:export"),
    ExportFormat("hdf5", "episodes.h5", "datagen.exports.hdf5:export"),
    ExportFormat("pointcloud", "pointclouds", "datagen.exports.pointcloud:export"),
    ExportFormat("usd", "usd", "datagen.exports.usd:export", worlds=("tabletop",)),
])  # fmt: skip
STORE = "webdataset"

EXECUTORS: Registry[Plugin] = Registry("executor", "datagen.executors", [
    Plugin("local", "datagen.build.executors.local_processes:LocalExecutor"),
    Plugin("ray", "datagen.build.executors.ray_actors:RayExecutor"),
])  # fmt: skip

LAYOUTS: Registry[LayoutKind] = Registry("layout family", "datagen.layouts", [
    LayoutKind("rooms", "datagen.navigation.layouts:rooms", "datagen.navigation.layouts:RoomsParams"),
    LayoutKind("corridor", "datagen.navigation.layouts:corridor", "datagen.navigation.layouts:CorridorParams"),
    LayoutKind("maze", "datagen.navigation.layouts:maze", "datagen.navigation.layouts:MazeParams"),
])  # fmt: skip
