"""Targets stay in the workspace: after settling, every target's centre of mass must be in the
tray (``assets.tabletop_layout.in_tray``). A scene where one is not is built again, fresh (a
reused PhysX scene would not replay the same), with drop poses from a derived stream; each
re-draw is recorded in ``randomisation.redraws`` and at most ``MAX_REDRAWS`` are made."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol

import sapien

from datagen.assets.tabletop_layout import DEFAULT_WORKSPACE, Workspace, in_tray

MAX_REDRAWS = 5


class Target(Protocol):
    """What is checked of a grasp target (``datagen.families.grasp_tabletop.world.SceneObject``)."""

    instance_id: int
    class_name: str
    entity: sapien.Entity


class TargetsOutsideTray(RuntimeError):
    """Targets still settled outside the tray after ``MAX_REDRAWS`` re-draws; the sample-error
    policy (``build.on_sample_error``) retries the sample or reports it."""


def centre_of_mass(target: Target) -> list[float]:
    """World metres: where the target's rigid body has its centre of mass now."""
    body = target.entity.find_component_by_type(sapien.physx.PhysxRigidDynamicComponent)
    return [float(v) for v in (body.entity_pose * body.cmass_local_pose).p]


def outside_tray(targets: Sequence[Target], ws: Workspace = DEFAULT_WORKSPACE) -> list[str]:
    """One line per target outside the tray: ``object 3 (mug) at (x, y, z) outside the tray``,
    x, y, z in world metres; empty when all are in."""
    lines = []
    for target in targets:
        point = centre_of_mass(target)
        if not in_tray(point, ws):
            where = ", ".join(f"{v:.3f}" for v in point)
            lines.append(
                f"object {target.instance_id} ({target.class_name}) at ({where}) outside the tray"
            )
    return lines
