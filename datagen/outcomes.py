"""A sample's outcome: whether it succeeded, and what campaign statistics group it by. The one
place that knows where each scene family keeps it in a sample's metadata (a grasp attempt's under
``attempt``, a navigation episode's under ``episode``); the live status, the manifest's campaign
statistics, the exports and the tools all read outcomes through here.

An outcome is plain JSON: ``{"kind": "grasp", "success", "sampler", "family", "failure_mode"}``
(``family``: the target's class; ``failure_mode``: None on success) or
``{"kind": "navigation", "success", "spl"}``.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

from datagen.records import Outcome


def grasp_outcome(attempt: Mapping[str, Any]) -> Outcome:
    """The outcome of a grasp attempt's record (``meta["attempt"]``)."""
    return {
        "kind": "grasp",
        "success": bool(attempt["outcome"]["success"]),
        "sampler": attempt["sampler"],
        "family": attempt["target"]["class"],
        "failure_mode": attempt["outcome"]["failure_mode"],
    }


def navigation_outcome(episode: Mapping[str, Any]) -> Outcome:
    """The outcome of a navigation episode's record (``meta["episode"]``)."""
    return {"kind": "navigation", "success": bool(episode["success"]), "spl": episode["spl"]}


def spl(success: bool, shortest_m: float, travelled_m: float) -> float:
    """Success weighted by path length (Anderson et al. 2018): ``shortest / max(travelled,
    shortest)`` when the agent succeeded, else 0 (6 decimals)."""
    return round(float(success) * shortest_m / max(travelled_m, shortest_m, 1e-9), 6)


def agents_outcome(agents: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """An episode of several agents (drones, robots) as a whole, from each agent's record: every
    one succeeded; SPL and path lengths averaged over them (``round``: 6 decimals)."""
    mean = lambda key: round(sum(float(a[key]) for a in agents) / len(agents), 6)  # noqa: E731
    return {
        "success": all(bool(a["success"]) for a in agents),
        "spl": mean("spl"),
        "path_length_m": mean("path_length_m"),
        "shortest_path_m": mean("shortest_path_m"),
    }


# the metadata key of each family's record -> its outcome
OUTCOME_RECORDS: dict[str, Callable[[Mapping[str, Any]], Outcome]] = {
    "attempt": grasp_outcome,
    "episode": navigation_outcome,
}


def sample_outcome(meta: Mapping[str, Any]) -> Outcome | None:
    """The outcome of a sample from its metadata; None for a sample without one."""
    for key, outcome in OUTCOME_RECORDS.items():
        if isinstance(meta.get(key), dict):
            return outcome(meta[key])
    return None
