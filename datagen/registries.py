"""Every name a user can choose, in one place: scene families, the metadata formats their
samples are written in, grasp samplers, export formats, executors, navigation layouts, arms,
ground robots and airframes.

Each table maps a name to a record whose code is referenced as ``"module:attribute"`` and
imported only when used, so that reading a config (or a dataset) never imports the simulator.
Config validation, CLI choices and the code that runs a choice all ask these tables; nothing
else lists the names. Adding a plug-in is one module plus one line here (docs/extending.md).

Installed packages may add entries through entry points in the groups ``datagen.families``,
``datagen.metadata_formats``, ``datagen.samplers``, ``datagen.exports``, ``datagen.executors``,
``datagen.layouts``, ``datagen.robots``, ``datagen.ground_robots`` and ``datagen.airframes``:
an entry point's object is the record itself (for example a :class:`SceneFamily`). They are
loaded the first time a table is read. A plug-in that cannot be used (its import fails, its
object is not a record of the table's kind, it has no name, or its name is a built-in's or an
earlier plug-in's) is skipped and reported once on the ``datagen.plugins`` logger; the table
stays usable, and choosing its name is an error that says why it failed to load.
"""

from __future__ import annotations

from typing import Any

from datagen.errors import DatasetError
from datagen.plugin_records import (
    Airframe,
    ExportFormat,
    GroundRobot,
    LayoutKind,
    LibrarySource,
    MetadataFormat,
    Plugin,
    RobotKind,
    SceneFamily,
)
from datagen.registry import Registry


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


FAMILIES: Registry[SceneFamily] = Registry(
    "scene family",
    "datagen.families",
    [
        SceneFamily(
            "grasp_tabletop",
            "annotated frames of a Panda before a tray of objects",
            produce="datagen.families.grasp_tabletop.produce:produce",
            classes="datagen.worlds.class_names:grasp_classes",
            world="tabletop",
        ),
        SceneFamily(
            "grasp_attempts",
            "physically executed grasps with success labels",
            produce="datagen.families.grasp_attempts.produce:produce",
            classes="datagen.worlds.class_names:grasp_classes",
            section="campaign",
            world="tabletop",
            finish="datagen.families.grasp_attempts.produce:campaign_summary",
            episodes=True,
        ),
        SceneFamily(
            "navigation",
            "Fetch driving expert paths through rooms, corridors and mazes",
            produce="datagen.families.navigation.produce:produce",
            classes="datagen.worlds.class_names:navigation_classes",
            section="navigation",
            metadata_formats=("datagen.nav_episode/1", "datagen.nav_fleet/1"),
            world="floorplan",
            episodes=True,
        ),
        SceneFamily(
            "aerial",
            "quadrotors flying minimum-snap expert trajectories through 3-D corridors, mazes and rooms",
            produce="datagen.families.aerial.produce:produce",
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
        Plugin("antipodal", "datagen.families.grasp_attempts.samplers.antipodal:AntipodalSampler"),
        Plugin("random", "datagen.families.grasp_attempts.samplers.random_pose:RandomSampler"),
        Plugin("learned", "datagen.families.grasp_attempts.samplers.learned:LearnedSampler"),
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
        Plugin("simulated", "datagen.pipeline.executors.simulated:SimulatedExecutor"),
    ],
)

LAYOUTS: Registry[LayoutKind] = Registry(
    "layout family",
    "datagen.layouts",
    [
        LayoutKind(
            "rooms", "datagen.floorplans.layouts:rooms", "datagen.floorplans.layouts:RoomsParams"
        ),
        LayoutKind(
            "corridor",
            "datagen.floorplans.layouts:corridor",
            "datagen.floorplans.layouts:CorridorParams",
        ),
        LayoutKind(
            "maze", "datagen.floorplans.layouts:maze", "datagen.floorplans.layouts:MazeParams"
        ),
        LayoutKind(
            "plus_maze",
            "datagen.floorplans.layouts:plus_maze",
            "datagen.floorplans.layouts:PlusMazeParams",
        ),
    ],
)

ROBOTS: Registry[RobotKind] = Registry(
    "robot",
    "datagen.robots",
    [
        RobotKind("panda", "datagen.robot_specs.panda:PANDA"),
        RobotKind("iiwa14", "datagen.robot_specs.iiwa14:IIWA14"),
        RobotKind("xarm7", "datagen.robot_specs.xarm7:XARM7"),
        RobotKind("so100", "datagen.robot_specs.so100:SO100"),
        RobotKind("koch", "datagen.robot_specs.koch:KOCH"),
    ],
)

GROUND_ROBOTS: Registry[GroundRobot] = Registry(
    "ground robot",
    "datagen.ground_robots",
    [
        GroundRobot(
            "fetch",
            "Fetch: a differential drive that turns on the spot (ManiSkill's Fetch)",
            drive="datagen.families.navigation.episode:differential_drive",
            body="datagen.families.navigation.world:fetch_body",
            describe="datagen.families.navigation.one_robot:fetch_record",
        ),
        GroundRobot(
            "car",
            "a car with Ackermann steering, its camera on a mast at the front",
            drive="datagen.families.navigation.episode:ackermann_drive",
            body="datagen.families.navigation.car:car_body",
            describe="datagen.families.navigation.one_robot:car_record",
            label="car",
            steers=True,
            view_limit_deg=90.0,
            view_limit_above=True,
            paint="datagen.families.navigation.values:car_paint",
        ),
    ],
)

AIRFRAMES: Registry[Airframe] = Registry(
    "airframe",
    "datagen.airframes",
    [
        Airframe(
            "quadrotor",
            "four rotors in an X, landing legs and a camera pod on a nose below the front rotors",
            shape="datagen.families.aerial.quadrotor:QuadrotorShape",
            parts="datagen.families.aerial.quadrotor:quadrotor_parts",
            mounts="datagen.families.aerial.quadrotor:camera_mounts",
            # dark frames, light or bright bodies, grey motors, translucent-looking rotors
            paint=(
                ("body", (0.3, 1.0)),
                ("arms", (0.05, 0.35)),
                ("motors", (0.2, 0.5)),
                ("rotors", (0.1, 0.6)),
                ("legs", (0.05, 0.4)),
                ("camera", (0.0, 0.2)),
            ),
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
