"""A campaign's attempts as examples for a grasp-quality model: what the model camera saw of
the executed grasp before it was tried (``datagen.grasp_model.inputs``) and whether it held.

The grasp is the planned one (``attempt.grasp.pose_world``, where the hand was sent): the
learned sampler scores planned candidates. Attempts without a grasp (``no_candidate``) teach
nothing and are left out; so are ``disturbed`` ones (an object moved faster than the hand could
push it: the label says more about the physics than about the grasp)."""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from datagen.dataset.loader import DatasetError, load
from datagen.dataset.parts import decode_parts
from datagen.grasp_model.inputs import GRASP_FEATURES, DepthView, grasp_inputs

LEFT_OUT = ("no_candidate", "disturbed")  # failure modes whose attempts are not examples


@dataclass
class GraspExamples:
    crops: np.ndarray  # (N, 1, S, S) float32
    features: np.ndarray  # (N, GRASP_FEATURES) float32
    success: np.ndarray  # (N,) bool
    attempts: list[str] = field(default_factory=list)  # "<campaign folder>/<key>" per example
    families: list[str] = field(default_factory=list)  # the target's class (shape family)
    modes: list[str | None] = field(default_factory=list)  # failure mode; None: it held
    # the scene each was tried in ("<seed>/<scene index>/<build attempt>"): several per scene
    # with campaign.grasps_per_scene, and campaigns of one seed share their scenes' draws (the
    # walk-through's antipodal and random campaigns try the same scenes), so not the folder
    scenes: list[str] = field(default_factory=list)
    left_out: Counter[str] = field(default_factory=Counter)  # failure mode -> attempts skipped

    def __len__(self) -> int:
        return len(self.success)

    def subset(self, rows: np.ndarray) -> GraspExamples:
        return GraspExamples(
            self.crops[rows],
            self.features[rows],
            self.success[rows],
            [self.attempts[i] for i in rows],
            [self.families[i] for i in rows],
            modes=[self.modes[i] for i in rows] if self.modes else [],
            scenes=[self.scenes[i] for i in rows] if self.scenes else [],
        )

    def scene_names(self) -> list[str]:
        """Each example's scene; an example of its own where none was recorded."""
        return self.scenes or list(self.attempts) or [str(i) for i in range(len(self))]


def depth_part(camera: str) -> str:
    """The part holding ``camera``'s depth in a campaign sample."""
    return "depth.png" if camera == "workspace" else f"{camera}.depth.png"


def campaign_examples(
    roots: Sequence[str | Path],
    camera: str = "wrist",
    size: int = 32,
    limit: int | None = None,
    on_progress: Callable[[int, int], None] | None = None,
) -> GraspExamples:
    """The examples of the campaigns in ``roots`` (at most ``limit`` attempts of each, in index
    order), seen by ``camera`` in crops of ``size`` pixels; DatasetError naming the folder for
    one that is not a campaign or lacks the camera's depth. ``on_progress(read, total)`` after
    each attempt read."""
    crops, features, success, attempts, families, modes, scenes = [], [], [], [], [], [], []
    left_out: Counter[str] = Counter()
    datasets = [(root, load(root)) for root in roots]
    total = sum(len(d) if limit is None else min(limit, len(d)) for _, d in datasets)
    read = 0
    for root, dataset in datasets:
        count = len(dataset) if limit is None else min(limit, len(dataset))
        for i in range(count):
            read += 1
            if on_progress:
                on_progress(read, total)
            meta = dataset.metadata(i)
            attempt = meta.get("attempt")
            if not isinstance(attempt, dict):
                raise DatasetError(
                    f"{root}: sample {dataset.keys[i]} has no attempt record: not a grasp "
                    "campaign (datagen campaign grasp)"
                )
            mode = attempt["outcome"]["failure_mode"]
            if attempt["grasp"] is None or mode in LEFT_OUT:
                left_out[mode] += 1
                continue
            item = decode_parts(dataset.raw(i, {depth_part(camera)}))
            depth = (
                item.get("depth")
                if camera == "workspace"
                else item.get("views", {}).get(camera, {}).get("depth")
            )
            views = meta.get("views", {})
            if depth is None or camera not in views:
                raise DatasetError(
                    f"{root}: sample {dataset.keys[i]} has no depth from the '{camera}' "
                    f"camera (part {depth_part(camera)}): choose a camera the campaign rendered"
                )
            view = DepthView.from_record(depth, views[camera]["camera"], meta["robot"])
            grasp = attempt["grasp"]
            crop, numbers = grasp_inputs(
                view, np.asarray(grasp["pose_world"]), grasp["width"], size
            )
            crops.append(crop[None])
            features.append(numbers)
            success.append(bool(attempt["outcome"]["success"]))
            attempts.append(f"{Path(root).name}/{dataset.keys[i]}")
            families.append(str(attempt["target"]["class"]))
            modes.append(None if attempt["outcome"]["success"] else mode)
            scenes.append(scene_of(meta))
        dataset.close()
    return GraspExamples(
        np.stack(crops) if crops else np.zeros((0, 1, size, size), np.float32),
        np.stack(features) if features else np.zeros((0, GRASP_FEATURES), np.float32),
        np.array(success, bool),
        attempts,
        families,
        left_out=left_out,
        modes=modes,
        scenes=scenes,
    )


def scene_of(meta: Mapping[str, Any]) -> str:
    """``<seed>/<scene index>/<build attempt>`` of a campaign sample: the attempts of one
    settled scene share it (``campaign.grasps_per_scene``; a retried build draws anew)."""
    attempt = meta["attempt"]
    index = (attempt.get("shared_scene") or {}).get("scene_index", attempt["index"])
    build = (meta.get("production") or {}).get("attempt", 0)
    return f"{attempt['scene_seed']}/{index}/{build}"
