"""How much of the tray floor an arm reaches with a top-down grasp, for a workspace scale: the
figure each small arm's ``workspace_scale`` was chosen by (docs/robots.md).

    .venv/bin/python scripts/workspace_reach.py so100 0.33

Builds sample 0 of ``configs/grasp_campaign.yaml`` with the arm and the scale, then asks the
motion planner (mplib, obstacles removed) for an IK solution of a straight-down TCP pose over a
5 x 3 grid of the tray floor's half (it is symmetric), 2 and 5 cm above the table top.
"""

from __future__ import annotations

import argparse
import dataclasses
import importlib

import numpy as np
import sapien

from datagen.config import load_config
from datagen.families.grasp_attempts.planner import make_planner, remove_obstacles, solve_ik
from datagen.families.grasp_tabletop.world import build_scene
from datagen.registries import ROBOTS

DOWN = [0.0, 1.0, 0.0, 0.0]  # wxyz: the TCP's z pointing down


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("robot", choices=sorted(ROBOTS))
    parser.add_argument("scale", type=float, help="the workspace scale to try")
    args = parser.parse_args()
    module, _, attribute = ROBOTS[args.robot].spec.partition(":")
    record = getattr(importlib.import_module(module), attribute)
    scaled = dataclasses.replace(record, workspace_scale=args.scale)
    setattr(importlib.import_module(module), attribute, scaled)
    config = load_config("configs/grasp_campaign.yaml")
    config = config.replace(robot=dataclasses.replace(config.robot, name=args.robot))
    scene = build_scene(config, config.seed, 0)
    ws = scene.workspace
    planner = make_planner(scene.scene, scene.robot, scene.objects, scene.spec)
    remove_obstacles(planner)
    qpos = scene.robot.get_qpos().astype(float)
    (cx, cy, _), (hx, hy) = ws.tray_centre, ws.tray_inner_half
    reached = total = 0
    for height in (0.02, 0.05):
        row = []
        for x in np.linspace(cx - hx, cx + hx, 5):
            for y in (cy, cy + hy / 2, cy + hy):
                ok = bool(solve_ik(planner, sapien.Pose([x, y, ws.table_top + height], DOWN), qpos))
                row.append("x" if ok else ".")
                reached, total = reached + ok, total + 1
        print(f"{height * 100:.0f} cm above the table: {''.join(row)}")
    print(f"{args.robot} at workspace scale {args.scale}: {reached}/{total} top-down poses reached")


if __name__ == "__main__":
    main()
