"""What ``datagen inspect`` says of navigation episodes of several robots: success, SPL and path
lengths per robot, the delays that kept them apart, what their cameras saw."""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from typing import Any

import numpy as np

from datagen.records import SampleMetadata


def _agents(metas: Sequence[SampleMetadata]) -> list[dict[str, Any]]:
    return [a for m in metas for a in m["episode"]["agents"]]


def agents_summary(metas: Sequence[SampleMetadata], agents: list[dict[str, Any]]) -> dict[str, Any]:
    """What episodes of several agents (robots, drones) share in their summary: counts, the
    agents' success rate and mean lengths and SPL, what every camera saw per class."""
    seen = Counter(
        t["class"]
        for m in metas
        for f in m["frames"]
        for c in f["cameras"].values()
        for t in c["things"]
    )
    mean = lambda key, digits: round(float(np.mean([a[key] for a in agents])), digits)  # noqa: E731
    return {
        "episodes": len(metas),
        "frames": sum(m["episode"]["frames"] for m in metas),
        "families": dict(Counter(m["family"] for m in metas)),
        "success_rate": mean("success", 4),
        "mean_path_length_m": mean("path_length_m", 3),
        "mean_shortest_path_m": mean("shortest_path_m", 3),
        "mean_spl": mean("spl", 4),
        "frames_with_collision": sum(
            s["collision"] for m in metas for f in m["frames"] for s in f["agents"]
        ),
        "things_seen_per_class": dict(sorted(seen.items())),
    }


def fleet_distributions(metas: list[SampleMetadata]) -> dict[str, list[float]]:
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


def fleet_summary(metas: Sequence[SampleMetadata]) -> dict[str, Any]:
    agents = _agents(metas)
    return {"robots": len(agents)} | agents_summary(metas, agents)
