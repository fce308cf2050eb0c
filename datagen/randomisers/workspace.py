"""A scene scaled to a small arm's reach: the lengths of a tabletop config that describe the
workspace (the camera's eye and target about the world origin, table distractors, the pre-grasp
and lift distances) times ``RobotSpec.workspace_scale``, object sizes and drop heights times
``RobotSpec.object_scale``, and as many objects as fit the smaller tray as well as the Panda's
(the count times the square of their ratio), so the randomisers draw a scene the arm can reach
and its gripper can hold. The table, tray and robot base are scaled by
:class:`datagen.assets.tabletop_layout.Workspace`; the room, lights and background are not."""

from __future__ import annotations

import dataclasses

from datagen.config import BuildConfig
from datagen.robot_specs import RobotSpec


def _times(values: tuple[float, ...], scale: float) -> tuple[float, ...]:
    return tuple(round(v * scale, 9) for v in values)


def scaled_to_robot(config: BuildConfig, spec: RobotSpec) -> BuildConfig:
    """``config`` with its workspace lengths scaled to the arm ``spec`` (the configured one,
    resolved); itself for a scale of 1."""
    s, o = spec.workspace_scale, spec.object_scale
    if s == 1.0 and o == 1.0:
        return config
    replace = dataclasses.replace
    room = (s / o) ** 2  # the tray's floor over an object's footprint, against the Panda's
    objects = replace(
        config.objects,
        count=tuple(max(1, round(c * room)) for c in config.objects.count),
        size=_times(config.objects.size, o),
        drop_height=_times(config.objects.drop_height, o),
    )
    camera = replace(
        config.camera,
        eye=_times(config.camera.eye, s),
        target=_times(config.camera.target, s),
        eye_jitter=config.camera.eye_jitter * s,
        target_jitter=config.camera.target_jitter * s,
    )
    distractors = replace(config.distractors, size=_times(config.distractors.size, s))
    campaign = replace(
        config.campaign,
        pre_grasp_distance=config.campaign.pre_grasp_distance * s,
        lift_height=config.campaign.lift_height * s,
    )
    return config.replace(
        objects=objects, camera=camera, distractors=distractors, campaign=campaign
    )
