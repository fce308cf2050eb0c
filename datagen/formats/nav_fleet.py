"""``datagen.nav_fleet/1``: ground robots sharing one floor plan, each with its own camera over
time (parts ``f0003.r0.rgb.png``, ...; records in ``frames``, per camera under ``cameras``), its
own path and start delay (``episode.agents``); the map (``map.png``, ``occupancy.png``)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from datagen.dataset.episode_parts import (
    CAMERA_FRAMES,
    MAP_PICTURES,
    OCCUPANCY_PICTURE,
    POSE_FILES,
)
from datagen.dataset.views import camera_sequence_views
from datagen.exports.episodes import Episode, frame_actions, ground_episode, on_grid
from datagen.formats.counting import agent_fields, agents_summary
from datagen.records import ExportedDataset, Manifest, SampleMetadata
from datagen.tools.preview import navigation_tile

views = camera_sequence_views
PARTS = (CAMERA_FRAMES, POSE_FILES, MAP_PICTURES, OCCUPANCY_PICTURE)


def _agents(metas: Sequence[SampleMetadata]) -> list[dict[str, Any]]:
    return [a for m in metas for a in m["episode"]["agents"]]


def summary(metas: Sequence[SampleMetadata]) -> dict[str, Any]:
    agents = _agents(metas)
    return {"robots": len(agents)} | agents_summary(metas, agents)


def distributions(metas: list[SampleMetadata]) -> dict[str, list[float]]:
    agents = _agents(metas)
    return {
        "path length (m)": [a["path_length_m"] for a in agents],
        "shortest path (m)": [a["shortest_path_m"] for a in agents],
        "SPL": [a["spl"] for a in agents],
        "start delay (s)": [a["delay_s"] for a in agents],
        "robots per episode": [len(m["episode"]["agents"]) for m in metas],
        "frames per episode": [m["episode"]["frames"] for m in metas],
        "wall height (m)": [m["randomisation"]["wall_height"] for m in metas],
        "camera height (m)": [c["height_m"] for m in metas for c in m["cameras"].values()],
        "camera pitch down (deg)": [
            c["pitch_down_deg"] for m in metas for c in m["cameras"].values()
        ],
    }


def summary_fields(meta: SampleMetadata) -> SampleMetadata:
    return agent_fields(meta, ())  # type: ignore[return-value]


def tile(item: dict[str, Any]) -> np.ndarray:
    """Robot 0's camera at the middle frame, with robot 0's own planned path, above the map."""
    meta, frames = item["meta"], item["frames"]
    k = len(frames) // 2
    record, seen = meta["frames"][k], meta["frames"][k]["cameras"]["r0"]
    frame = frames[k]["cameras"]["r0"] | {"meta": record["agents"][0] | seen}
    path = meta["episode"]["agents"][0]["planned_path"]
    return navigation_tile(item, k, frame, meta["cameras"]["r0"], path, meta["episode"])


def episodes(
    meta: SampleMetadata, dataset: ExportedDataset, i: int, manifest: Manifest
) -> list[Episode]:
    """One episode per robot (key ``<sample>.r<k>``), as a single robot's, its camera ``r<k>``
    named ``head``."""
    fps = float(manifest["config"]["navigation"]["frame_rate_hz"])
    records = [meta["frames"][n] for n in on_grid(meta["frames"], fps)]
    return [_robot(meta, records, fps, k) for k in range(len(meta["episode"]["agents"]))]


def _robot(
    meta: SampleMetadata, records: Sequence[Mapping[str, Any]], fps: float, k: int
) -> Episode:
    agent, key = meta["episode"]["agents"][k], f"{meta['key']}.r{k}"
    where = f"episode.agents[{k}].trajectory"
    action = frame_actions(agent["trajectory"], records, fps, float(agent["delay_s"]), where)
    states = [r["agents"][k] for r in records]
    prefixes = [f"f{r['frame']:04d}.r{k}." for r in records]
    return ground_episode(meta, fps, key, states, bool(agent["success"]), prefixes, action)
