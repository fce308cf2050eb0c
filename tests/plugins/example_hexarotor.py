"""An example airframe, ``hexarotor``: six rotors on arms 60 degrees apart and a camera pod on a
long nose ahead of them. It is what docs/extending.md ("An airframe") walks: one record
(``HEXAROTOR``) registered by one entry point (``datagen.airframes``); planning, the world, the
paint and the exports take it from the record."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import trimesh

from datagen.plugin_records import Airframe


@dataclass(frozen=True)
class HexShape:
    span: float  # metres between opposite rotor centres


def _box(extents, centre) -> trimesh.Trimesh:
    return trimesh.creation.box(extents=extents).apply_translation(centre)


def parts(shape: HexShape) -> dict[str, trimesh.Trimesh]:
    """Body, arms, rotors and the camera pod, in the body frame (x forward, y left, z up)."""
    s = shape.span
    arms, rotors = [], []
    for k in range(6):
        angle = math.pi / 6 + k * math.pi / 3  # no arm straight ahead: the nose passes between
        direction = np.array([math.cos(angle), math.sin(angle), 0.0])
        beam = _box([s / 2, 0.05 * s, 0.03 * s], direction * s / 4)
        beam.apply_transform(
            trimesh.transformations.rotation_matrix(angle, [0, 0, 1], direction * s / 4)
        )
        arms.append(beam)
        disc = trimesh.creation.cylinder(radius=0.12 * s, height=0.01 * s, sections=24)
        rotors.append(disc.apply_translation(direction * s / 2 + [0, 0, 0.03 * s]))
    nose = _box([0.45 * s, 0.04 * s, 0.03 * s], [0.4 * s, 0.0, -0.04 * s])
    pod = _box([0.06 * s, 0.1 * s, 0.07 * s], [0.72 * s, 0.0, -0.05 * s])
    return {
        "body": _box([0.3 * s, 0.3 * s, 0.1 * s], [0.0, 0.0, 0.0]),
        "arms": trimesh.util.concatenate(arms),
        "rotors": trimesh.util.concatenate(rotors),
        "camera": trimesh.util.concatenate([nose, pod]),
    }


def mounts(shape: HexShape, shift: tuple[float, float] = (0.0, 0.0)) -> dict[str, np.ndarray]:
    """The forward camera on the pod's front face (``shift`` moves it 2 % of the span left and
    1 % up at most), the down camera under the body."""
    s = shape.span
    return {
        "forward": np.array(
            [0.75 * s + 0.005, 0.02 * s * shift[0], -0.05 * s + 0.01 * s * shift[1]]
        ),
        "down": np.array([0.0, 0.0, -0.05 * s - 0.005]),
    }


HEXAROTOR = Airframe(
    "hexarotor",
    "six rotors 60 degrees apart and a camera pod on a long nose (the docs/extending.md example)",
    shape="example_hexarotor:HexShape",
    parts="example_hexarotor:parts",
    mounts="example_hexarotor:mounts",
    paint=(
        ("body", (0.3, 1.0)),
        ("arms", (0.05, 0.3)),
        ("rotors", (0.1, 0.6)),
        ("camera", (0.0, 0.2)),
    ),
)
