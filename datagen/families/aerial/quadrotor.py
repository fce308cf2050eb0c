"""A procedural quadrotor (pure: sampled sizes in, meshes out): a body, four arms in an X, a motor
and a rotor disc at each arm's end, landing legs and a camera pod on a nose ahead of the front
rotors and below them, so its camera never sees its own drone (with the forward camera's tilt up
to ``MAX_CAMERA_TOP_DEG`` above the horizon at its top edge, at 4:3; the config refuses more;
tests/aerial/test_quadrotor.py).

Body frame (as the flight's, :mod:`datagen.families.aerial.flatness`): x forward, y left, z up, origin at
the centre of mass (the body's centre). Sizes in metres: ``span`` is the distance between the
centres of two opposite rotors; everything else scales with it. Its record is ``quadrotor`` in
``datagen.registries.AIRFRAMES``; :mod:`datagen.families.aerial.airframe` measures it for planning.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import trimesh

PARTS = ("body", "arms", "motors", "rotors", "legs", "camera")  # one material each


@dataclass(frozen=True)
class QuadrotorShape:
    span: float  # metres between opposite rotor centres
    rotor_fraction: float = 0.35  # rotor radius / neighbouring rotors' distance: discs 30 % apart

    @property
    def arm_length(self) -> float:
        return self.span / 2

    @property
    def rotor_radius(self) -> float:
        """Metres: a fraction of the distance between neighbouring rotors (span / sqrt 2)."""
        return self.rotor_fraction * self.span / math.sqrt(2)


def _box(extents, centre) -> trimesh.Trimesh:
    return trimesh.creation.box(
        extents=extents, transform=trimesh.transformations.translation_matrix(centre)
    )


def _cylinder(radius: float, height: float, centre) -> trimesh.Trimesh:
    mesh = trimesh.creation.cylinder(radius=radius, height=height, sections=24)
    return mesh.apply_translation(centre)


def _joined(meshes: list[trimesh.Trimesh]) -> trimesh.Trimesh:
    joined = trimesh.util.concatenate(meshes)
    assert isinstance(joined, trimesh.Trimesh)  # meshes concatenate to one mesh
    return joined


def quadrotor_parts(shape: QuadrotorShape) -> dict[str, trimesh.Trimesh]:
    """One mesh per entry of :data:`PARTS`, in the body frame."""
    s, arm = shape.span, shape.arm_length
    body_h = 0.12 * s
    arms, motors, rotors, legs = [], [], [], []
    for k in range(4):
        angle = math.pi / 4 + k * math.pi / 2
        direction = np.array([math.cos(angle), math.sin(angle), 0.0])
        beam = _box([arm, 0.06 * s, 0.04 * s], direction * arm / 2)
        beam.apply_transform(
            trimesh.transformations.rotation_matrix(angle, [0, 0, 1], direction * arm / 2)
        )
        arms.append(beam)
        tip = direction * arm
        motors.append(_cylinder(0.05 * s, 0.08 * s, tip + np.array([0, 0, 0.03 * s])))
        rotors.append(_cylinder(shape.rotor_radius, 0.008 * s, tip + np.array([0, 0, 0.075 * s])))
        legs.append(
            _box(
                [0.025 * s, 0.025 * s, 0.14 * s],
                direction * 0.22 * s - [0, 0, body_h / 2 + 0.07 * s],
            )
        )
    camera = _joined(
        [
            _box([0.3 * s, 0.04 * s, 0.03 * s], [0.3 * s, 0.0, -0.03 * s]),  # the nose
            _box([0.08 * s, 0.1 * s, 0.07 * s], [0.46 * s, 0.0, -0.04 * s]),
        ]  # the pod
    )
    return {
        "body": _box([0.3 * s, 0.22 * s, body_h], [0.0, 0.0, 0.0]),
        "arms": _joined(arms),
        "motors": _joined(motors),
        "rotors": _joined(rotors),
        "legs": _joined(legs),
        "camera": camera,
    }


MOUNT_SHIFT = (0.04, 0.015)  # spans: how far the forward camera may sit off the pod's centre (y, z)


def camera_mounts(
    shape: QuadrotorShape, shift: tuple[float, float] = (0.0, 0.0)
) -> dict[str, np.ndarray]:
    """Where the cameras sit in the body frame: ``forward`` on the pod's front face, ``shift``
    (fractions of ``MOUNT_SHIFT``, in [-1, 1]) left and up of its centre; ``down`` under the body
    (positions, metres)."""
    s = shape.span
    y, z = (f * m * s for f, m in zip(shift, MOUNT_SHIFT, strict=True))
    return {
        "forward": np.array([0.5 * s + 0.005, y, -0.04 * s + z]),
        "down": np.array([0.0, 0.0, -0.06 * s - 0.005]),
    }
