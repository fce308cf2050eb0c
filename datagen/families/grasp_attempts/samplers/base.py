"""What every grasp sampler takes and returns."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
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
# one round of candidates: (candidates, tries, reason), no candidate when the sampler found none
Draw = Callable[[], tuple[list[GraspCandidate], int, str]]
Rank = Callable[[list[GraspCandidate]], list[int]]  # a round's indices, best first
# rounds of K candidates drawn while none drawn is reached, a round that found none included:
# 3 of the panda's 11 unreachable attempts on held-out objects had 1-2 candidates in one round,
# none reached, where 400 tries found reached ones; 4 of its 32 attempts without a candidate in
# 200 tries had one in 400 (docs/campaigns.md)
REACH_ROUNDS = 3


@dataclass(frozen=True)
class Reached:
    """What :func:`choose_reached` drew and chose."""

    drawn: list[GraspCandidate]  # every candidate, round after round, in the order drawn
    chosen: int  # index into ``drawn``; -1 when no round found any
    tries: int  # summed over the rounds
    reason: str  # the last round's


def choose_reached(
    draw: Draw, rank: Rank, reachable: Reachable, rounds: int = REACH_ROUNDS
) -> Reached:
    """Draws a round of candidates, ranks it and takes the first the arm reaches; while none is
    reached (a round that found none included), draws another round, up to ``rounds``. None
    reached: the best of the first round that found any (it will fail, unreachable). The chosen
    candidate's ``info`` says how many were planned (``reach_checked``), whether it was reached
    and in how many rounds (``reach_rounds``)."""
    drawn: list[GraspCandidate] = []
    checked = tries = best = 0
    reason = ""
    for done in range(1, rounds + 1):
        found, spent, reason = draw()
        tries += spent
        if not found:
            continue
        start = len(drawn)
        drawn += found
        order = rank(found)
        best = best if start else order[0]
        for i in order:
            checked += 1
            if reachable(found[i]):
                chosen = start + i
                return Reached(_marked(drawn, chosen, checked, True, done), chosen, tries, reason)
    if not drawn:
        each = f", in each of {rounds} rounds" if rounds > 1 else ""
        return Reached([], -1, tries, reason + each)
    return Reached(_marked(drawn, best, checked, False, done), best, tries, reason)


def _marked(
    drawn: list[GraspCandidate], chosen: int, checked: int, reached: bool, rounds: int
) -> list[GraspCandidate]:
    info = drawn[chosen].info | {
        "reach_checked": checked,
        "reached": reached,
        "reach_rounds": rounds,
    }
    marked = list(drawn)
    marked[chosen] = dataclasses.replace(drawn[chosen], info=info)
    return marked


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
