"""Build configuration: strict, versioned, every field with its unit.

A YAML file is turned into nested frozen dataclasses by ``dacite`` in strict mode (unknown keys
fail), then every range is checked. Every error names the file, the dotted key and what was
expected, and is raised as :class:`ConfigError` for the CLI to print without a traceback.
"""

from __future__ import annotations

import dataclasses
import math
import os
import typing
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import dacite

from datagen.config.aerial import MAX_CAMERA_TOP_DEG, AerialConfig
from datagen.config.appearance import (
    BackgroundConfig,
    CameraEffectsConfig,
    DepthSensorConfig,
    DistractorsConfig,
    PhotosConfig,
)
from datagen.config.campaign import check_campaign_model
from datagen.config.pictures import check_photos, check_pictures, resolve_picture_folders
from datagen.config.robot import RobotConfig, robot_spec
from datagen.config.sections import (
    SAMPLE_ERROR_POLICIES,
    SHAPE_FAMILIES,
    BuildPolicyConfig,
    CameraConfig,
    CampaignConfig,
    ExecutorConfig,
    LightingConfig,
    MaterialsConfig,
    NavigationConfig,
    ObjectsConfig,
    OutputConfig,
    PhysicsConfig,
    RenderConfig,
    TransferConfig,
    ranged,
)
from datagen.config.shading import check_shader
from datagen.config.values import fits, shape, show, show_key
from datagen.config.versions import CONFIG_VERSION, as_current_version
from datagen.config.yaml_file import read_yaml
from datagen.errors import ConfigError
from datagen.registries import AIRFRAMES, EXPORTS, FAMILIES, GROUND_ROBOTS, LAYOUTS, SAMPLERS, STORE


@dataclass(frozen=True)
class BuildConfig:
    version: int = CONFIG_VERSION
    scene: str = "grasp_tabletop"
    num_samples: int = field(default=100, metadata=ranged(1, 10**9 - 1, "samples"))
    seed: int = field(default=0, metadata=ranged(0, 2**63 - 1, "build seed"))
    render: RenderConfig = field(default_factory=RenderConfig)
    objects: ObjectsConfig = field(default_factory=ObjectsConfig)
    materials: MaterialsConfig = field(default_factory=MaterialsConfig)
    lighting: LightingConfig = field(default_factory=LightingConfig)
    background: BackgroundConfig = field(default_factory=BackgroundConfig)
    distractors: DistractorsConfig = field(default_factory=DistractorsConfig)
    photos: PhotosConfig = field(default_factory=PhotosConfig)
    camera: CameraConfig = field(default_factory=CameraConfig)
    camera_effects: CameraEffectsConfig = field(default_factory=CameraEffectsConfig)
    depth_sensor: DepthSensorConfig = field(default_factory=DepthSensorConfig)
    robot: RobotConfig = field(default_factory=RobotConfig)
    physics: PhysicsConfig = field(default_factory=PhysicsConfig)
    output: OutputConfig = field(default_factory=OutputConfig)
    transfer: TransferConfig = field(default_factory=TransferConfig)
    executor: ExecutorConfig = field(default_factory=ExecutorConfig)
    campaign: CampaignConfig = field(default_factory=CampaignConfig)
    navigation: NavigationConfig = field(default_factory=NavigationConfig)
    aerial: AerialConfig = field(default_factory=AerialConfig)
    build: BuildPolicyConfig = field(default_factory=BuildPolicyConfig)

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
    data = read_yaml(path)
    return config_from_dict(data if data is not None else {}, source=str(path))


