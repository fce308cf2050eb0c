"""The sections of a build config: frozen dataclasses, every field with its unit and range
(``metadata`` ``min``/``max``/``doc``, checked by :func:`datagen.config.config_from_dict`)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from datagen.assets.family_names import HOUSEHOLD_FAMILIES, TEXTURE_FAMILIES

PRIMITIVE_FAMILIES = ("box", "cylinder", "sphere", "capsule", "convex", "compound")
SHAPE_FAMILIES = (*PRIMITIVE_FAMILIES, *HOUSEHOLD_FAMILIES)
SAMPLE_ERROR_POLICIES = ("fail", "retry")
SHADERS = ("rasterized", "raytraced")
DENOISERS = ("none", "oidn", "optix")


def ranged(lo: float, hi: float, doc: str) -> Any:
    return {"min": lo, "max": hi, "doc": doc}


@dataclass(frozen=True)
class RenderConfig:
    width: int = field(default=640, metadata=ranged(16, 4096, "image width, pixels"))
    height: int = field(default=480, metadata=ranged(16, 4096, "image height, pixels"))
    wrist_camera: bool = True
    views: int = field(
        default=1, metadata=ranged(1, 16, "randomised cameras per settled scene (tabletop scenes)")
    )
    near: float = field(default=0.05, metadata=ranged(0.001, 10.0, "near clip plane, metres"))
    far: float = field(default=5.0, metadata=ranged(0.1, 100.0, "far clip plane, metres"))
    shadow_map_size: int = field(default=1024, metadata=ranged(128, 8192, "pixels"))
    robot_triangles: int = field(
        default=20000,
        metadata=ranged(0, 10**7, "most triangles the robot is drawn with; 0 = its own meshes"),
    )
    shader: str = "rasterized"  # or "raytraced": colour images path-traced, labels rasterized
    samples_per_pixel: int = field(
        default=16, metadata=ranged(1, 4096, "paths per pixel of a path-traced image")
    )
    path_depth: int = field(
        default=8, metadata=ranged(0, 32, "bounces of a path after its first hit; 0: direct light")
    )
    denoiser: str = "none"  # or "oidn", "optix" (SAPIEN's, on CUDA)
    raytraced_share: float = field(
        default=1.0,
        metadata=ranged(0.0, 1.0, "chance that a view is path-traced (shader raytraced)"),
    )


@dataclass(frozen=True)
class ObjectsConfig:
    count: tuple[int, int] = field(default=(3, 12), metadata=ranged(1, 32, "objects per scene"))
    families: tuple[str, ...] = SHAPE_FAMILIES
    source: str = "procedural"  # or "folder": users' meshes from assets_dir
    assets_dir: str = ""  # DIR/<class>/<mesh>; relative to the config file
    max_mesh_faces: int = field(
        default=1_000_000, metadata=ranged(4, 10**9, "faces of one mesh in assets_dir")
    )
    size: tuple[float, float] = field(
        default=(0.045, 0.1), metadata=ranged(0.005, 0.5, "largest extent of an object, metres")
    )
    density: tuple[float, float] = field(
        default=(200.0, 1200.0), metadata=ranged(1.0, 20000.0, "kg/m^3")
    )
    friction: tuple[float, float] = field(
        default=(0.3, 1.0), metadata=ranged(0.0, 2.0, "Coulomb coefficient")
    )
    restitution: tuple[float, float] = field(
        default=(0.0, 0.1), metadata=ranged(0.0, 1.0, "coefficient")
    )
    drop_height: tuple[float, float] = field(
        default=(0.03, 0.25), metadata=ranged(0.0, 1.0, "metres above the tray floor")
    )


@dataclass(frozen=True)
class MaterialsConfig:
    roughness: tuple[float, float] = field(default=(0.1, 0.9), metadata=ranged(0.0, 1.0, ""))
    metallic: tuple[float, float] = field(default=(0.0, 0.5), metadata=ranged(0.0, 1.0, ""))
    saturation: tuple[float, float] = field(
        default=(0.3, 1.0), metadata=ranged(0.0, 1.0, "HSV saturation of object colours")
    )
    value: tuple[float, float] = field(
        default=(0.35, 1.0), metadata=ranged(0.0, 1.0, "HSV value of object colours")
    )
    texture_probability: float = field(
        default=0.8, metadata=ranged(0.0, 1.0, "chance that a surface is textured")
    )
    texture_families: tuple[str, ...] = TEXTURE_FAMILIES
    texture_scale_m: tuple[float, float] = field(
        default=(0.03, 0.4), metadata=ranged(0.001, 100.0, "metres per repeat of a texture")
    )
    textures_dir: str = ""  # users' PNG/JPEG textures; relative to the config file
    textures_dir_share: float = field(
        default=0.5,
        metadata=ranged(0.0, 1.0, "share of textured surfaces showing a picture of textures_dir"),
    )
    normal_maps: bool = False
    class_independent_probability: float = field(
        default=0.5,
        metadata=ranged(0.0, 1.0, "chance that surfaces and objects share one colour range"),
    )


@dataclass(frozen=True)
class LightingConfig:
    ambient: tuple[float, float] = field(
        default=(0.05, 0.6), metadata=ranged(0.0, 2.0, "ambient level")
    )
    lights: tuple[int, int] = field(default=(1, 4), metadata=ranged(0, 8, "number of lights"))
    intensity: tuple[float, float] = field(
        default=(0.3, 3.0), metadata=ranged(0.0, 20.0, "directional light radiance")
    )
    elevation_deg: tuple[float, float] = field(
        default=(15.0, 89.0), metadata=ranged(5.0, 90.0, "light elevation above horizon, degrees")
    )
    colour_temperature_k: tuple[float, float] = field(
        default=(2700.0, 8000.0),
        metadata=ranged(1000.0, 40000.0, "black-body colour temperature of a light, kelvin"),
    )
    colour_temperature_jitter: float = field(
        default=0.15, metadata=ranged(0.0, 1.0, "max per-channel colour deviation")
    )
    shadows: bool = True
    soft_shadow_probability: float = field(
        default=0.5, metadata=ranged(0.0, 1.0, "chance that the key light's shadow is soft")
    )
    soft_shadow_radius_m: tuple[float, float] = field(
        default=(0.1, 0.3),
        metadata=ranged(0.01, 0.5, "radius of a soft key light's area light, metres"),
    )


@dataclass(frozen=True)
class CameraConfig:
    eye: tuple[float, float, float] = field(
        default=(-0.85, 0.9, 1.8), metadata=ranged(-100.0, 100.0, "world metres, per axis")
    )
    target: tuple[float, float, float] = field(
        default=(-0.25, 0.0, 0.85), metadata=ranged(-100.0, 100.0, "world metres, per axis")
    )
    eye_jitter: float = field(default=0.05, metadata=ranged(0.0, 1.0, "metres, per axis"))
    target_jitter: float = field(default=0.03, metadata=ranged(0.0, 1.0, "metres, per axis"))
    fovy_deg: tuple[float, float] = field(
        default=(48.0, 56.0), metadata=ranged(5.0, 150.0, "vertical field of view, degrees")
    )
    orbit_deg: float = field(
        default=30.0,
        metadata=ranged(0.0, 180.0, "extra views turn about the target's vertical, +- degrees"),
    )


@dataclass(frozen=True)
class PhysicsConfig:
    timestep: float = field(default=0.005, metadata=ranged(0.0005, 0.05, "seconds"))
    settle_time: float = field(
        default=1.5, metadata=ranged(0.0, 30.0, "simulated seconds before rendering")
    )
    settle_velocity: float = field(
        default=0.01, metadata=ranged(0.0, 1.0, "m/s; settling ends early once objects are slower")
    )


@dataclass(frozen=True)
class OutputConfig:
    shard_size: int = field(default=200, metadata=ranged(1, 1_000_000, "samples per tar shard"))
    formats: tuple[str, ...] = ("webdataset",)  # the shards' store, then formats exported
    png_level: int = field(
        default=1,
        metadata=ranged(0, 9, "PNG compression: 1 fastest (default), 9 smallest, 0 none"),
    )


@dataclass(frozen=True)
class ExecutorConfig:
    recycle_after: int = field(
        default=2000,
        metadata=ranged(
            0, 10**9, "samples a worker makes before a fresh one replaces it; 0 = never"
        ),
    )
    cpus_per_worker: float = field(
        default=1.0, metadata=ranged(0.0, 256.0, "CPUs a Ray worker actor reserves")
    )
    gpus_per_worker: float = field(
        default=0.0,
        metadata=ranged(0.0, 16.0, "GPUs a Ray worker actor reserves (SAPIEN renders on it)"),
    )


@dataclass(frozen=True)
class TransferConfig:
    window: int = field(default=8, metadata=ranged(1, 256, "in-flight samples per worker"))
    max_sample_mb: float = field(default=32.0, metadata=ranged(0.1, 256.0, "MiB per sample"))
    ack_timeout_s: float = field(
        default=60.0,
        metadata=ranged(1.0, 86400.0, "seconds from publish to the writer's ack before re-issue"),
    )
    unacked_per_writer: int = field(
        default=64,
        metadata=ranged(
            1,
            100_000,
            "published samples not yet durable per writer of the build; past it "
            "no new sample is issued until the writers catch up",
        ),
    )


@dataclass(frozen=True)
class CampaignConfig:
    """Grasp-attempt campaigns (scene ``grasp_attempts``): one physically executed grasp per sample."""

    sampler: str = "antipodal"
    sampler_tries: int = field(
        default=200, metadata=ranged(1, 100000, "candidates tried per attempt")
    )
    friction: float = field(
        default=0.5,
        metadata=ranged(0.05, 2.0, "friction coefficient the antipodal sampler assumes"),
    )
    pre_grasp_distance: float = field(
        default=0.1, metadata=ranged(0.0, 0.5, "metres back along the approach")
    )
    lift_height: float = field(default=0.1, metadata=ranged(0.01, 0.5, "metres"))
    hold_time: float = field(default=1.0, metadata=ranged(0.0, 10.0, "simulated seconds"))
    post_grasp_frame: bool = True
    record_hz: float = field(
        default=20.0,
        metadata=ranged(0.0, 1000.0, "Hz: state rows of trajectory.npz (0: not recorded)"),
    )
    frame_hz: float = field(
        default=0.0,
        metadata=ranged(0.0, 1000.0, "Hz: colour frames while executing (0: none)"),
    )
    # the learned sampler (docs/campaigns.md, "Learning to grasp"): the model scores this many
    # antipodal candidates from the named camera's depth and the best is executed
    model: str | None = None  # ONNX file, relative to the config file
    model_sha256: str | None = None  # filled in from the file when absent; a given one must match
    candidates: int = field(
        default=16, metadata=ranged(1, 256, "antipodal candidates the learned sampler scores")
    )
    model_camera: str = "wrist"  # whose depth the model sees: wrist or workspace
    # plan candidates before executing one: the antipodal sampler executes the first of its
    # ``candidates`` the arm reaches, the learned one the best-scored the arm reaches
    check_reach: bool = False
    # training data with pairs to rank: attempt i grasps in scene i // k (drawn, built and
    # settled from that index) and executes the antipodal sampler's (i mod k)-th candidate there
    grasps_per_scene: int = field(
        default=1, metadata=ranged(1, 64, "attempts sharing one scene, each its own candidate")
    )


@dataclass(frozen=True)
class NavigationConfig:
    """Navigation episodes (scene ``navigation``): Fetch drives from a start to a goal."""

    family: str = "rooms"
    robot: str = "fetch"  # "fetch" (differential drive) or "car" (Ackermann steering)
    robots: int = field(default=1, metadata=ranged(1, 8, "robots driving at once in one episode"))
    max_steering_deg: float = field(
        default=30.0, metadata=ranged(5.0, 60.0, "a car's steering limit, degrees")
    )
    clutter: tuple[int, int] | None = field(
        default=None, metadata=ranged(0, 40, "obstacles placed in the layout (None: per family)")
    )
    clutter_size: tuple[float, float] = field(
        default=(0.3, 0.7), metadata=ranged(0.05, 2.0, "obstacle footprint side, metres")
    )
    obstacle_height: tuple[float, float] = field(
        default=(0.3, 1.2), metadata=ranged(0.02, 3.0, "metres")
    )
    wall_height: tuple[float, float] = field(
        default=(2.3, 2.8), metadata=ranged(0.5, 5.0, "metres")
    )
    robot_radius: float = field(
        default=0.3, metadata=ranged(0.05, 1.0, "footprint disk for planning and collisions, m")
    )
    planning_margin: float = field(
        default=0.1, metadata=ranged(0.0, 0.5, "clearance added to the radius when planning, m")
    )
    min_goal_distance: float = field(
        default=3.0, metadata=ranged(0.0, 50.0, "straight-line start-goal distance, metres")
    )
    control_rate_hz: float = field(default=10.0, metadata=ranged(1.0, 100.0, "Hz"))
    frame_rate_hz: float = field(
        default=2.0, metadata=ranged(0.01, 100.0, "rendered frames per simulated second")
    )
    max_linear: float = field(default=0.6, metadata=ranged(0.05, 3.0, "m/s"))
    max_angular: float = field(default=1.5, metadata=ranged(0.1, 6.0, "rad/s"))
    lookahead: float = field(default=0.3, metadata=ranged(0.05, 3.0, "pure-pursuit lookahead, m"))
    torso_lift: tuple[float, float] = field(
        default=(0.0, 0.386),
        metadata=ranged(0.0, 0.386, "Fetch torso lift, metres (camera at about 1.03-1.42 m)"),
    )
    camera_pitch_deg: tuple[float, float] = field(
        default=(5.0, 30.0), metadata=ranged(-60.0, 85.0, "head tilt below horizontal, degrees")
    )
    camera_fovy_deg: tuple[float, float] = field(
        default=(50.0, 70.0), metadata=ranged(10.0, 150.0, "vertical field of view, degrees")
    )


@dataclass(frozen=True)
class BuildPolicyConfig:
    """What a build does when producing a sample raises: ``fail`` ends the build at once;
    ``retry`` re-draws the sample from the streams of attempt k = 1..retries (still a function
    of (seed, index) alone), and after the last attempt goes on with the other samples and
    fails at the end listing every failed index with its errors. An attempt that runs past
    ``sample_timeout_s`` counts as a failed attempt (its worker is killed); a worker, writer or
    broker silent past its timeout is killed and restarted, or reported (docs/liveness.md)."""

    on_sample_error: str = "retry"
    retries: int = field(default=3, metadata=ranged(0, 10, "attempts after the first"))
    # liveness (docs/liveness.md): what is silent or stuck this long is killed or reported
    sample_timeout_s: float = field(
        default=900.0,
        metadata=ranged(1.0, 86400.0, "seconds one attempt at one sample may take"),
    )
    worker_timeout_s: float = field(
        default=120.0,
        metadata=ranged(5.0, 86400.0, "seconds a worker may send nothing (heartbeats: 2 s)"),
    )
    writer_timeout_s: float = field(
        default=60.0,
        metadata=ranged(5.0, 86400.0, "seconds a writer may send nothing (heartbeats: 2 s)"),
    )
    broker_timeout_s: float = field(
        default=60.0,
        metadata=ranged(5.0, 86400.0, "seconds the broker may not answer (probed every 2 s)"),
    )
    outage_wait_s: float = field(
        default=600.0,
        metadata=ranged(
            0.0,
            86400.0,
            "seconds an external writer or broker may stay silent "
            "after it was reported, before the build stops",
        ),
    )
