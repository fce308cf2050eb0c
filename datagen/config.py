"""Build configuration: strict, versioned, every field with its unit.

A YAML file is turned into nested frozen dataclasses by ``dacite`` in strict mode (unknown keys
fail), then every range is checked. Every error names the file, the dotted key and what was
expected, and is raised as :class:`ConfigError` for the CLI to print without a traceback.
"""

from __future__ import annotations

import dataclasses
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import dacite
import yaml

from datagen.errors import ConfigError

CONFIG_VERSION = 1
SHAPE_FAMILIES = ("box", "cylinder", "sphere", "capsule", "convex", "compound")
SCENES = ("grasp_tabletop", "grasp_attempts", "navigation")
NAV_FAMILIES = ("rooms", "corridor", "maze")
GRASP_SAMPLERS = ("antipodal", "random")
SINKS = (
    "webdataset",
    "coco",
    "hdf5",
    "pointcloud",
    "usd",
)  # webdataset is the store the others are exported from


def _range(lo: float, hi: float, doc: str) -> Any:
    return {"min": lo, "max": hi, "doc": doc}


@dataclass(frozen=True)
class RenderConfig:
    width: int = field(default=640, metadata=_range(16, 4096, "image width, pixels"))
    height: int = field(default=480, metadata=_range(16, 4096, "image height, pixels"))
    wrist_camera: bool = False
    near: float = field(default=0.05, metadata=_range(0.001, 10.0, "near clip plane, metres"))
    far: float = field(default=5.0, metadata=_range(0.1, 100.0, "far clip plane, metres"))
    shadow_map_size: int = field(default=1024, metadata=_range(128, 8192, "pixels"))


@dataclass(frozen=True)
class ObjectsConfig:
    count: tuple[int, int] = field(default=(3, 12), metadata=_range(1, 32, "objects per scene"))
    families: tuple[str, ...] = SHAPE_FAMILIES
    source: str = "procedural"  # or "folder": users' meshes from assets_dir
    assets_dir: str = ""  # DIR/<class>/<mesh>; relative to the config file
    size: tuple[float, float] = field(
        default=(0.045, 0.1), metadata=_range(0.005, 0.5, "largest extent of an object, metres")
    )
    density: tuple[float, float] = field(
        default=(200.0, 1200.0), metadata=_range(1.0, 20000.0, "kg/m^3")
    )
    friction: tuple[float, float] = field(
        default=(0.3, 1.0), metadata=_range(0.0, 2.0, "Coulomb coefficient")
    )
    restitution: tuple[float, float] = field(
        default=(0.0, 0.1), metadata=_range(0.0, 1.0, "coefficient")
    )
    drop_height: tuple[float, float] = field(
        default=(0.03, 0.25), metadata=_range(0.0, 1.0, "metres above the tray floor")
    )


@dataclass(frozen=True)
class MaterialsConfig:
    roughness: tuple[float, float] = field(default=(0.1, 0.9), metadata=_range(0.0, 1.0, ""))
    metallic: tuple[float, float] = field(default=(0.0, 0.5), metadata=_range(0.0, 1.0, ""))
    saturation: tuple[float, float] = field(
        default=(0.3, 1.0), metadata=_range(0.0, 1.0, "HSV saturation of object colours")
    )
    value: tuple[float, float] = field(
        default=(0.35, 1.0), metadata=_range(0.0, 1.0, "HSV value of object colours")
    )


@dataclass(frozen=True)
class LightingConfig:
    ambient: tuple[float, float] = field(
        default=(0.15, 0.45), metadata=_range(0.0, 2.0, "ambient level")
    )
    lights: tuple[int, int] = field(default=(1, 3), metadata=_range(0, 8, "number of lights"))
    intensity: tuple[float, float] = field(
        default=(0.6, 2.0), metadata=_range(0.0, 20.0, "directional light radiance")
    )
    elevation_deg: tuple[float, float] = field(
        default=(35.0, 85.0), metadata=_range(5.0, 90.0, "light elevation above horizon, degrees")
    )
    colour_temperature_jitter: float = field(
        default=0.15, metadata=_range(0.0, 1.0, "max per-channel colour deviation")
    )
    shadows: bool = True


