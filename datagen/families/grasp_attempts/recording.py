"""Recording one grasp attempt step by step (pure numpy): the executor hands the recorder the
command of every physics step and, on the steps it samples, the state; the result is the
``trajectory.npz`` part (``datagen.dataset.trajectory``).

Rates: a state row every ``round(1 / (record_hz * timestep))`` physics steps and a camera frame
every ``round(1 / (frame_hz * timestep))`` steps (at 5 ms steps, 20 Hz = every 10 steps; a rate
that does not divide the physics rate is rounded to the nearest whole step count, and the rate
actually kept is stored). Each row holds the state before its step and the command applied
from that step on; a last row holds the final state. Nothing here draws random numbers or
touches the simulation, so recording cannot change an attempt.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from datagen.dataset.trajectory import ARRAYS, CONTACT_NAMES, PHASES, encode_trajectory


def steps_per_sample(rate_hz: float, timestep: float, key: str) -> int:
    """Physics steps between two samples at ``rate_hz``; ValueError above the physics rate."""
    if rate_hz * timestep > 1.0 + 1e-9:
        raise ValueError(
            f"{key}: {rate_hz} Hz is above the physics rate {1 / timestep:g} Hz "
            f"(physics.timestep {timestep} s)"
        )
    return max(1, round(1.0 / (rate_hz * timestep)))


@dataclass
class StepState:
    """What the executor observed before one physics step (shapes: J joints, A action)."""

    qpos: np.ndarray  # (J,) in joint_names order
    qvel: np.ndarray  # (J,)
    gripper_opening: float  # m
    tcp_pose: np.ndarray  # (7,) world xyz + wxyz
    target_pose: np.ndarray  # (7,)
    contact: tuple[float, float, float]  # CONTACT_NAMES


class Recorder:
    """Kept by the executor for one attempt; ``on_frame(k)`` renders frame ``k`` (the caller's
    cameras) when a frame is due."""

    def __init__(
        self,
        timestep: float,
        record_hz: float,
        joint_names: Sequence[str],
        arm_joints: Sequence[str],
        frame_hz: float = 0.0,
        on_frame: Callable[[int], None] | None = None,
        finger_unit: str = "m",
    ):
        self.timestep, self.finger_unit = timestep, finger_unit
        self.row_every = steps_per_sample(record_hz, timestep, "campaign.record_hz")
        self.frame_every = (
            steps_per_sample(frame_hz, timestep, "campaign.frame_hz") if frame_hz > 0 else 0
        )
        self.on_frame = on_frame
        self.joint_names, self.arm_joints = list(joint_names), list(arm_joints)
        self.rows: dict[str, list] = {k: [] for k, v in ARRAYS.items() if v[2] == "row"}
        self.step_actions: list[np.ndarray] = []
        self.frame_steps: list[int] = []
        self.phase_start = [-1] * len(PHASES)
        self.phase = 0
        self._last_action = np.zeros(len(self.arm_joints) + 1)

    def begin_phase(self, name: str, step: int) -> None:
        self.phase = PHASES.index(name)
        self.phase_start[self.phase] = step

    def wants_state(self, step: int) -> bool:
        return step % self.row_every == 0

    def command(self, step: int, step_action: np.ndarray) -> bool:
        """Logs physics step ``step``'s command (arm targets, arm velocity targets, finger
        target); renders a frame if one is due; True if the step's state is wanted."""
        self.step_actions.append(np.asarray(step_action, np.float32))
        arm = len(self.arm_joints)
        self._last_action = np.append(step_action[:arm], step_action[-1])
        if self.frame_every and step % self.frame_every == 0:
            self._frame(step)
        return self.wants_state(step)

    def state(self, step: int, state: StepState) -> None:
        """One row: the state before ``step`` and the command applied from it on."""
        values = {
            "step": step,
            "time": step * self.timestep,
            "phase": self.phase,
            "qpos": state.qpos,
            "qvel": state.qvel,
            "action": self._last_action,
            "gripper_opening": state.gripper_opening,
            "tcp_pose": state.tcp_pose,
            "target_pose": state.target_pose,
            "contact": state.contact,
        }
        for key, value in values.items():
            self.rows[key].append(np.asarray(value, float))

    def finish(self, step: int, state: StepState) -> None:
        """The final state (after the last step), with the last command; its frame if due."""
        if self.frame_every and step % self.frame_every == 0:
            self._frame(step)
        self.state(step, state)

    def _frame(self, step: int) -> None:
        if self.frame_steps and self.frame_steps[-1] == step:
            return
        self.frame_steps.append(step)
        if self.on_frame is not None:
            self.on_frame(len(self.frame_steps) - 1)

    def encode(self) -> bytes:
        """The ``trajectory.npz`` part."""
        arm = len(self.arm_joints)
        arrays = {key: np.asarray(values) for key, values in self.rows.items()}
        arrays["step_action"] = np.asarray(self.step_actions).reshape(-1, 2 * arm + 1)
        arrays["frame_step"] = np.asarray(self.frame_steps, int)
        arrays["frame_time"] = arrays["frame_step"] * self.timestep
        arrays["phase_start_step"] = np.asarray(self.phase_start)
        names = {
            "joint_names": self.joint_names,
            "action_names": [*self.arm_joints, "finger_target"],
            "step_action_names": [
                *self.arm_joints,
                *(f"{name}.velocity" for name in self.arm_joints),
                "finger_target",
            ],
            # each prismatic finger's travel (m), or a jaw's angle (rad)
            "finger_target_unit": self.finger_unit,
            "contact_names": list(CONTACT_NAMES),
            "phases": list(PHASES),
            "timestep": round(self.timestep, 9),  # s (the scene's, stored as float32)
            "row_every_steps": self.row_every,
            "record_hz": round(1.0 / (self.row_every * self.timestep), 4),
            "frame_every_steps": self.frame_every,
            "frame_hz": round(1.0 / (self.frame_every * self.timestep), 4)
            if self.frame_every
            else 0.0,
        }
        return encode_trajectory(arrays, names)
