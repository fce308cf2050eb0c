"""``datagen.nav_episode/1``: one ground robot's episode, its camera's frames over time (parts
``f0003.rgb.png``, ...; records in ``frames``), its episode record (``episode``: path lengths,
SPL, trajectory, layout) and its map (``map.png``, ``occupancy.png``)."""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from typing import Any

import numpy as np

from datagen.dataset.episode_parts import (
    FRAME_IMAGES,
    MAP_PICTURES,
    OCCUPANCY_PICTURE,
    POSE_FILES,
)
from datagen.dataset.views import labelled_views, sequence_views
from datagen.exports.episodes import Episode, frame_actions, ground_episode, on_grid
from datagen.formats.counting import histogram
from datagen.outcomes import navigation_outcome
from datagen.records import ExportedDataset, Manifest, SampleMetadata
from datagen.tools.preview import navigation_tile

views = sequence_views
PARTS = (FRAME_IMAGES, POSE_FILES, MAP_PICTURES, OCCUPANCY_PICTURE)


def summary(metas: Sequence[SampleMetadata]) -> dict[str, Any]:
    episodes_ = [m["episode"] for m in metas]
    things = Counter(t["class"] for m in metas for f in m["frames"] for t in f["things"])
    mean = lambda key, digits: round(float(np.mean([e[key] for e in episodes_])), digits)  # noqa: E731
    return {
        "episodes": len(episodes_),
        "frames": sum(e["frames"] for e in episodes_),
        "families": dict(Counter(m["family"] for m in metas)),
        "success_rate": round(
            float(np.mean([navigation_outcome(e)["success"] for e in episodes_])), 4
        ),
        "mean_path_length_m": mean("path_length_m", 3),
        "mean_shortest_path_m": mean("shortest_path_m", 3),
        "mean_spl": mean("spl", 4),
        "frames_with_collision": sum(f["collision"] for m in metas for f in m["frames"]),
        "things_seen_per_class": dict(sorted(things.items())),
        "spl_histogram": histogram([e["spl"] for e in episodes_]),
    }


def distributions(metas: list[SampleMetadata]) -> dict[str, list[float]]:
    episodes_ = [m["episode"] for m in metas]
    return {
        "path length (m)": [e["path_length_m"] for e in episodes_],
        "shortest path (m)": [e["shortest_path_m"] for e in episodes_],
        "SPL": [e["spl"] for e in episodes_],
        "frames per episode": [e["frames"] for e in episodes_],
        "obstacles": [len(e["layout"]["obstacles"]) for e in episodes_],
        "wall height (m)": [m["randomisation"]["wall_height"] for m in metas],
        "camera height (m)": [m["camera"]["height_m"] for m in metas],
        "camera pitch down (deg)": [m["camera"]["pitch_down_deg"] for m in metas],
        "camera fovy (deg)": [m["camera"]["fovy_deg"] for m in metas],
    }


def summary_fields(meta: SampleMetadata) -> SampleMetadata:
    """``meta`` cut to what :func:`summary` reads: the episode without its trajectory, layout
    and path, each frame's collision and the classes it saw."""
    heavy = ("trajectory", "layout", "planned_path")
    cut = {
        "format": meta["format"],
        "family": meta["family"],
        "episode": {k: v for k, v in meta["episode"].items() if k not in heavy},
        "frames": [
            {"collision": f["collision"], "things": [{"class": t["class"]} for t in f["things"]]}
            for f in meta["frames"]
        ],
    }
    return cut  # type: ignore[return-value]


def tile(item: dict[str, Any]) -> np.ndarray:
    """The middle frame annotated with the robot's planned path, above the map."""
    meta, frames = item["meta"], item["frames"]
    k = len(frames) // 2
    path = meta["episode"]["planned_path"]
    return navigation_tile(item, k, frames[k], meta["camera"], path, meta["episode"])


def episodes(
    meta: SampleMetadata, dataset: ExportedDataset, i: int, manifest: Manifest
) -> list[Episode]:
    """The episode at ``navigation.frame_rate_hz``: camera ``head`` with depth; state x, y, yaw;
    action the commands between one frame and the next (docs/exports.md)."""
    fps = float(manifest["config"]["navigation"]["frame_rate_hz"])
    seen = labelled_views(meta)
    seen = [seen[n] for n in on_grid([v.record for v in seen], fps)]
    records = [v.record for v in seen]
    trajectory = meta["episode"]["trajectory"]
    action = frame_actions(trajectory, records, fps, 0.0, "episode.trajectory")
    success = bool(meta["episode"]["success"])
    prefixes = [v.prefix for v in seen]
    return [ground_episode(meta, fps, meta["key"], records, success, prefixes, action)]
