"""What the room-like worlds (floor plans, flight volumes) share: a labelled thing (entities
under one instance id), the box over a floor-plan rectangle, and the things a camera sees."""

from __future__ import annotations

from collections.abc import Container, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import sapien
from scipy import ndimage

from datagen.sample import sample_key


@dataclass
class Thing:
    """A labelled instance: one or more entities under one instance id."""

    instance_id: int
    class_name: str
    name: str
    entities: list[sapien.Entity] = field(default_factory=list)


def rect_box(rect, z0: float, z1: float) -> tuple[list[float], list[float]]:
    """(half size, centre) of the box over ``rect`` (x0, y0, x1, y1) from z0 to z1."""
    x0, y0, x1, y1 = rect
    return [(x1 - x0) / 2, (y1 - y0) / 2, (z1 - z0) / 2], [
        (x0 + x1) / 2,
        (y0 + y1) / 2,
        (z0 + z1) / 2,
    ]


def things_in_view(
    things: Sequence[Thing], instance: np.ndarray, skip: Container[str] = ()
) -> list[dict[str, Any]]:
    """2-D boxes of the labelled things the camera sees, leaving out those of the classes in
    ``skip``."""
    out = []
    slices = ndimage.find_objects(instance)
    for thing in things:
        box = slices[thing.instance_id - 1] if thing.instance_id <= len(slices) else None
        if box is None or thing.class_name in skip:
            continue
        rows, cols = box
        out.append(
            {
                "instance_id": thing.instance_id,
                "class": thing.class_name,
                "name": thing.name,
                "bbox_xyxy": [cols.start, rows.start, cols.stop - 1, rows.stop - 1],  # inclusive
                "pixels": int((instance[box] == thing.instance_id).sum()),
            }
        )
    return out


def episode_header(
    metadata_format: str,
    index: int,
    seed: int,
    scene: str,
    family: str,
    classes: Sequence[str],
    things: Sequence[Thing],
) -> dict[str, Any]:
    """The fields every episode's metadata opens with: its format, key, index and seed, the
    scene family and layout family, the class names (a class's id is its position) and the
    labelled things (instance id, class, name)."""
    return {
        "format": metadata_format,
        "key": sample_key(index),
        "index": index,
        "seed": seed,
        "scene": scene,
        "family": family,
        "classes": list(classes),
        "things": [
            {"instance_id": t.instance_id, "class": t.class_name, "name": t.name} for t in things
        ],
    }
