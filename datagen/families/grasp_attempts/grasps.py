"""A grasp candidate (what a sampler proposes), its outcome (what executing it did) and the
failure modes an outcome names; pose convention: :mod:`datagen.families.grasp_attempts`."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

# "disturbed": an object moved faster than the hand could push it (datagen.families.grasp_attempts.disturbance)
FAILURE_MODES = ("missed", "slipped", "collision", "unreachable", "no_candidate", "disturbed")


@dataclass(frozen=True)
class GraspCandidate:
    pose_world: np.ndarray  # (4, 4) TCP pose, see the module docstring
    width: float  # metres the fingers must open to enclose the object there
    sampler: str
    contacts_world: np.ndarray | None = None  # (2, 3) contact points, antipodal sampler only
    info: dict[str, Any] = field(default_factory=dict)

    @property
    def approach(self) -> np.ndarray:
        return self.pose_world[:3, 2]

    @property
    def closing(self) -> np.ndarray:
        return self.pose_world[:3, 1]

    def to_json(self) -> dict[str, Any]:
        out = {
            "sampler": self.sampler,
            "pose_world": np.round(self.pose_world, 7).tolist(),
            "width": round(float(self.width), 6),
            "approach": np.round(self.approach, 7).tolist(),
            "closing": np.round(self.closing, 7).tolist(),
        }
        if self.contacts_world is not None:
            out["contacts_world"] = np.round(self.contacts_world, 7).tolist()
        return out | ({"info": self.info} if self.info else {})


@dataclass(frozen=True)
class GraspOutcome:
    success: bool
    failure_mode: str | None  # one of FAILURE_MODES, None on success
    lift_height: float  # metres the target's centre rose between grasp and the end of the hold
    gripper_width: float  # metres between the fingers at the end of the hold
    details: dict[str, Any] = field(default_factory=dict)
    # the grasp as executed (datagen.families.grasp_attempts.executed), for attempt.grasp: not in to_json
    executed: dict[str, Any] | None = None

    def to_json(self) -> dict[str, Any]:
        return {
            "success": self.success,
            "failure_mode": self.failure_mode,
            "lift_height": round(float(self.lift_height), 6),
            "gripper_width": round(float(self.gripper_width), 6),
            **({"details": self.details} if self.details else {}),
        }
