"""Grasp candidate samplers: pure functions of (rng, target, obstacles), no simulator.

Adding a sampler: a module with a class that has ``name`` and ``sample`` (see ``GraspSampler``)
and one line in ``SAMPLERS``.
"""

from __future__ import annotations

from typing import Any

from datagen.grasping.samplers.antipodal import AntipodalSampler
from datagen.grasping.samplers.base import (
    GraspSampler,
    GraspTarget,
    Obstacles,
    SampleResult,
)
from datagen.grasping.samplers.random import RandomSampler

SAMPLERS: dict[str, type] = {
    "random": RandomSampler,
    "antipodal": AntipodalSampler,
}

__all__ = [
    "SAMPLERS",
    "GraspSampler",
    "GraspTarget",
    "Obstacles",
    "SampleResult",
    "make_sampler",
]


def make_sampler(name: str, **params: Any) -> GraspSampler:
    """The sampler registered as ``name``, built with ``params`` (its keyword arguments)."""
    if name not in SAMPLERS:
        raise ValueError(f"unknown grasp sampler {name!r}; known samplers: {sorted(SAMPLERS)}")
    return SAMPLERS[name](**params)
