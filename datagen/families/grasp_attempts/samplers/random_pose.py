"""Baseline: a TCP anywhere near the object, any orientation, fingers fully open."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import trimesh

from datagen.config.sections import CampaignConfig
from datagen.families.grasp_attempts.grasps import GraspCandidate
from datagen.families.grasp_attempts.gripper_geometry import GripperGeometry
from datagen.families.grasp_attempts.samplers.base import (
    GraspTarget,
    Obstacles,
    Reachable,
    SampleResult,
)
from datagen.grasp_model.inputs import DepthView


def random_rotation(rng: np.random.Generator) -> np.ndarray:
    """A rotation matrix uniform on SO(3) (a normalised 4D Gaussian is a uniform quaternion)."""
    quat = rng.normal(size=4)
    return trimesh.transformations.quaternion_matrix(quat / np.linalg.norm(quat))[:3, :3]


@dataclass(frozen=True)
class RandomSampler:
    gripper: GripperGeometry
    margin: float = 0.03  # metres the target's bounding box is grown by
    name: str = "random"

    @classmethod
    def from_campaign(cls, campaign: CampaignConfig, gripper: GripperGeometry) -> RandomSampler:
        return cls(gripper)

    def sample(
        self,
        rng: np.random.Generator,
        target: GraspTarget,
        obstacles: Obstacles,
        max_tries: int = 200,
        view: DepthView | None = None,
        reachable: Reachable | None = None,  # refused by the config: one pose, no choice
    ) -> SampleResult:
        lo = np.min([part.bounds[0] for part in target.parts_world], axis=0) - self.margin
        hi = np.max([part.bounds[1] for part in target.parts_world], axis=0) + self.margin
        for tries in range(1, max_tries + 1):
            position = rng.uniform(lo, hi)
            if position[2] <= obstacles.table_z:
                continue
            pose = np.eye(4)
            pose[:3, :3] = random_rotation(rng)
            pose[:3, 3] = position
            candidate = GraspCandidate(
                pose, self.gripper.max_width, self.name, info={"tries": tries}
            )
            return SampleResult(candidate, tries, "sampled")
        return SampleResult(
            None, max_tries, f"no TCP position above the table (z > {obstacles.table_z})"
        )
