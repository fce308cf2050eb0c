"""Config sections of the appearance randomisers added for transfer: backgrounds, distractors,
camera effects and the depth-sensor model (textures live in ``materials``). Same conventions as
:mod:`datagen.config.sections`: frozen dataclasses, ranges in ``metadata``."""

from __future__ import annotations

from dataclasses import dataclass, field

from datagen.config.sections import ranged


@dataclass(frozen=True)
class BackgroundConfig:
    enabled: bool = True
    room_half_size: tuple[float, float] = field(
        default=(1.5, 3.5), metadata=ranged(0.8, 20.0, "metres from the table centre to a wall")
    )
    wall_height: tuple[float, float] = field(
        default=(2.6, 3.4), metadata=ranged(0.5, 20.0, "metres")
    )
    ceiling_probability: float = field(
        default=0.5, metadata=ranged(0.0, 1.0, "chance that the room has a ceiling")
    )
    texture_probability: float = field(
        default=0.9, metadata=ranged(0.0, 1.0, "chance that a wall or the ceiling is textured")
    )
    images_dir: str = ""  # users' PNG/JPEG backdrop pictures; relative to the config file
    images_dir_share: float = field(
        default=0.5,
        metadata=ranged(0.0, 1.0, "share of textured walls showing a picture of images_dir"),
    )
    room_lights: tuple[int, int] = field(
        default=(0, 3), metadata=ranged(0, 8, "point lights under the ceiling or wall tops")
    )
    room_light_intensity: tuple[float, float] = field(
        default=(0.2, 1.0), metadata=ranged(0.0, 20.0, "radiance of a room light at the tray")
    )


@dataclass(frozen=True)
class DistractorsConfig:
    enabled: bool = True
    on_table: tuple[int, int] = field(
        default=(0, 3), metadata=ranged(0, 16, "distractors on the table outside the tray")
    )
    in_air: tuple[int, int] = field(
        default=(0, 1), metadata=ranged(0, 4, "distractors floating between camera and tray")
    )
    background: tuple[int, int] = field(
        default=(1, 4), metadata=ranged(0, 16, "distractors on the floor beyond the table")
    )
    size: tuple[float, float] = field(
        default=(0.03, 0.12),
        metadata=ranged(0.005, 0.3, "largest extent of a table or air distractor, metres"),
    )
    background_size: tuple[float, float] = field(
        default=(0.15, 0.6),
        metadata=ranged(0.01, 2.0, "largest extent of a background distractor, metres"),
    )
    flying: tuple[int, int] = field(
        default=(0, 5), metadata=ranged(0, 16, "distractors anywhere in view, at many depths")
    )
    flying_depth: tuple[float, float] = field(
        default=(0.1, 1.6),
        metadata=ranged(0.05, 5.0, "depth of a flying distractor, fraction of camera-to-target"),
    )
    flying_size: tuple[float, float] = field(
        default=(0.03, 0.3),
        metadata=ranged(0.005, 2.0, "largest extent of a flying distractor, metres"),
    )


@dataclass(frozen=True)
class CameraEffectsConfig:
    """Each effect is applied to a view with its probability, its values drawn from its range."""

    enabled: bool = True
    keep_clean: bool = False  # also store the image before the effects (rgb_clean.png)
    exposure_probability: float = field(default=0.5, metadata=ranged(0.0, 1.0, "chance"))
    exposure_ev: tuple[float, float] = field(
        default=(-0.7, 0.7), metadata=ranged(-4.0, 4.0, "stops (EV), gain 2^EV")
    )
    white_balance_probability: float = field(default=0.5, metadata=ranged(0.0, 1.0, "chance"))
    white_balance: tuple[float, float] = field(
        default=(0.9, 1.1), metadata=ranged(0.5, 2.0, "gain of red and of blue, green 1")
    )
    gamma_probability: float = field(default=0.3, metadata=ranged(0.0, 1.0, "chance"))
    gamma: tuple[float, float] = field(
        default=(0.85, 1.15), metadata=ranged(0.3, 3.0, "exponent on the encoded [0, 1] values")
    )
    noise_probability: float = field(default=0.7, metadata=ranged(0.0, 1.0, "chance"))
    shot_noise: tuple[float, float] = field(
        default=(0.0002, 0.003),
        metadata=ranged(0.0, 0.1, "noise variance per unit linear intensity"),
    )
    read_noise: tuple[float, float] = field(
        default=(0.001, 0.01), metadata=ranged(0.0, 0.2, "noise std, linear intensity")
    )
    motion_blur_probability: float = field(default=0.2, metadata=ranged(0.0, 1.0, "chance"))
    motion_blur_px: tuple[float, float] = field(
        default=(2.0, 9.0), metadata=ranged(1.0, 100.0, "length of the blur streak, pixels")
    )
    defocus_blur_probability: float = field(default=0.15, metadata=ranged(0.0, 1.0, "chance"))
    defocus_radius_px: tuple[float, float] = field(
        default=(0.7, 2.5), metadata=ranged(0.5, 50.0, "radius of the blur disc, pixels")
    )
    jpeg_probability: float = field(default=0.3, metadata=ranged(0.0, 1.0, "chance"))
    jpeg_quality: tuple[int, int] = field(
        default=(35, 95), metadata=ranged(1, 100, "OpenCV JPEG quality")
    )
    vignetting_probability: float = field(default=0.5, metadata=ranged(0.0, 1.0, "chance"))
    vignetting: tuple[float, float] = field(
        default=(0.1, 0.45), metadata=ranged(0.0, 0.95, "intensity lost at the image corners")
    )
    distortion_probability: float = field(default=0.3, metadata=ranged(0.0, 1.0, "chance"))
    distortion_k1: tuple[float, float] = field(
        default=(-0.25, 0.1), metadata=ranged(-0.5, 0.5, "OpenCV radial coefficient k1")
    )
    distortion_k2: tuple[float, float] = field(
        default=(-0.05, 0.05), metadata=ranged(-0.2, 0.2, "OpenCV radial coefficient k2")
    )
    distortion_k3: tuple[float, float] = field(
        default=(-0.01, 0.01), metadata=ranged(-0.1, 0.1, "OpenCV radial coefficient k3")
    )
    distortion_p: tuple[float, float] = field(
        default=(-0.002, 0.002), metadata=ranged(-0.02, 0.02, "OpenCV tangential p1 and p2")
    )