def config_from_dict(data: Any, source: str = "<config>") -> BuildConfig:
    if not isinstance(data, dict):
        raise ConfigError(
            f"{source}: expected a mapping of keys at the top level, got {show(data)}"
        )
    data = as_current_version(data, source)
    _check_keys_and_types(BuildConfig, data, source, prefix="")
    try:
        config = dacite.from_dict(
            BuildConfig, data, config=dacite.Config(strict=True, cast=[tuple])
        )
    except dacite.UnexpectedDataError as exc:
        keys = ", ".join(sorted(exc.keys))
        raise ConfigError(f"{source}: unknown key(s) {keys} (see configs/README.md)") from None
    except dacite.WrongTypeError as exc:
        raise ConfigError(
            f"{source}: {exc.field_path}: expected {shape(exc.field_type)}, got {show(exc.value)}"
        ) from None
    except dacite.DaciteError as exc:
        raise ConfigError(f"{source}: {exc}") from None
    if config.objects.assets_dir and not Path(config.objects.assets_dir).is_absolute():
        objects = dataclasses.replace(
            config.objects, assets_dir=_resolved(config.objects.assets_dir, source)
        )
        config = dataclasses.replace(config, objects=objects)
    urdf = config.robot.urdf
    if urdf.file and not Path(urdf.file).is_absolute():
        files = {
            k: _resolved(v, source, f"robot.urdf.{k}")
            for k in ("file", "srdf")
            if (v := getattr(urdf, k))
        }
        robot = dataclasses.replace(config.robot, urdf=dataclasses.replace(urdf, **files))
        config = dataclasses.replace(config, robot=robot)
    if config.campaign.model and not Path(config.campaign.model).is_absolute():
        model = _resolved(config.campaign.model, source, "campaign.model")
        campaign = dataclasses.replace(config.campaign, model=model)
        config = dataclasses.replace(config, campaign=campaign)
    config = resolve_picture_folders(config, source)
    _check_ranges(config, source, prefix="")
    _check_semantics(config, source)
    check_pictures(config, source)
    check_photos(config, source)
    return check_campaign_model(config, source)


def _resolved(assets_dir: str, source: str, key: str = "objects.assets_dir") -> str:
    """A path of the config (``objects.assets_dir``, ``robot.urdf.file``) relative to the config
    file (else to the working directory)."""
    try:
        base = Path(source).parent if Path(source).is_file() else Path.cwd()
        return str((base / assets_dir).resolve())
    except (OSError, RuntimeError, ValueError) as exc:  # too long, a symlink loop, ...
        raise ConfigError(f"{source}: {key}: not a usable path ({exc})") from None


def _check_keys_and_types(cls: type, data: dict[str, Any], source: str, prefix: str) -> None:
    """Names the full dotted key of an unknown key (dacite does not) and of a value of the wrong
    type or shape, saying what was expected, before dacite sees the data."""
    fields = {f.name: f for f in dataclasses.fields(cls)}
    unknown = [f"{prefix}{show_key(k)}" for k in data if k not in fields]
    if unknown:
        shown = ", ".join(unknown[:10]) + (f" and {len(unknown) - 10} more" if unknown[10:] else "")
        raise ConfigError(
            f"{source}: unknown key(s) {shown}; expected keys here: {', '.join(fields)}"
        )
    hints = typing.get_type_hints(cls)
    for name, value in data.items():
        tp, key = hints[name], f"{prefix}{name}"
        if isinstance(tp, type) and dataclasses.is_dataclass(tp):
            if not isinstance(value, dict):
                raise ConfigError(f"{source}: {key}: expected a mapping of keys, got {show(value)}")
            _check_keys_and_types(tp, value, source, prefix=f"{key}.")
        elif not fits(tp, value):
            expected = shape(tp, fields[name].default)
            if isinstance(value, str) and tp is str:
                expected = "a string without NUL characters"
            raise ConfigError(f"{source}: {key}: expected {expected}, got {show(value)}")


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
                    f"{source}: {key}: expected values in [{lo}, {hi}]{unit}, got {show(v)}"
                )
        if isinstance(value, tuple) and len(value) == 2 and value[0] > value[1]:
            raise ConfigError(
                f"{source}: {key}: expected [min, max] with min <= max, got {list(value)}"
            )


def _check_aerial_camera(config: BuildConfig, source: str) -> None:
    top = config.aerial.camera_pitch_deg[1] + config.aerial.camera_fovy_deg[1] / 2
    if top > MAX_CAMERA_TOP_DEG:
        raise ConfigError(
            f"{source}: aerial.camera_pitch_deg: the forward camera's view would reach {top:g} "
            f"degrees above the horizon (pitch {config.aerial.camera_pitch_deg[1]:g} + half of "
            f"aerial.camera_fovy_deg {config.aerial.camera_fovy_deg[1]:g}), where it sees its own "
            f"rotors; expected at most {MAX_CAMERA_TOP_DEG:g}"
        )


