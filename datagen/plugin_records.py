"""The records of the plug-in tables (``datagen.registries``): what a scene family, a metadata
format, an export, a grasp sampler or an executor, a navigation layout, an arm, a ground robot, an
airframe and a library source are. Their code is referenced as ``"module:attribute"`` and imported when used.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from typing import Any

from datagen.errors import DatasetError
from datagen.records import ExportFunction
from datagen.registry import resolve


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

    def parts(self) -> tuple[Any, ...]:
        """The rules of the parts of its own (``PARTS``: ``datagen.dataset.part_rules.PartRule``
        s; none when it writes only the parts every sample may have)."""
        return tuple(getattr(importlib.import_module(self.module), "PARTS", ()))


@dataclass(frozen=True)
class ExportFormat:
    """A format exported from a finished dataset's shards (``output.formats``, ``--to``)."""

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
    :class:`datagen.robot_specs.RobotSpec` (with its summary), referenced as
    ``"module:attribute"``. The name is written here too so that reading a config imports no
    robot description; a test checks that it is the record's."""

    name: str
    spec: str

    def load(self):
        return resolve(self.spec)


@dataclass(frozen=True)
class GroundRobot:
    """A robot that drives floor plans (``navigation.robot``): everything that differs between
    Fetch and the car, in one record. Its code is referenced as ``"module:attribute"``: the
    expert's drive (simulator-free), its body in the SAPIEN world, its metadata record and, if it
    is painted, its parts' materials."""

    name: str
    summary: str  # one line, shown in docs/navigation.md
    # (cfg, path, start yaw, layout) -> (Trajectory, start yaw, the drive's parameters)
    drive: str
    # (config, scene, camera values, the episode's values) -> (body, its entities, its camera);
    # the body is an articulation whose first joints are x, y, yaw, or has set_base(x, y, yaw, steer)
    body: str
    describe: str  # (config, scene) -> the sample's "robot" record
    label: str = "robot"  # its semantic class (datagen.worlds.class_names.NAV_CLASSES)
    steers: bool = False  # its second command is a steering angle, shown by its front wheels
    # degrees off straight ahead its camera's view may reach (pitch + half the vertical field of
    # view) below (and above) so that it never sees itself: Fetch's head camera sees its base
    # from about 78 degrees down (rendered at 4:3, 2:1 and 3:5; tests/navigation); the car's
    # camera looks out ahead of every part of it (datagen/families/navigation/car.py): 90 either way
    view_limit_deg: float = 75.0
    view_limit_above: bool = False
    paint: str | None = None  # (rng, config) -> materials of its parts, from stream nav_<name>


@dataclass(frozen=True)
class Airframe:
    """A drone's frame (``aerial.airframe``), sized by the span drawn for each drone. Its code is
    referenced as ``"module:attribute"``: ``shape`` (span, metres) -> a shape with ``span``;
    ``parts`` (shape) -> {part: trimesh.Trimesh} in the body frame (x forward, y left, z up,
    origin at the centre of mass); ``mounts`` (shape, shift) -> {"forward": xyz, "down": xyz},
    where its cameras sit (metres; ``shift`` in [-1, 1] x [-1, 1] moves the forward camera
    within its randomisation). Its camera must see none of its own parts: the config checks the
    forward camera's tilt (``aerial.camera_pitch_deg``) against the quadrotor's pod."""

    name: str
    summary: str  # one line, shown in docs/aerial.md
    shape: str
    parts: str
    mounts: str
    paint: tuple[tuple[str, tuple[float, float]], ...]  # each part: the HSV value range it gets


@dataclass(frozen=True)
class LibrarySource:
    """A source of the library of real appearance (``photos.sources``, ``datagen library``):
    its record, a :class:`datagen.library.sources.Source`, referenced as ``"module:attribute"``."""

    name: str
    summary: str  # one line, shown by `datagen library list` and in docs/photo-library.md
    spec: str

    def load(self):
        return resolve(self.spec)
