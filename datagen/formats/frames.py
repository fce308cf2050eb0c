"""``datagen.sample/1``: the cameras of one scene, each a labelled view (the workspace camera's
images unprefixed, another camera's prefixed by its name), and for a grasp attempt its record
(``attempt``), its recorded trajectory (``trajectory.npz``) and its film (``frame<k>.rgb.png``,
``frame<k>.wrist.rgb.png``)."""

from __future__ import annotations

import re
from collections import Counter
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from datagen.dataset.part_rules import Decoding, PartRule
from datagen.dataset.trajectory import decode_trajectory
from datagen.dataset.views import camera_views
from datagen.errors import DatasetError
from datagen.exports.episodes import Episode, words
from datagen.formats.counting import histogram
from datagen.records import ExportedDataset, Manifest, SampleMetadata
from datagen.tools.preview import camera_tile
from datagen.tools.randomisation_plots import plot_randomisation, randomisation_panels
from datagen.tools.sample_checks import check_plottable

views = camera_views
tile = camera_tile


def _trajectory(decoding: Decoding, match: re.Match[str], data: bytes) -> None:
    decoding.item["trajectory"] = decode_trajectory(data)


def _film_frame(decoding: Decoding, match: re.Match[str], data: bytes) -> None:
    into = decoding.film.setdefault(int(match[1]), {})
    decoding.image(into, "wrist_rgb" if match[2] else "rgb", "rgb.png", data)


# a grasp attempt's recorded trajectory, and its film: frame3.rgb.png (the workspace camera),
# frame3.wrist.rgb.png, each matched to a frame time of the trajectory
PARTS = (
    PartRule(re.compile(r"trajectory\.npz"), _trajectory),
    PartRule(re.compile(r"frame(\d+)\.(?:(wrist)\.)?rgb\.png"), _film_frame),
)

# name -> the values of one sample; a name whose fields a family's metadata lacks is left out
_SAMPLE_VALUES: dict[str, Callable[[SampleMetadata], list[float]]] = {
    "objects per scene": lambda m: [len(m["objects"])],
    "object mass (kg)": lambda m: [o["mass"] for o in m["objects"]],
    "object friction": lambda m: [o["friction"] for o in m["objects"]],
    "visible fraction, targets": lambda m: visible(m, "target"),
    "visible fraction, distractors": lambda m: visible(m, "distractor"),
    "ambient light": lambda m: [m["randomisation"]["lighting"]["ambient"]],
    "lights": lambda m: [len(m["randomisation"]["lighting"]["lights"])],
    "camera fovy (deg)": lambda m: [m["randomisation"]["camera"]["fovy_deg"]],
    "camera eye z (m)": lambda m: [m["randomisation"]["camera"]["eye"][2]],
}


def visible(meta: SampleMetadata, role: str) -> list[float]:
    """Visible fractions of the workspace view's objects of one ``role`` (target, distractor)."""
    objects = meta["views"]["workspace"]["objects"]
    return [o["visible_fraction"] for o in objects if o.get("role", "target") == role]


def distributions(metas: list[SampleMetadata]) -> dict[str, list[float]]:
    values = {}
    for name, of_sample in _SAMPLE_VALUES.items():
        try:
            values[name] = [v for m in metas for v in of_sample(m)]
        except KeyError:
            continue
    attempts = [m["attempt"] for m in metas if "attempt" in m]
    if attempts:
        values["grasp lift height (m)"] = [a["outcome"]["lift_height"] for a in attempts]
    return values


def summary(metas: Sequence[SampleMetadata]) -> dict[str, Any]:
    classes = Counter(o["class"] for m in metas for o in m["objects"])
    targets = [v for m in metas for v in visible(m, "target")]
    distractors = [v for m in metas for v in visible(m, "distractor")]
    panels = randomisation_panels(metas)
    return {
        "samples": len(metas),
        "objects": sum(classes.values()),
        "objects_per_class": dict(sorted(classes.items())),
        "visible_fraction_targets": histogram(targets),
        "visible_fraction_distractors": histogram(distractors),
        "surface_textures": dict(sorted(panels["surface textures"].items())),
        "distractors": int(sum(panels["distractors per scene"])),
    }


def check(meta: SampleMetadata) -> None:
    check_plottable(randomisation_panels([meta]), "its randomisation")


def pictures(metas: list[SampleMetadata], title: str) -> dict[str, Callable[[Path], None]]:
    return {"randomisation.png": lambda path: plot_randomisation(metas, title, path)}


def _texture_only(material: dict[str, Any]) -> dict[str, Any]:
    texture = material.get("texture")
    if texture is None:
        return {}
    return {"texture": {"family": texture["family"]} if "family" in texture else {}}


