"""The grasp the hand executed: where the grasp frame was when the fingers had closed, beside the
planned one (``attempt.grasp.pose_world``, the planner's goal), and the offset between them.

The planner moves the TCP link to ``pose_world @ tcp_in_grasp`` (identity for a symmetric
gripper; a jaw gripper's TCP is off the centre between its pads, ``GripperGeometry.tcp_in_grasp``
at the opening it approached with). The executed grasp frame is the TCP link's pose at closure,
forward kinematics of the joint state then, carried back by the same transform:
``executed_pose_world = tcp_world @ inv(tcp_in_grasp)``, so a hand that tracked its plan exactly
has ``executed_pose_world == pose_world``. Pure numpy.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np


def rotation_angle_deg(rotation: np.ndarray) -> float:
    """Degrees of the rotation (3, 3) about its axis."""
    cos = (float(np.trace(rotation)) - 1.0) / 2.0
    return float(np.degrees(np.arccos(np.clip(cos, -1.0, 1.0))))


def executed_grasp(
    planned: np.ndarray,
    tcp_world: np.ndarray,
    tcp_in_grasp: np.ndarray,
    qpos: Sequence[float],
    time: float,
) -> dict[str, Any]:
    """The record's executed keys: ``planned`` (4, 4) the candidate's grasp frame, ``tcp_world``
    (4, 4) the TCP link at closure, ``tcp_in_grasp`` (4, 4), ``qpos`` the joint state at closure
    (radians or metres, the spec's ``joint_names`` order), ``time`` seconds into the attempt."""
    executed = np.asarray(tcp_world, float) @ np.linalg.inv(tcp_in_grasp)
    offset = np.linalg.inv(np.asarray(planned, float)) @ executed
    return {
        "executed_pose_world": np.round(executed, 7).tolist(),
        "executed_offset": {  # the executed frame in the planned one: z approach, y closing
            "position": np.round(offset[:3, 3], 7).tolist(),  # metres
            "angle_deg": round(rotation_angle_deg(offset[:3, :3]), 5),
        },
        "executed_qpos": np.round(np.asarray(qpos, float), 7).tolist(),
        "executed_time": round(float(time), 6),
        "tcp_in_grasp": np.round(np.asarray(tcp_in_grasp, float), 9).tolist(),
    }
