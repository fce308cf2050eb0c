"""Grasp candidate samplers: pure functions of (rng, target, obstacles), no simulator.

Adding a sampler: a module with a class that has ``name``, ``from_campaign`` and ``sample`` (see
``GraspSampler`` in ``base.py``) and one line in ``datagen.registries.SAMPLERS``.
"""

from __future__ import annotations

from datagen.families.grasp_attempts.samplers.base import (
    GraspSampler,
    GraspTarget,
    Obstacles,
    SampleResult,
)

__all__ = ["GraspSampler", "GraspTarget", "Obstacles", "SampleResult"]
