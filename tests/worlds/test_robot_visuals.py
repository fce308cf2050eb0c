"""The robot drawn with at most ``render.robot_triangles`` triangles
(datagen/worlds/robot_visuals.py): within the budget, the same silhouette as the shipped meshes
(IoU of the rendered masks), the same physics, and one set of files per machine."""

from __future__ import annotations

import os
import subprocess
import sys
from dataclasses import replace

import numpy as np
import pytest
import sapien

from datagen.config import load_config
from datagen.families.grasp_tabletop.world import GraspScene, build_scene
from datagen.sensing.render import capture, keep_renderer_alive

pytestmark = [pytest.mark.sim]
BUDGET = 20000


def _config(robot_triangles: int, robot: str = "panda"):
    config = load_config("configs/grasp_tabletop.yaml")
    config = config.replace(robot=replace(config.robot, name=robot))
    return config.replace(
        render=replace(config.render, width=320, height=240, robot_triangles=robot_triangles)
    )


def _drawn_triangles(robot: sapien.physx.PhysxArticulation) -> int:
    total = 0
    for link in robot.get_links():
        body = link.entity.find_component_by_type(sapien.render.RenderBodyComponent)
        for shape in body.render_shapes if body else []:
            total += sum(len(part.triangles) for part in shape.parts)
    return total


def _robot_mask(config, index: int) -> tuple[np.ndarray, GraspScene]:
    """The robot's rendered mask, and the scene (its robot lives as long as the scene)."""
    keep_renderer_alive()
    scene = build_scene(config, config.seed, index)
    scene.scene.update_render()
    frame = capture(scene.cameras["workspace"])
    links = [link.entity.per_scene_id for link in scene.robot.get_links()]
    return np.isin(frame.entity_ids, links), scene


@pytest.mark.parametrize("index", [0, 3])
def test_the_simplified_panda_covers_the_pixels_the_shipped_one_covers(index):
    shipped, full = _robot_mask(_config(0), index)
    drawn, simplified = _robot_mask(_config(BUDGET), index)
    assert _drawn_triangles(full.robot) == 135_548
    # parts under KEEP_BELOW triangles (fingers, the flange's marks) are kept whole
    assert BUDGET * 0.9 < _drawn_triangles(simplified.robot) <= BUDGET * 1.1
    assert shipped.sum() > 2000  # pixels: the arm is in view
    iou = (shipped & drawn).sum() / (shipped | drawn).sum()
    assert iou > 0.99, iou


def test_simplifying_changes_no_collision_shape_or_mass():
    _, full = _robot_mask(_config(0), 0)
    _, simplified = _robot_mask(_config(BUDGET), 0)
    for a, b in zip(full.robot.get_links(), simplified.robot.get_links(), strict=True):
        assert a.name == b.name and np.isclose(a.mass, b.mass)
        assert [type(s).__name__ for s in a.collision_shapes] == [
            type(s).__name__ for s in b.collision_shapes
        ]


def test_an_arm_within_the_budget_is_drawn_as_shipped():
    _, shipped = _robot_mask(_config(0, "iiwa14"), 0)
    _, budgeted = _robot_mask(_config(10**6, "iiwa14"), 0)
    assert _drawn_triangles(budgeted.robot) == _drawn_triangles(shipped.robot)


def test_the_simplified_files_are_made_once_per_machine_and_read_back_the_same(tmp_path):
    code = """
import sys, numpy as np, sapien
from datagen.registries import ROBOTS
from datagen.worlds.robot_visuals import cache_dir
from datagen.families.grasp_tabletop.world import load_arm
scene = sapien.Scene()
robot = load_arm(scene, ROBOTS["panda"].load(), 20000)
parts = [p for link in robot.get_links()
         for body in [link.entity.find_component_by_type(sapien.render.RenderBodyComponent)] if body
         for shape in body.render_shapes for p in shape.parts]
files = sorted(cache_dir().glob("*.glb"))
print(len(files), sum(f.stat().st_mtime_ns for f in files), sum(len(p.triangles) for p in parts),
      float(sum(np.asarray(p.vertices, float).sum() for p in parts)))
"""
    env = os.environ | {"XDG_CACHE_HOME": str(tmp_path), "OMP_NUM_THREADS": "1"}
    runs = [
        subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
        for _ in range(2)
    ]
    assert all(run.returncode == 0 for run in runs), runs[0].stderr[-2000:]
    first, second = (run.stdout.split() for run in runs)
    assert int(first[0]) == 22  # a file per simplified part of the Panda's meshes
    assert first == second  # not written again (same times), the same meshes
