"""What every grasp sampler takes and returns."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import Protocol

import numpy as np
import trimesh

from datagen.assets.shapes import ObjectGeometry
from datagen.config.sections import CampaignConfig
from datagen.convex import ConvexBody
from datagen.families.grasp_attempts.grasps import GraspCandidate
from datagen.families.grasp_attempts.gripper_geometry import GripperGeometry
from datagen.grasp_model.inputs import DepthView

TABLE_Z = 0.75  # metres, the grasping scene's table top


@dataclass(frozen=True)
class GraspTarget:
    """The object to grasp: its convex parts in the world frame, and its pose; and, for an arm
    that reaches it only from one vertical plane, that plane."""

    parts_world: list[trimesh.Trimesh]
    pose_world: np.ndarray  # (4, 4)
    # (x, y) world metres of a five-joint arm's shoulder axis (pan, three pitch joints, wrist
    # roll): its approaches lie in the vertical plane through this axis and the grasp. Samplers
    # that choose approaches honour it; the random baseline draws any pose.
    approach_plane_through: tuple[float, float] | None = None

    @classmethod
    def from_geometry(cls, geometry: ObjectGeometry, pose_world: np.ndarray) -> GraspTarget:
        pose = np.asarray(pose_world, float)
        return cls([part.copy().apply_transform(pose) for part in geometry.parts], pose)

    @cached_property
    def bodies(self) -> list[ConvexBody]:
        return [ConvexBody.from_mesh(part) for part in self.parts_world]


@dataclass(frozen=True)
class Obstacles:
    """Everything but the target the gripper must not touch: convex meshes in the world frame
    (the other objects' parts, the tray's boxes) and the table top, the half-space z < table_z.
    A non-convex mesh is treated as its convex hull."""

    meshes_world: list[trimesh.Trimesh]
    table_z: float = TABLE_Z

    @cached_property
    def bodies(self) -> list[ConvexBody]:
        return [ConvexBody.from_mesh(mesh) for mesh in self.meshes_world]


@dataclass(frozen=True)
class SampleResult:
    candidate: GraspCandidate | None
    tries: int
    reason: str  # why sampling failed, or how the candidate was found


# whether the arm reaches a candidate as execution will plan it (``grasp_attempts.reach``)
Reachable = Callable[[GraspCandidate], bool]


def first_reached(
    ranked: Sequence[GraspCandidate], reachable: Reachable
) -> tuple[int, GraspCandidate]:
    """(its position in ``ranked``, the candidate): the first the arm reaches, else the first
    (it will fail, unreachable); its ``info`` says how many were checked and whether it was
    reached."""
    for checked, candidate in enumerate(ranked, 1):
        if reachable(candidate):
            info = candidate.info | {"reach_checked": checked, "reached": True}
            return checked - 1, dataclasses.replace(candidate, info=info)
    info = ranked[0].info | {"reach_checked": len(ranked), "reached": False}
    return 0, dataclasses.replace(ranked[0], info=info)


class GraspSampler(Protocol):
    """What ``datagen.registries.SAMPLERS`` names: a class built from the campaign section and
    the robot's gripper (its opening and collision boxes). ``view`` is the pre-grasp depth of
    the campaign's ``model_camera``, for samplers that look (the learned one); the others
    ignore it. ``reachable``, when the campaign checks reach, tells a sampler with candidates to
    choose among which ones the arm reaches; the random sampler draws one pose and is not
    given it (the config refuses ``check_reach`` there)."""

    name: str

    @classmethod
    def from_campaign(cls, campaign: CampaignConfig, gripper: GripperGeometry) -> GraspSampler: ...

    def sample(
        self,
        rng: np.random.Generator,
        target: GraspTarget,
        obstacles: Obstacles,
        max_tries: int = 200,
        view: DepthView | None = None,
        reachable: Reachable | None = None,
    ) -> SampleResult: ...