def summary_fields(meta: SampleMetadata) -> SampleMetadata:
    """``meta`` cut to what :func:`summary` and the campaign statistics read: a few hundred
    bytes instead of tens of kilobytes per sample."""
    cut: dict[str, Any] = {"format": meta["format"]}
    if "attempt" in meta:
        attempt = meta["attempt"]
        cut["attempt"] = {
            "sampler": attempt["sampler"],
            "target": {"class": attempt["target"]["class"]},
            "outcome": {k: attempt["outcome"][k] for k in ("success", "failure_mode")},
        }
    cut["objects"] = [
        {"class": o["class"], "shape": {"family": o["shape"]["family"]}} for o in meta["objects"]
    ]
    seen = meta["views"]["workspace"]["objects"]
    kept = [
        {"visible_fraction": o["visible_fraction"], "role": o.get("role", "target")} for o in seen
    ]
    cut["views"] = {"workspace": {"objects": kept}}
    drawn = meta.get("randomisation", {})
    materials = drawn.get("materials", {})
    cut["randomisation"] = {
        "materials": {
            name: [_texture_only(m) for m in value] if name == "objects" else _texture_only(value)
            for name, value in materials.items()
            if name == "objects" or isinstance(value, dict)
        },
        "distractors": [
            {"material": _texture_only(d["material"])} if "material" in d else {}
            for d in drawn.get("distractors", [])
        ],
    }
    if "distractors" not in drawn:
        del cut["randomisation"]["distractors"]
    if "background" in drawn:  # the panels also read its room
        background = drawn["background"]
        walls = {k: _texture_only(w) for k, w in background.get("walls", {}).items()}
        cut["randomisation"]["background"] = {"walls": walls, "room": background["room"]}
    return cut  # type: ignore[return-value]


def episodes(
    meta: SampleMetadata, dataset: ExportedDataset, i: int, manifest: Manifest
) -> list[Episode]:
    """A recorded grasp attempt's episode; none for a frame, or an attempt that found no
    candidate (no ``trajectory.npz``)."""
    names = set(dataset.part_names(i))
    if not isinstance(meta.get("attempt"), dict) or "trajectory.npz" not in names:
        return []
    raw = dataset.raw(i, {"trajectory.npz"})
    return [grasp_episode(meta, decode_trajectory(raw["trajectory.npz"]), names)]


def grasp_episode(meta: Mapping[str, Any], traj: dict[str, Any], part_names: set[str]) -> Episode:
    """The episode of a recorded attempt: its filmed frames at their rate, or its state rows."""
    names, key = traj["names"], meta["key"]
    timestep = float(names["timestep"])
    row_every, frame_every = int(names["row_every_steps"]), int(names["frame_every_steps"] or 0)
    steps = traj["step"]
    if len(traj["frame_step"]):
        if frame_every % row_every:
            raise DatasetError(
                f"sample {key}: frames every {frame_every} physics steps do not fall on the "
                f"state rows (every {row_every}): build with campaign.frame_hz equal to "
                f"campaign.record_hz (or a divisor of it)"
            )
        rows = np.searchsorted(steps, traj["frame_step"])
        fps = 1.0 / (frame_every * timestep)
        cameras = {"workspace": [f"frame{k}.rgb.png" for k in range(len(rows))]}
        wrist = [f"frame{k}.wrist.rgb.png" for k in range(len(rows))]
        if all(p in part_names for p in wrist):
            cameras["wrist"] = wrist
    else:
        rows = np.flatnonzero(steps % row_every == 0)  # the last row, after the hold, is off it
        fps, cameras = 1.0 / (row_every * timestep), {}
    attempt = meta["attempt"]
    return Episode(
        key=key,
        kind="grasp",
        task=f"pick up the {words(attempt['target']['class'])}",
        fps=fps,
        state=traj["qpos"][rows].astype(np.float32),
        state_names=list(names["joint_names"]),
        action=traj["action"][rows].astype(np.float32),
        action_names=list(names["action_names"]),
        success=bool(attempt["outcome"]["success"]),
        cameras=cameras,
        extras={
            "gripper_opening": traj["gripper_opening"][rows, None],  # m
            "tcp_pose": traj["tcp_pose"][rows],  # world xyz m, quaternion wxyz
            "target_pose": traj["target_pose"][rows],
            "qvel": traj["qvel"][rows],
            "phase": traj["phase"][rows, None].astype(np.int64),
        },
        extra_names={
            "gripper_opening": ["opening_m"],
            "tcp_pose": ["x", "y", "z", "qw", "qx", "qy", "qz"],
            "target_pose": ["x", "y", "z", "qw", "qx", "qy", "qz"],
            "qvel": list(names["joint_names"]),
            "phase": ["phase"],
        },
    )