@dataclass(frozen=True)
class CameraConfig:
    eye: tuple[float, float, float] = (-0.22, 0.28, 1.22)
    target: tuple[float, float, float] = (0.08, 0.0, 0.76)
    eye_jitter: float = field(default=0.05, metadata=_range(0.0, 1.0, "metres, per axis"))
    target_jitter: float = field(default=0.03, metadata=_range(0.0, 1.0, "metres, per axis"))
    fovy_deg: tuple[float, float] = field(
        default=(42.0, 52.0), metadata=_range(5.0, 150.0, "vertical field of view, degrees")
    )


@dataclass(frozen=True)
class RobotConfig:
    joint_jitter: float = field(
        default=0.15, metadata=_range(0.0, 1.0, "radians around the ready pose, per arm joint")
    )


@dataclass(frozen=True)
class PhysicsConfig:
    timestep: float = field(default=0.005, metadata=_range(0.0005, 0.05, "seconds"))
    settle_time: float = field(
        default=1.5, metadata=_range(0.0, 30.0, "simulated seconds before rendering")
    )


@dataclass(frozen=True)
class OutputConfig:
    shard_size: int = field(default=200, metadata=_range(1, 1_000_000, "samples per tar shard"))
    sinks: tuple[str, ...] = ("webdataset",)


@dataclass(frozen=True)
class ExecutorConfig:
    recycle_after: int = field(
        default=2000,
        metadata=_range(
            0, 10**9, "samples a worker makes before a fresh one replaces it; 0 = never"
        ),
    )
    cpus_per_worker: float = field(
        default=1.0, metadata=_range(0.0, 256.0, "CPUs a Ray worker actor reserves")
    )
    gpus_per_worker: float = field(
        default=0.0,
        metadata=_range(0.0, 16.0, "GPUs a Ray worker actor reserves (SAPIEN renders on it)"),
    )


@dataclass(frozen=True)
class TransferConfig:
    window: int = field(default=8, metadata=_range(1, 256, "in-flight samples per worker"))
    max_sample_mb: float = field(default=32.0, metadata=_range(0.1, 256.0, "MiB per sample"))
    ack_timeout_s: float = field(
        default=60.0,
        metadata=_range(1.0, 86400.0, "seconds from publish to the writer's ack before re-issue"),
    )


@dataclass(frozen=True)
class CampaignConfig:
    """Grasp-attempt campaigns (scene ``grasp_attempts``): one physically executed grasp per sample."""

    sampler: str = "antipodal"
    sampler_tries: int = field(
        default=200, metadata=_range(1, 100000, "candidates tried per attempt")
    )
    friction: float = field(
        default=0.5,
        metadata=_range(0.05, 2.0, "friction coefficient the antipodal sampler assumes"),
    )
    pre_grasp_distance: float = field(
        default=0.1, metadata=_range(0.0, 0.5, "metres back along the approach")
    )
    lift_height: float = field(default=0.1, metadata=_range(0.01, 0.5, "metres"))
    hold_time: float = field(default=1.0, metadata=_range(0.0, 10.0, "simulated seconds"))
    post_grasp_frame: bool = True