def _check_navigation(nav: NavigationConfig, source: str) -> None:
    GROUND_ROBOTS.check(nav.robot, f"{source}: navigation.robot")
    steps = nav.control_rate_hz / nav.frame_rate_hz  # control steps per frame
    if steps < 1 - 1e-9 or abs(steps - round(steps)) > 1e-9:
        raise ConfigError(
            f"{source}: navigation.frame_rate_hz: expected control_rate_hz "
            f"({nav.control_rate_hz:g}) divided by a whole number (frames every whole number of "
            f"control steps), got {nav.frame_rate_hz:g}"
        )
    _check_robot_view(nav, source)


def _check_robot_view(nav: NavigationConfig, source: str) -> None:
    """A robot's camera never sees the robot itself (its record's ``view_limit_deg``)."""
    robot = GROUND_ROBOTS[nav.robot]
    limit = robot.view_limit_deg
    if robot.view_limit_above:  # up or down
        pitch, where = max(map(abs, nav.camera_pitch_deg)), "off"
    else:  # down: the robot's base
        pitch, where = nav.camera_pitch_deg[1], "below"
    reach = pitch + nav.camera_fovy_deg[1] / 2
    if reach > limit:
        raise ConfigError(
            f"{source}: navigation.camera_pitch_deg: the {nav.robot} camera's view would reach "
            f"{reach:g} degrees {where} straight ahead (pitch {pitch:g} + half of "
            f"navigation.camera_fovy_deg {nav.camera_fovy_deg[1]:g}), where it sees the robot "
            f"itself; expected at most {limit:g}"
        )


def _check_semantics(config: BuildConfig, source: str) -> None:
    family = FAMILIES.check(config.scene, f"{source}: scene")
    objects = config.objects
    if objects.source not in ("procedural", "folder"):
        raise ConfigError(
            f"{source}: objects.source: expected 'procedural' or 'folder', got {objects.source!r}"
        )
    if objects.source == "folder" and not _is_dir(objects.assets_dir):
        raise ConfigError(
            f"{source}: objects.assets_dir: expected a folder of DIR/<class>/<mesh> files "
            f"(objects.source is 'folder'), got {objects.assets_dir!r}"
        )
    if objects.source == "folder":
        _check_mesh_sizes(objects.assets_dir, objects.max_mesh_faces, source)
    unknown = [f for f in config.objects.families if f not in SHAPE_FAMILIES]
    if unknown or not config.objects.families:
        raise ConfigError(
            f"{source}: objects.families: expected a non-empty list from {list(SHAPE_FAMILIES)}, "
            f"got {list(config.objects.families)}"
        )
    SAMPLERS.check(config.campaign.sampler, f"{source}: campaign.sampler")
    if family.world == "tabletop":
        robot_spec(config.robot, source)
    LAYOUTS.check(config.navigation.family, f"{source}: navigation.family")
    _check_navigation(config.navigation, source)
    LAYOUTS.check(config.aerial.family, f"{source}: aerial.family")
    AIRFRAMES.check(config.aerial.airframe, f"{source}: aerial.airframe")
    _check_aerial_camera(config, source)
    _check_formats(list(config.output.formats), family, source)
    if config.build.on_sample_error not in SAMPLE_ERROR_POLICIES:
        raise ConfigError(
            f"{source}: build.on_sample_error: expected one of {list(SAMPLE_ERROR_POLICIES)}, "
            f"got {config.build.on_sample_error!r}"
        )
    if config.render.near >= config.render.far:
        raise ConfigError(f"{source}: render.near: must be smaller than render.far")
    check_shader(config.render, config.scene, family.world, source)
    _check_camera(config.camera, source)
    _check_recording(config, source)
    if config.render.views > 1 and family.world != "tabletop":
        raise ConfigError(
            f"{source}: render.views: expected 1 for scene {config.scene!r} (several views per "
            f"scene are rendered by the tabletop scenes: grasp_tabletop, grasp_attempts), "
            f"got {config.render.views}"
        )


