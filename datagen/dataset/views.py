"""The labelled camera views inside a sample, whatever its scene: one per camera of a grasp
sample or attempt (the pre-grasp frame), one per frame of a navigation episode."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

# Classes that are surfaces, not countable instances: left out of instance annotations.
STUFF = frozenset({"background", "floor", "wall", "table", "tray", "robot"})


@dataclass
class LabelledView:
    name: str  # "" for a grasp sample's workspace camera, else "wrist", "f0003", ...
    prefix: str  # part-name prefix of its images: "" or "wrist." or "f0003."
    instances: list[dict[str, Any]]  # instance_id, class, bbox_xyxy (inclusive), extras
    camera: dict[str, Any]  # intrinsics, extrinsics_world_to_camera, width, height, ...


def labelled_views(meta: dict[str, Any]) -> Iterator[LabelledView]:
    if "frames" in meta:  # navigation episode
        for record in meta["frames"]:
            name = f"f{record['frame']:04d}"
            camera = meta["camera"] | {
                "extrinsics_world_to_camera": record["extrinsics_world_to_camera"]
            }
            yield LabelledView(name, f"{name}.", list(record["things"]), camera)
        return
    for name, view in meta["views"].items():
        instances = [
            {k: o[k] for k in ("instance_id", "class", "bbox_xyxy", "visible_fraction")}
            for o in view["objects"]
            if o["visible"]
        ]
        prefix = "" if name == "workspace" else f"{name}."
        yield LabelledView("" if name == "workspace" else name, prefix, instances, view["camera"])


def thing_classes(classes: list[str]) -> dict[str, int]:
    """Countable classes -> their id in the dataset's class list (= the semantic.png value)."""
    return {name: i for i, name in enumerate(classes) if name not in STUFF}
