"""Several ground robots in one floor plan (``navigation.robots``): their tasks and the time each
sets off, so that no two ever touch.

Robot after robot, a task (start, goal, path, expert trajectory: :func:`plan_task`) is drawn with
its start and goal kept ``separation`` from the other robots' starts and goals; it waits at its
start for a whole number of control steps (0, ``DELAY_STEPS``, 2 ``DELAY_STEPS``, ...) chosen so
that, at every control step of the episode, its centre stays ``separation`` (two radii and the
planning margin) from every other robot's, each waiting at its start before setting off and at
its goal after arriving. A robot no delay up to ``MAX_DELAY_S`` separates is drawn again; a
layout where that fails ``DRAWS`` times is drawn again, from ``nav_layout/1``, ... as for one
robot.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from datagen.config.sections import NavigationConfig
from datagen.families.navigation.episode import LAYOUT_ATTEMPTS, Episode, layout_attempts, plan_task
from datagen.families.navigation.planning import PlanningError
from datagen.floorplans.grid import Layout

DELAY_STEPS = 5  # control steps between tried delays
MAX_DELAY_S = 30.0  # seconds
DRAWS = 8  # tasks drawn per robot before the layout is given up
HOLD_S = 0.5  # seconds the episode runs on after the last robot arrives


@dataclass
class GroundAgent:
    episode: Episode  # its task, path and trajectory (at the control rate)
    delay: int  # control steps it waits at its start

    @property
    def arrival(self) -> int:
        """The control step at which it stands at its goal."""
        return self.delay + len(self.episode.trajectory.poses) - 1

    def step_index(self, step: np.ndarray | int) -> np.ndarray:
        """Its trajectory's row at each episode control step (held at both ends)."""
        return np.clip(np.asarray(step) - self.delay, 0, len(self.episode.trajectory.poses) - 1)


@dataclass
class FleetEpisode:
    layout: Layout
    agents: list[GroundAgent]
    dt: float  # seconds per control step

    @property
    def steps(self) -> int:
        """Control steps of the episode: until the last robot arrives, and HOLD_S more."""
        return max(a.arrival for a in self.agents) + round(HOLD_S / self.dt)


def closest_approach(a: GroundAgent, b: GroundAgent, steps: int) -> float:
    """Least distance (metres) between the two robots' centres at every control step."""
    n = np.arange(steps + 1)
    pa = a.episode.trajectory.poses[a.step_index(n), :2]
    pb = b.episode.trajectory.poses[b.step_index(n), :2]
    return float(np.hypot(*(pa - pb).T).min())


def _taken(layout: Layout, points: list[np.ndarray], radius: float) -> np.ndarray:
    """Cells within ``radius`` of any of ``points`` (x, y metres)."""
    rows, cols = np.mgrid[0 : layout.grid.shape[0], 0 : layout.grid.shape[1]]
    centres = np.stack([(cols + 0.5) * layout.resolution, (rows + 0.5) * layout.resolution], -1)
    taken = np.zeros(layout.grid.shape, bool)
    for p in points:
        taken |= np.hypot(*(centres - p).transpose(2, 0, 1)) < radius
    return taken


def _set_off(agent: GroundAgent, others: list[GroundAgent], apart: float) -> GroundAgent | None:
    dt = agent.episode.trajectory.dt
    for delay in range(0, round(MAX_DELAY_S / dt) + 1, DELAY_STEPS):
        trial = GroundAgent(agent.episode, delay)
        end = max([trial.arrival, *(o.arrival for o in others)])
        if all(closest_approach(trial, o, end) >= apart for o in others):
            return trial
    return None


def plan_fleet_episode(
    cfg: NavigationConfig, seed: int, index: int, retry: int = 0
) -> FleetEpisode:
    apart = 2 * cfg.robot_radius + cfg.planning_margin
    reasons = []
    for layout, rng in layout_attempts(cfg, seed, index, retry):
        agents: list[GroundAgent] = []
        for _ in range(cfg.robots):
            ends = [np.asarray(p[:2]) for a in agents for p in (a.episode.start, a.episode.goal)]
            taken = _taken(layout, ends, apart) if ends else None
            for _ in range(DRAWS):
                try:
                    episode = plan_task(cfg, layout, rng, taken)
                except PlanningError as exc:
                    reasons.append(str(exc))
                    continue
                if not episode.trajectory.success:
                    continue
                agent = _set_off(GroundAgent(episode, 0), agents, apart)
                if agent is not None:
                    agents.append(agent)
                    break
            else:
                reasons.append(
                    f"robot {len(agents) + 1}: no task and start time kept it {apart} m from the others"
                )
                break
        if len(agents) == cfg.robots:
            return FleetEpisode(layout, agents, agents[0].episode.trajectory.dt)
    raise PlanningError(
        f"episode {index}: no {cfg.family} layout out of {LAYOUT_ATTEMPTS} gave {cfg.robots} robots "
        f"tasks that keep them {apart} m apart; lower navigation.robots or navigation.clutter "
        f"(last reason: {reasons[-1] if reasons else 'none'})"
    )