def _check_recording(config: BuildConfig, source: str) -> None:
    rate = 1.0 / config.physics.timestep  # physics steps per simulated second
    for key in ("record_hz", "frame_hz"):
        if getattr(config.campaign, key) > rate + 1e-9:
            raise ConfigError(
                f"{source}: campaign.{key}: expected at most the physics rate {rate:g} Hz "
                f"(1 / physics.timestep), got {getattr(config.campaign, key)}"
            )
    if config.campaign.frame_hz > 0 and config.campaign.record_hz <= 0:
        raise ConfigError(
            f"{source}: campaign.frame_hz: frames need campaign.record_hz > 0 (their times are "
            f"kept in trajectory.npz), got record_hz {config.campaign.record_hz}"
        )


def _check_camera(camera: CameraConfig, source: str) -> None:
    """The jittered eye must never reach the jittered target (the view direction would be
    undefined): each moves up to its jitter along each axis."""
    distance = math.dist(camera.eye, camera.target)
    needed = math.sqrt(3) * (camera.eye_jitter + camera.target_jitter)
    if distance <= needed:
        raise ConfigError(
            f"{source}: camera.eye: expected a point other than camera.target, farther from it "
            f"than the jitter reaches (sqrt(3) * (eye_jitter + target_jitter) = {needed:.3g} m), "
            f"got eye {list(camera.eye)} and target {list(camera.target)}, {distance:.3g} m apart"
        )


def _check_mesh_sizes(assets_dir: str, max_faces: int, source: str) -> None:
    """A huge mesh would take minutes to decompose in every worker, and one with a vertex at
    NaN or 1e300 would collapse when normalised: refused before any process starts (the face
    counts from headers first, so a huge file is refused before it is parsed)."""
    from datagen.assets.mesh_library import MAX_COORDINATE, out_of_range_meshes, oversized_meshes

    oversized = oversized_meshes(assets_dir, max_faces)
    if oversized:
        path, faces = oversized[0]
        more = f" (and {len(oversized) - 1} more)" if len(oversized) > 1 else ""
        raise ConfigError(
            f"{source}: objects.assets_dir: {Path(assets_dir) / path} has {faces} faces, more "
            f"than objects.max_mesh_faces ({max_faces}){more}: simplify it (decimate it in "
            f"MeshLab or Blender) or raise objects.max_mesh_faces"
        )
    out_of_range = out_of_range_meshes(assets_dir)
    if out_of_range:
        path, problem = out_of_range[0]
        more = f" (and {len(out_of_range) - 1} more)" if len(out_of_range) > 1 else ""
        raise ConfigError(
            f"{source}: objects.assets_dir: {Path(assets_dir) / path} has {problem}{more}; "
            f"expected finite vertex coordinates within +-{MAX_COORDINATE:.0e}: fix or remove it"
        )


def _is_dir(path: str) -> bool:
    try:
        return Path(path).is_dir()
    except OSError:  # a name too long, a directory we may not enter, ...
        return False


def _check_formats(formats: list[str], family, source: str) -> None:
    choices = [STORE, *EXPORTS]
    if (
        STORE not in formats
        or any(s not in choices for s in formats)
        or len(set(formats)) != len(formats)
    ):
        raise ConfigError(
            f"{source}: output.formats: expected distinct names from {choices} including "
            f"{STORE!r} (the store the other formats are exported from), got {formats}"
        )
    for name in formats[1:] if formats[0] == STORE else [s for s in formats if s != STORE]:
        if EXPORTS[name].episodes and not family.episodes:
            raise ConfigError(
                f"{source}: output.formats: {name!r} stores episodes, and scene {family.name!r} "
                f"makes single frames; episodes come from "
                f"{' or '.join(n for n in FAMILIES if FAMILIES[n].episodes)}"
            )
        worlds = EXPORTS[name].worlds
        if worlds is not None and family.world not in worlds:
            raise ConfigError(
                f"{source}: output.formats: {name!r} exports scenes of the {' or '.join(worlds)} "
                f"world only, not scene {family.name!r} ({family.world} world)"
            )
