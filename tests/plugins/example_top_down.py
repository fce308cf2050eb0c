"""An example grasp sampler, ``top_down`` (docs/extending.md): a vertical approach over the
target's centre, closing across its narrower horizontal side. A pure function of its inputs."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from datagen.config.sections import CampaignConfig
from datagen.families.grasp_attempts.grasps import GraspCandidate
from datagen.families.grasp_attempts.gripper_geometry import GripperGeometry
from datagen.families.grasp_attempts.samplers.base import GraspTarget, Obstacles, SampleResult
from datagen.registries import Plugin


@dataclass(frozen=True)
class TopDownSampler:
    gripper: GripperGeometry  # the robot's: its opening and collision boxes
    clearance: float = 0.01  # metres added to the object's width
    name: str = "top_down"

    @classmethod
    def from_campaign(cls, campaign: CampaignConfig, gripper: GripperGeometry) -> TopDownSampler:
        return cls(gripper)

    def sample(self, rng, target: GraspTarget, obstacles: Obstacles, max_tries: int = 200):
        points = np.vstack([part.vertices for part in target.parts_world])
        lo, hi = points.min(axis=0), points.max(axis=0)
        extent = hi - lo
        axis = int(np.argmin(extent[:2]))  # close across the narrower side
        width = float(extent[axis] + self.clearance)
        if width > self.gripper.max_width:
            return SampleResult(None, 1, f"too wide: {width:.3f} m")
        closing = np.eye(3)[axis]
        approach = np.array([0.0, 0.0, -1.0])
        pose = np.eye(4)
        pose[:3, :3] = np.stack([np.cross(closing, approach), closing, approach], axis=1)
        pose[:3, 3] = [(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, hi[2] - min(0.02, extent[2] / 2)]
        return SampleResult(GraspCandidate(pose, width, self.name), 1, "top-down over the centre")


SAMPLER = Plugin("top_down", "example_top_down:TopDownSampler")
