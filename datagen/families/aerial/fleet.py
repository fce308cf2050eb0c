"""Several drones in one volume: their starts and goals, their expert flights, and take-off times
that keep every pair apart.

Each drone hovers at its start until its take-off time, flies its own flight
(:func:`datagen.families.aerial.planning.plan_flight`) and hovers at its goal afterwards. Take-off times
are chosen drone after drone (0, ``DELAY_STEP``, 2 ``DELAY_STEP``, ... seconds) so that, sampled
every ``CHECK_DT`` seconds over the whole episode, every two drones' centres stay at least
:func:`separation` apart (two radii and a margin): the experts never collide, separated in
time where their paths cross and in space where they do not. A drone that no delay up to
``MAX_DELAY`` separates is drawn again (start, goal, flight) from the same stream.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from datagen.families.aerial.flatness import FlatStates
from datagen.families.aerial.planning import (
    Flight,
    FlightError,
    FlightLimits,
    plan_flight,
    voxel_centre,
)
from datagen.families.aerial.volumes import Volume, free_space

CHECK_DT = 0.02  # seconds between separation checks
DELAY_STEP = 0.5  # seconds between tried take-off times
MAX_DELAY = 30.0  # seconds
DRAWS = 12  # start/goal pairs drawn per drone before the episode is given up
_SIX = ndimage.generate_binary_structure(3, 1)


class FleetError(RuntimeError):
    """No start, goal, flight or take-off time for a drone after ``DRAWS`` draws."""


@dataclass(frozen=True)
class Agent:
    start: np.ndarray  # (3,) metres
    goal: np.ndarray  # (3,) metres
    flight: Flight
    take_off: float  # seconds after the episode starts

    @property
    def landing(self) -> float:
        return self.take_off + self.flight.duration

    def states(self, time: np.ndarray) -> FlatStates:
        """States at episode ``time`` (seconds): at rest at the start before take-off, at the
        goal after arriving."""
        return self.flight.states(np.asarray(time, float) - self.take_off)


def closest_approach(a: Agent, b: Agent, duration: float) -> float:
    """Least distance (metres) between the two drones' centres over [0, duration] seconds."""
    time = np.append(np.arange(0.0, duration, CHECK_DT), duration)
    pa = a.flight.path.evaluate(np.clip(time - a.take_off, 0.0, a.flight.duration))
    pb = b.flight.path.evaluate(np.clip(time - b.take_off, 0.0, b.flight.duration))
    return float(np.linalg.norm(pa - pb, axis=1).min())


def _endpoints(
    rng,
    free: np.ndarray,
    labels: np.ndarray,
    resolution: float,
    min_distance: float,
    taken: list[np.ndarray],
    separation: float,
) -> tuple[np.ndarray, np.ndarray] | None:
    """A start and a goal: free voxel centres of one component, ``min_distance`` apart, each
    ``separation`` from every start and goal already taken."""
    cells = np.argwhere(free)
    centres = (cells[:, ::-1] + 0.5) * resolution
    if taken:
        away = np.min(np.linalg.norm(centres[:, None] - np.asarray(taken)[None], axis=2), axis=1)
        cells, centres = cells[away >= separation], centres[away >= separation]
    if len(cells) == 0:
        return None
    s = int(rng.integers(len(cells)))
    same = labels[tuple(cells.T)] == labels[tuple(cells[s])]
    far = same & (np.linalg.norm(centres - centres[s], axis=1) >= min_distance)
    if not far.any():
        return None
    g = int(rng.choice(np.flatnonzero(far)))
    return voxel_centre(cells[s], resolution), voxel_centre(cells[g], resolution)


def separation(a: FlightLimits, b: FlightLimits) -> float:
    """Metres two drones' centres keep apart: both radii and the larger margin."""
    return a.radius + b.radius + max(a.margin, b.margin)


def plan_fleet(
    rng: np.random.Generator, volume: Volume, limits: list[FlightLimits], min_distance: float
) -> list[Agent]:
    """One drone per entry of ``limits`` (its radius, margin and dynamics), with its flight and
    take-off time, every pair kept :func:`separation` apart."""
    r = volume.resolution
    occupancy = volume.occupancy
    agents: list[Agent] = []
    for mine in limits:
        free = free_space(occupancy, r, mine.clearance)
        labels, _ = ndimage.label(free, structure=_SIX)
        apart = [separation(mine, other) for other in limits[: len(agents)]]
        for _ in range(DRAWS):
            taken = [p for a in agents for p in (a.start, a.goal)]
            ends = _endpoints(rng, free, labels, r, min_distance, taken, max(apart, default=0.0))
            if ends is None:
                continue
            try:
                flight = plan_flight(volume, *ends, mine)
            except FlightError:
                continue
            agent = _take_off(Agent(ends[0], ends[1], flight, 0.0), agents, apart)
            if agent is not None:
                agents.append(agent)
                break
        else:
            raise FleetError(
                f"drone {len(agents) + 1} of {len(limits)}: no start, goal, flight and take-off time after {DRAWS} draws"
            )
    return agents


def _take_off(agent: Agent, others: list[Agent], apart: list[float]) -> Agent | None:
    """``agent`` with the first take-off time that keeps it ``apart[k]`` from ``others[k]``."""
    for delay in np.arange(0.0, MAX_DELAY + 1e-9, DELAY_STEP):
        trial = Agent(agent.start, agent.goal, agent.flight, float(delay))
        end = max([trial.landing, *(o.landing for o in others)])
        if all(closest_approach(trial, o, end) >= d for o, d in zip(others, apart, strict=True)):
            return trial
    return None
