"""One aerial episode, without the simulator: the volume, the drones' sizes, their flights and
take-off times, and the lower bound on each drone's path length.

Random streams (``datagen.seeding.sample_rng(seed, index, name)``): ``nav_layout`` for the floor
plan (the same plan a ground episode of that index and family drives), ``aerial_volume`` for its
heights and flyer-only solids, ``aerial_drones`` for the drones' sizes, ``aerial_task`` for the
starts, goals and flights. When the drones cannot all be given flights, everything is drawn again
from ``<stream>/1``, ``<stream>/2``, ...: still a function of (seed, index) alone.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from datagen.config.aerial import AerialConfig
from datagen.families.aerial.airframe import bounding_radius, camera_reach, drone_shape
from datagen.families.aerial.fleet import Agent, FleetError, plan_fleet
from datagen.families.aerial.planning import FlightLimits
from datagen.families.aerial.volumes import Volume, VolumeParams, make_volume, voxelise
from datagen.floorplans.geodesic import lower_bound_grid, shortest_length
from datagen.floorplans.layouts import make_layout
from datagen.registries import AIRFRAMES, LAYOUTS
from datagen.registry import resolve
from datagen.seeding import sample_rng

ATTEMPTS = 8
HOVER_AFTER_S = 0.5  # seconds the episode runs on after the last drone arrives


class AerialPlanningError(RuntimeError):
    """No volume out of ``ATTEMPTS`` gave every drone a flight."""


@dataclass
class AerialEpisode:
    volume: Volume
    shapes: list[Any]  # each drone's airframe shape (aerial.airframe), with its span
    limits: list[FlightLimits]
    agents: list[Agent]
    attempt: int

    @property
    def duration(self) -> float:
        return max(a.landing for a in self.agents) + HOVER_AFTER_S


def volume_params(cfg: AerialConfig, clearance: float) -> VolumeParams:
    return VolumeParams(
        resolution=cfg.voxel_size,
        height=cfg.height,
        pillars=cfg.pillars,
        beams=cfg.beams,
        hanging=cfg.hanging,
        screens=cfg.screens,
        window_probability=cfg.window_probability,
        clearance=clearance,
    )


def flight_limits(cfg: AerialConfig, radius: float) -> FlightLimits:
    return FlightLimits(
        radius=radius,
        margin=cfg.margin,
        max_speed=cfg.max_speed,
        max_acceleration=cfg.max_acceleration,
        max_thrust=cfg.max_thrust,
        min_thrust=cfg.min_thrust,
        max_body_rate=cfg.max_body_rate,
    )


def plan_aerial_episode(cfg: AerialConfig, seed: int, index: int, retry: int = 0) -> AerialEpisode:
    reasons, airframe = [], AIRFRAMES[cfg.airframe]
    for attempt in range(ATTEMPTS):
        suffix = f"/{attempt}" if attempt else ""
        sizes = sample_rng(seed, index, "aerial_drones" + suffix, retry)
        shapes = [
            drone_shape(airframe, round(float(sizes.uniform(*cfg.span)), 4))
            for _ in range(cfg.drones)
        ]
        # a stereo pair's right camera may reach beyond the drone's parts: planned with it
        radii = [
            max(bounding_radius(airframe, s), camera_reach(airframe, s, cfg.stereo_baseline))
            for s in shapes
        ]
        limits = [flight_limits(cfg, radius) for radius in radii]
        layout = make_layout(
            cfg.family,
            sample_rng(seed, index, "nav_layout" + suffix, retry),
            resolve(LAYOUTS[cfg.family].params)(),
        )
        clearance = max(lim.clearance for lim in limits)
        volume = make_volume(
            sample_rng(seed, index, "aerial_volume" + suffix, retry),
            layout,
            volume_params(cfg, clearance),
        )
        try:
            agents = plan_fleet(
                sample_rng(seed, index, "aerial_task" + suffix, retry),
                volume,
                limits,
                cfg.min_goal_distance,
            )
        except FleetError as exc:
            reasons.append(str(exc))
            continue
        return AerialEpisode(volume, shapes, limits, agents, attempt)
    raise AerialPlanningError(
        f"episode {index}: no {cfg.family} volume out of {ATTEMPTS} gave {cfg.drones} drone(s) "
        f"flights aerial.min_goal_distance={cfg.min_goal_distance} m long with their clearance; "
        f"lower those or the flyer-only solids (last reason: {reasons[-1]})"
    )


def path_lower_bound(volume: Volume, agent: Agent, limits: FlightLimits) -> float:
    """Metres no collision-free flight from the agent's start to its goal (the centre, where the
    expert flies: SPL's shortest path as Habitat's, to the goal's position) can be shorter than:
    its horizontal part cannot beat the shortest path round the solids that fill a whole column
    from floor to ceiling (a flyer passes every other one above, below or through it), computed
    as for ground robots (:mod:`datagen.floorplans.geodesic`) with the drone's radius, and its
    vertical part cannot beat the height difference; a curve is at least as long as
    sqrt(horizontal² + vertical²) of those."""
    r = volume.resolution
    inner = voxelise([_shrunk(s.box, r) for s in volume.solids], volume.shape, r)
    # (ny, nx): columns solid from the floor to the last whole voxel under the ceiling (the
    # slab above it is thinner than a voxel, and a drone is wider: it cannot pass there)
    walls = inner[: max(int(volume.height / r), 1)].all(axis=0)
    step = limits.max_speed * 0.01  # metres between two checked positions of a flight
    occupied = lower_bound_grid(walls, r, limits.radius, step)
    horizontal = shortest_length(occupied, r, tuple(agent.start[:2]), tuple(agent.goal[:2]))
    vertical = abs(agent.goal[2] - agent.start[2])
    return math.hypot(horizontal, vertical)


def _shrunk(box, resolution: float):
    """A box whose voxels are only those it fills entirely (its inner voxelisation)."""
    x0, y0, z0, x1, y1, z1 = box
    inner = [math.ceil(v / resolution - 1e-9) * resolution for v in (x0, y0, z0)]
    outer = [math.floor(v / resolution + 1e-9) * resolution for v in (x1, y1, z1)]
    return (*[v + 1e-6 for v in inner], *[v - 1e-6 for v in outer])


def flown_length(agent: Agent, dt: float = 0.01) -> float:
    """Metres along the agent's trajectory (sampled every ``dt`` seconds)."""
    time = np.append(np.arange(0.0, agent.flight.duration, dt), agent.flight.duration)
    points = agent.flight.path.evaluate(time)
    return float(np.linalg.norm(np.diff(points, axis=0), axis=1).sum())
