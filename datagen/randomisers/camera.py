"""Camera randomiser: pose jitter around a nominal look-at, and the vertical field of view.

A scene has ``render.views`` such cameras. View 0 (``workspace``) is jittered around the
nominal eye; each extra view ``view<k>`` first turns the nominal eye about the vertical axis
through the nominal target by an angle drawn in +-``camera.orbit_deg`` (so the views see the
tray from different sides at the same distance), then is jittered the same way."""

from __future__ import annotations

import numpy as np

from datagen.config.sections import CameraConfig
from datagen.scene_values.camera import CameraPose
from datagen.scene_values.rounding import uniform


def draw_camera(rng: np.random.Generator, cfg: CameraConfig) -> CameraPose:
    """The workspace camera (view 0): the nominal eye and target, each jittered."""
    return _jittered(rng, cfg, np.asarray(cfg.eye, float))


def extra_view_name(k: int) -> str:
    """Name (and part prefix, ``view1.rgb.png``) of extra view k = 1, 2, ..."""
    return f"view{k}"


def draw_extra_view(rng: np.random.Generator, cfg: CameraConfig) -> CameraPose:
    """An extra view: the nominal eye turned about the target's vertical, then jittered."""
    azimuth = float(rng.uniform(-cfg.orbit_deg, cfg.orbit_deg))
    return _jittered(rng, cfg, orbited_eye(cfg, azimuth), round(azimuth, 6))


def orbited_eye(cfg: CameraConfig, azimuth_deg: float) -> np.ndarray:
    """The nominal eye turned by ``azimuth_deg`` about the vertical through the nominal target."""
    c, s = np.cos(np.deg2rad(azimuth_deg)), np.sin(np.deg2rad(azimuth_deg))
    target = np.asarray(cfg.target, float)
    x, y, z = np.asarray(cfg.eye, float) - target
    return target + np.array([c * x - s * y, s * x + c * y, z])


def _jittered(
    rng: np.random.Generator, cfg: CameraConfig, eye: np.ndarray, azimuth: float | None = None
) -> CameraPose:
    eye = eye + rng.uniform(-cfg.eye_jitter, cfg.eye_jitter, 3)
    target = np.asarray(cfg.target) + rng.uniform(-cfg.target_jitter, cfg.target_jitter, 3)
    return CameraPose(
        eye=tuple(np.round(eye, 6).tolist()),
        target=tuple(np.round(target, 6).tolist()),
        fovy_deg=uniform(rng, cfg.fovy_deg),
        azimuth_deg=azimuth,
    )