@dataclass(frozen=True)
class NavigationConfig:
    """Navigation episodes (scene ``navigation``): Fetch drives from a start to a goal."""

    family: str = "rooms"
    clutter: tuple[int, int] | None = field(
        default=None, metadata=_range(0, 40, "obstacles placed in the layout (None: per family)")
    )
    clutter_size: tuple[float, float] = field(
        default=(0.3, 0.7), metadata=_range(0.05, 2.0, "obstacle footprint side, metres")
    )
    obstacle_height: tuple[float, float] = field(
        default=(0.3, 1.2), metadata=_range(0.02, 3.0, "metres")
    )
    wall_height: tuple[float, float] = field(
        default=(2.3, 2.8), metadata=_range(0.5, 5.0, "metres")
    )
    robot_radius: float = field(
        default=0.3, metadata=_range(0.05, 1.0, "footprint disk for planning and collisions, m")
    )
    planning_margin: float = field(
        default=0.1, metadata=_range(0.0, 0.5, "clearance added to the radius when planning, m")
    )
    min_goal_distance: float = field(
        default=3.0, metadata=_range(0.0, 50.0, "straight-line start-goal distance, metres")
    )
    control_rate_hz: float = field(default=10.0, metadata=_range(1.0, 100.0, "Hz"))
    frame_rate_hz: float = field(
        default=2.0, metadata=_range(0.01, 100.0, "rendered frames per simulated second")
    )
    max_linear: float = field(default=0.6, metadata=_range(0.05, 3.0, "m/s"))
    max_angular: float = field(default=1.5, metadata=_range(0.1, 6.0, "rad/s"))
    lookahead: float = field(default=0.3, metadata=_range(0.05, 3.0, "pure-pursuit lookahead, m"))
    torso_lift: tuple[float, float] = field(
        default=(0.0, 0.386),
        metadata=_range(0.0, 0.386, "Fetch torso lift, metres (camera at about 1.03-1.42 m)"),
    )
    camera_pitch_deg: tuple[float, float] = field(
        default=(5.0, 30.0), metadata=_range(-60.0, 85.0, "head tilt below horizontal, degrees")
    )
    camera_fovy_deg: tuple[float, float] = field(
        default=(50.0, 70.0), metadata=_range(10.0, 150.0, "vertical field of view, degrees")
    )


@dataclass(frozen=True)
class BuildConfig:
    version: int = CONFIG_VERSION
    scene: str = "grasp_tabletop"
    num_samples: int = field(default=100, metadata=_range(1, 10**9 - 1, "samples"))
    seed: int = field(default=0, metadata=_range(0, 2**63 - 1, "build seed"))
    render: RenderConfig = RenderConfig()
    objects: ObjectsConfig = ObjectsConfig()
    materials: MaterialsConfig = MaterialsConfig()
    lighting: LightingConfig = LightingConfig()
    camera: CameraConfig = CameraConfig()
    robot: RobotConfig = RobotConfig()
    physics: PhysicsConfig = PhysicsConfig()
    output: OutputConfig = OutputConfig()
    transfer: TransferConfig = TransferConfig()
    executor: ExecutorConfig = ExecutorConfig()
    campaign: CampaignConfig = CampaignConfig()
    navigation: NavigationConfig = NavigationConfig()

    def to_dict(self) -> dict[str, Any]:
        return _jsonable(dataclasses.asdict(self))

    def replace(self, **changes: Any) -> BuildConfig:
        return dataclasses.replace(self, **changes)


def _jsonable(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: _jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_jsonable(v) for v in value]
    return value


def load_config(path: str | os.PathLike) -> BuildConfig:
    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"{path}: no such config file")
    try:
        data = yaml.safe_load(path.read_text())
    except yaml.YAMLError as exc:
        raise ConfigError(f"{path}: not valid YAML: {exc}") from None
    return config_from_dict(data if data is not None else {}, source=str(path))


def config_from_dict(data: Any, source: str = "<config>") -> BuildConfig:
    if not isinstance(data, dict):
        raise ConfigError(f"{source}: expected a mapping of keys at the top level")
    version = data.get("version", CONFIG_VERSION)
    if version != CONFIG_VERSION:
        raise ConfigError(
            f"{source}: version: this datagen reads config version {CONFIG_VERSION}, got {version!r}"
        )
    _check_unknown_keys(BuildConfig, data, source, prefix="")
    try:
        config = dacite.from_dict(
            BuildConfig, data, config=dacite.Config(strict=True, cast=[tuple])
        )
    except dacite.UnexpectedDataError as exc:
        keys = ", ".join(sorted(exc.keys))
        raise ConfigError(f"{source}: unknown key(s) {keys} (see configs/README.md)") from None
    except dacite.WrongTypeError as exc:
        raise ConfigError(
            f"{source}: {exc.field_path}: expected {_type_name(exc.field_type)}, got {exc.value!r}"
        ) from None
    except dacite.DaciteError as exc:
        raise ConfigError(f"{source}: {exc}") from None
    if config.objects.assets_dir and not Path(config.objects.assets_dir).is_absolute():
        base = Path(source).parent if Path(source).is_file() else Path.cwd()
        objects = dataclasses.replace(
            config.objects, assets_dir=str((base / config.objects.assets_dir).resolve())
        )
        config = dataclasses.replace(config, objects=objects)
    _check_ranges(config, source, prefix="")
    _check_semantics(config, source)
    return config


