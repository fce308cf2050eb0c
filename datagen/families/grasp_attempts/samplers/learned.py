"""Learned grasps: the antipodal sampler draws up to K candidates (each contact pair it finds
gives up to ``approaches_per_pair`` of them: its clear approaches), a grasp-quality model scores
each from what the camera sees of it (``datagen.grasp_model.inputs``), and the best is executed
(with ``campaign.check_reach``, the best the arm reaches: ``grasp_attempts.reach``).

The model is a file the user names (``campaign.model``; ONNX, ``datagen.grasp_model.model_file``
states the contract), so datagen's own model (``datagen train grasp``) and a user's plug in the
same way. The candidates come from the attempt's ``grasp`` stream in order and the model scores
on one thread, so an attempt is reproduced from (seed, index, the model's sha256)."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from datagen.config.sections import CampaignConfig
from datagen.families.grasp_attempts.grasps import GraspCandidate
from datagen.families.grasp_attempts.gripper_geometry import GripperGeometry
from datagen.families.grasp_attempts.samplers.antipodal import (
    APPROACHES_PER_PAIR,
    AntipodalSampler,
)
from datagen.families.grasp_attempts.samplers.base import (
    GraspTarget,
    Obstacles,
    Reachable,
    SampleResult,
    choose_reached,
)
from datagen.grasp_model.inputs import DepthView, grasp_batch
from datagen.grasp_model.model_file import GraspModel, cached_model


@dataclass(frozen=True)
class LearnedSampler:
    antipodal: AntipodalSampler
    model: GraspModel
    candidates: int  # K: antipodal candidates drawn and scored per attempt
    # candidates a contact pair may give (its clear approaches); the model tells them apart
    approaches_per_pair: int = APPROACHES_PER_PAIR
    name: str = "learned"

    @classmethod
    def from_campaign(cls, campaign: CampaignConfig, gripper: GripperGeometry) -> LearnedSampler:
        if not campaign.model:
            raise ValueError("campaign.model: the learned sampler needs a model file")
        model = cached_model(campaign.model, campaign.model_sha256)
        return cls(AntipodalSampler.from_campaign(campaign, gripper), model, campaign.candidates)

    def sample(
        self,
        rng: np.random.Generator,
        target: GraspTarget,
        obstacles: Obstacles,
        max_tries: int = 200,
        view: DepthView | None = None,
        reachable: Reachable | None = None,
    ) -> SampleResult:
        if view is None:
            raise ValueError("the learned sampler scores candidates from a depth view: none given")
        scores: list[float] = []

        def draw() -> tuple[list[GraspCandidate], int, str]:
            return self.antipodal.draw(
                rng, target, obstacles, self.candidates, max_tries, self.approaches_per_pair
            )

        def rank(found: list[GraspCandidate]) -> list[int]:
            crops, features = grasp_batch(
                view, [(c.pose_world, c.width) for c in found], self.model.crop_size
            )
            scored = self.model.score(crops, features)
            scores.extend(round(float(s), 6) for s in scored)
            return [int(i) for i in np.argsort(-scored, kind="stable")]  # ties: first first

        if reachable is None:
            found, tries, reason = draw()
            if not found:
                return SampleResult(None, tries, reason)
            best = rank(found)[0]
        else:
            reached = choose_reached(draw, rank, reachable)
            if reached.chosen < 0:
                return SampleResult(None, reached.tries, reached.reason)
            found, best, tries = reached.drawn, reached.chosen, reached.tries
        info = found[best].info | {"candidates": len(found), "scores": scores, "chosen": best}
        chosen = dataclasses.replace(found[best], sampler=self.name, info=info)
        which = "the best" if reachable is None else "the best the arm reaches"
        return SampleResult(chosen, tries, f"{which} of {len(found)} by the model")
