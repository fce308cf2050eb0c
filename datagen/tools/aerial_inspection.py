"""What ``datagen inspect`` says of aerial episodes: success, SPL and path lengths per drone, and
the altitude and speed of every drone in every frame."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from datagen.records import SampleMetadata
from datagen.tools.fleet_inspection import agents_summary


def _agents(metas: Sequence[SampleMetadata]) -> list[dict[str, Any]]:
    return [a for m in metas for a in m["episode"]["agents"]]


def _states(metas: Sequence[SampleMetadata]) -> list[dict[str, Any]]:
    return [s for m in metas for f in m["frames"] for s in f["agents"]]


def aerial_distributions(metas: list[SampleMetadata]) -> dict[str, list[float]]:
    agents, states = _agents(metas), _states(metas)
    return {
        "path length (m)": [a["path_length_m"] for a in agents],
        "shortest path (m)": [a["shortest_path_m"] for a in agents],
        "SPL": [a["spl"] for a in agents],
        "flight time (s)": [a["flight_s"] for a in agents],
        "altitude (m)": [s["position"][2] for s in states],
        "speed (m/s)": [float(np.linalg.norm(s["velocity"])) for s in states],
        "drones per episode": [len(m["episode"]["agents"]) for m in metas],
        "frames per episode": [m["episode"]["frames"] for m in metas],
        "ceiling height (m)": [m["episode"]["volume"]["height"] for m in metas],
    }


def aerial_summary(metas: Sequence[SampleMetadata]) -> dict[str, Any]:
    agents, states = _agents(metas), _states(metas)
    speeds = [float(np.linalg.norm(s["velocity"])) for s in states]
    return (
        {"drones": len(agents)}
        | agents_summary(metas, agents)
        | {
            "altitude_m": [
                round(min(s["position"][2] for s in states), 3),
                round(max(s["position"][2] for s in states), 3),
            ],
            "mean_speed_m_s": round(float(np.mean(speeds)), 3),
            "max_speed_m_s": round(float(np.max(speeds)), 3),
        }
    )
