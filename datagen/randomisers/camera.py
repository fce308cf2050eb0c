"""Camera randomiser: pose jitter around a nominal look-at, and the vertical field of view."""

from __future__ import annotations

from typing import Any

import numpy as np
import sapien

from datagen.config.sections import CameraConfig
from datagen.geometry import look_at


def sample_camera(rng: np.random.Generator, cfg: CameraConfig) -> dict[str, Any]:
    eye = np.asarray(cfg.eye) + rng.uniform(-cfg.eye_jitter, cfg.eye_jitter, 3)
    target = np.asarray(cfg.target) + rng.uniform(-cfg.target_jitter, cfg.target_jitter, 3)
    return {
        "eye": np.round(eye, 6).tolist(),
        "target": np.round(target, 6).tolist(),
        "fovy_deg": round(float(rng.uniform(*cfg.fovy_deg)), 6),
    }


def apply_camera(camera: sapien.render.RenderCameraComponent, values: dict[str, Any]) -> None:
    camera.set_fovy(np.deg2rad(values["fovy_deg"]), compute_x=True)
    camera.entity.set_pose(sapien.Pose(look_at(values["eye"], values["target"])))
