"""Counting helpers the formats' summaries share."""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from typing import Any

import numpy as np

from datagen.records import SampleMetadata


def histogram(values: list[float], bins: int = 5) -> dict[str, int]:
    """Counts of ``values`` in ``bins`` equal bins over [0, 1], keyed ``"0.0-0.2"``, ..."""
    counts, edges = np.histogram(values, bins=bins, range=(0, 1))
    return {
        f"{lo:.1f}-{hi:.1f}": int(c) for lo, hi, c in zip(edges, edges[1:], counts, strict=False)
    }


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


def agent_fields(meta: SampleMetadata, state_keys: tuple[str, ...]) -> dict[str, Any]:
    """An episode of several agents cut to what :func:`agents_summary` reads, with the
    ``state_keys`` of each agent's state per frame (the collision flag always)."""
    totals = ("success", "path_length_m", "shortest_path_m", "spl")
    return {
        "format": meta["format"],
        "family": meta["family"],
        "episode": {
            "frames": meta["episode"]["frames"],
            "agents": [{k: a[k] for k in totals} for a in meta["episode"]["agents"]],
        },
        "frames": [
            {
                "cameras": {
                    name: {"things": [{"class": t["class"]} for t in seen["things"]]}
                    for name, seen in f["cameras"].items()
                },
                "agents": [{k: s[k] for k in ("collision", *state_keys)} for s in f["agents"]],
            }
            for f in meta["frames"]
        ],
    }