def _check_unknown_keys(cls: type, data: dict[str, Any], source: str, prefix: str) -> None:
    """dacite reports unknown keys without their section; this names the full dotted key."""
    fields = {f.name: f for f in dataclasses.fields(cls)}
    unknown = [f"{prefix}{k}" for k in data if k not in fields]
    if unknown:
        expected = ", ".join(fields)
        raise ConfigError(
            f"{source}: unknown key(s) {', '.join(unknown)}; expected keys here: {expected}"
        )
    for name, value in data.items():
        field_type = cls.__annotations__.get(name)
        nested = globals().get(field_type) if isinstance(field_type, str) else None
        if nested is not None and dataclasses.is_dataclass(nested):
            if not isinstance(value, dict):
                raise ConfigError(
                    f"{source}: {prefix}{name}: expected a mapping of keys, got {value!r}"
                )
            _check_unknown_keys(nested, value, source, prefix=f"{prefix}{name}.")


def _type_name(tp: Any) -> str:
    return getattr(tp, "__name__", None) or str(tp).replace("typing.", "")


def _check_ranges(obj: Any, source: str, prefix: str) -> None:
    for f in dataclasses.fields(obj):
        key = f"{prefix}{f.name}"
        value = getattr(obj, f.name)
        if dataclasses.is_dataclass(value):
            _check_ranges(value, source, prefix=f"{key}.")
            continue
        if "min" not in f.metadata or value is None:
            continue
        lo, hi, doc = f.metadata["min"], f.metadata["max"], f.metadata["doc"]
        values = value if isinstance(value, tuple) else (value,)
        unit = f" ({doc})" if doc else ""
        for v in values:
            if isinstance(v, bool) or not lo <= v <= hi:
                raise ConfigError(
                    f"{source}: {key}: expected values in [{lo}, {hi}]{unit}, got {v!r}"
                )
        if isinstance(value, tuple) and len(value) == 2 and value[0] > value[1]:
            raise ConfigError(
                f"{source}: {key}: expected [min, max] with min <= max, got {list(value)}"
            )


def _check_semantics(config: BuildConfig, source: str) -> None:
    if config.scene not in SCENES:
        raise ConfigError(f"{source}: scene: expected one of {list(SCENES)}, got {config.scene!r}")
    objects = config.objects
    if objects.source not in ("procedural", "folder"):
        raise ConfigError(
            f"{source}: objects.source: expected 'procedural' or 'folder', got {objects.source!r}"
        )
    if objects.source == "folder" and not Path(objects.assets_dir).is_dir():
        raise ConfigError(
            f"{source}: objects.assets_dir: expected a folder of DIR/<class>/<mesh> files "
            f"(objects.source is 'folder'), got {objects.assets_dir!r}"
        )
    unknown = [f for f in config.objects.families if f not in SHAPE_FAMILIES]
    if unknown or not config.objects.families:
        raise ConfigError(
            f"{source}: objects.families: expected a non-empty list from {list(SHAPE_FAMILIES)}, "
            f"got {list(config.objects.families)}"
        )
    if config.campaign.sampler not in GRASP_SAMPLERS:
        raise ConfigError(
            f"{source}: campaign.sampler: expected one of {list(GRASP_SAMPLERS)}, got {config.campaign.sampler!r}"
        )
    sinks = list(config.output.sinks)
    if (
        "webdataset" not in sinks
        or any(s not in SINKS for s in sinks)
        or len(set(sinks)) != len(sinks)
    ):
        raise ConfigError(
            f"{source}: output.sinks: expected distinct names from {list(SINKS)} including "
            f"'webdataset' (the store the other formats are exported from), got {sinks}"
        )
    if "usd" in sinks and config.scene == "navigation":
        raise ConfigError(
            f"{source}: output.sinks: 'usd' exports grasp scenes only, not scene 'navigation'"
        )
    if config.navigation.family not in NAV_FAMILIES:
        raise ConfigError(
            f"{source}: navigation.family: expected one of {list(NAV_FAMILIES)}, "
            f"got {config.navigation.family!r}"
        )
    if config.render.near >= config.render.far:
        raise ConfigError(f"{source}: render.near: must be smaller than render.far")
