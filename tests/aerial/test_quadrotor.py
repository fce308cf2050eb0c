"""The procedural quadrotor (datagen/families/aerial/quadrotor.py): its radius holds every part, and its
forward camera, tilted as far up as a config allows, sees none of its own drone."""

from __future__ import annotations

import numpy as np
import pytest

from datagen.config import config_from_dict
from datagen.config.aerial import MAX_CAMERA_TOP_DEG
from datagen.errors import ConfigError
from datagen.families.aerial.airframe import (
    bounding_radius,
    camera_mounts,
    camera_reach,
    right_camera,
)
from datagen.families.aerial.quadrotor import QuadrotorShape, quadrotor_parts
from datagen.registries import AIRFRAMES

QUADROTOR = AIRFRAMES["quadrotor"]


@pytest.mark.parametrize("span", [0.1, 0.25, 0.45, 1.0])
def test_the_bounding_radius_holds_every_part_and_scales_with_the_span(span):
    shape = QuadrotorShape(span)
    radius = bounding_radius(QUADROTOR, shape)
    assert all(
        np.linalg.norm(m.vertices, axis=1).max() <= radius + 1e-12
        for m in quadrotor_parts(shape).values()
    )
    assert radius == pytest.approx(bounding_radius(QUADROTOR, QuadrotorShape(1.0)) * span)


def _seen(points: np.ndarray, pitch_deg: float, fovy_deg: float, aspect: float) -> np.ndarray:
    """Which points (camera-relative, body axes) lie in the view of a camera tilted up by the
    pitch with that vertical field of view and width / height."""
    p = np.radians(pitch_deg)
    forward = points @ [np.cos(p), 0.0, np.sin(p)]
    up = points @ [-np.sin(p), 0.0, np.cos(p)]
    half = np.tan(np.radians(fovy_deg) / 2)
    with np.errstate(divide="ignore", invalid="ignore"):
        return (
            (forward > 0)
            & (np.abs(up / forward) <= half)
            & (np.abs(points[:, 1] / forward) <= half * aspect)
        )


@pytest.mark.parametrize("span", [0.25, 0.45])
@pytest.mark.parametrize(("pitch", "fovy"), [(-20, 75), (5, 75), (15, 60), (-60, 75), (0, 90)])
@pytest.mark.parametrize("shift", [(0.0, 0.0), (1.0, 1.0), (-1.0, 1.0), (1.0, -1.0)])
@pytest.mark.parametrize("baseline", [0.0, 0.05, 0.12, 0.25, 0.5])
def test_the_forward_cameras_see_nothing_of_their_drone_up_to_the_limit(
    span, pitch, fovy, shift, baseline
):
    """At 4:3 (the default 640x480), with the view's top at most MAX_CAMERA_TOP_DEG up, the
    mount anywhere its randomisation puts it; a stereo pair's right camera (``baseline`` > 0)
    as well, and its drone is planned with a radius that holds it."""
    assert pitch + fovy / 2 <= MAX_CAMERA_TOP_DEG
    shape = QuadrotorShape(span)
    eye = right_camera(camera_mounts(QUADROTOR, shape, shift)["forward"], baseline)
    assert np.linalg.norm(eye) <= camera_reach(QUADROTOR, shape, baseline) + 1e-12
    for name, mesh in quadrotor_parts(shape).items():
        seen = _seen(np.asarray(mesh.vertices) - eye, pitch, fovy, 4 / 3)
        assert not seen.any(), (name, pitch, fovy)


def test_a_config_whose_camera_would_see_its_rotors_is_refused():
    with pytest.raises(ConfigError, match=r"aerial\.camera_pitch_deg: .* sees its own rotors"):
        config_from_dict(
            {
                "scene": "aerial",
                "aerial": {"camera_pitch_deg": [0, 20], "camera_fovy_deg": [60, 60]},
            }
        )