@dataclass(frozen=True)
class DepthSensorConfig:
    """A structured-light / stereo depth camera at the colour camera (values drawn per view)."""

    enabled: bool = True
    noise_a: tuple[float, float] = field(
        default=(0.0005, 0.0015), metadata=ranged(0.0, 0.1, "noise std at z = 0, metres")
    )
    noise_b: tuple[float, float] = field(
        default=(0.001, 0.004), metadata=ranged(0.0, 0.1, "std = a + b z^2, 1/metres")
    )
    baseline: tuple[float, float] = field(
        default=(0.03, 0.075),
        metadata=ranged(-0.5, 0.5, "projector offset along the camera's +x, metres"),
    )
    disparity_step: tuple[float, float] = field(
        default=(0.0625, 0.125), metadata=ranged(0.0, 2.0, "disparity quantum, pixels")
    )
    edge_jump: tuple[float, float] = field(
        default=(0.02, 0.05),
        metadata=ranged(0.001, 1.0, "neighbour depth jump that drops a reading, fraction of z"),
    )
    edge_width_px: tuple[int, int] = field(
        default=(1, 2), metadata=ranged(0, 10, "holes beside a depth edge, pixels")
    )
    dark_threshold: tuple[float, float] = field(
        default=(0.01, 0.04), metadata=ranged(0.0, 1.0, "linear luminance below which it fails")
    )
    dark_dropout: tuple[float, float] = field(
        default=(0.5, 1.0), metadata=ranged(0.0, 1.0, "chance that a dark pixel has no reading")
    )
    specular_metallic: float = field(
        default=0.35, metadata=ranged(0.0, 1.0, "objects at least this metallic ...")
    )
    specular_roughness: float = field(
        default=0.3, metadata=ranged(0.0, 1.0, "... and at most this rough are specular")
    )
    specular_dropout: tuple[float, float] = field(
        default=(0.3, 0.8), metadata=ranged(0.0, 1.0, "chance that a specular pixel has no reading")
    )


@dataclass(frozen=True)
class PhotosConfig:
    """Photographs and material pictures of the installed library (``datagen library install``)
    on the tabletop scenes' surfaces, walls and flying distractors, each drawn with a random crop,
    scale, rotation and colour jitter. ``sources`` are drawn from; ``held_out`` never are (kept
    for testing transfer): naming a source in both is an error."""

    enabled: bool = True
    sources: tuple[str, ...] = ("robosuite-textures", "mate-backgrounds", "ukui-wallpapers")
    held_out: tuple[str, ...] = ("skimage-data",)
    surface_probability: float = field(
        default=0.3,
        metadata=ranged(0.0, 1.0, "chance that an object, the table, tray or floor shows one"),
    )
    backdrop_probability: float = field(
        default=0.6, metadata=ranged(0.0, 1.0, "chance that a wall or the ceiling shows one")
    )
    distractor_probability: float = field(
        default=0.7, metadata=ranged(0.0, 1.0, "chance that a flying distractor shows one")
    )
    crop: tuple[float, float] = field(
        default=(0.25, 1.0), metadata=ranged(0.05, 1.0, "side of the crop, fraction of the picture")
    )
    surface_scale_m: tuple[float, float] = field(
        default=(0.05, 0.6), metadata=ranged(0.001, 100.0, "metres across one repeat on a surface")
    )
    backdrop_scale_m: tuple[float, float] = field(
        default=(0.8, 4.0), metadata=ranged(0.001, 100.0, "metres across one repeat on a wall")
    )
    contrast: tuple[float, float] = field(
        default=(0.6, 1.4), metadata=ranged(0.0, 4.0, "gain about the picture's mean")
    )
    brightness: tuple[float, float] = field(
        default=(-0.15, 0.15), metadata=ranged(-1.0, 1.0, "offset, fraction of full scale")
    )
    saturation: tuple[float, float] = field(
        default=(0.4, 1.4), metadata=ranged(0.0, 4.0, "gain of the HSV saturation")
    )
    hue_deg: tuple[float, float] = field(
        default=(-30.0, 30.0), metadata=ranged(-180.0, 180.0, "hue rotation, degrees")
    )
