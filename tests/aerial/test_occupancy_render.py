"""The voxel grid holds what the cameras see: every point SAPIEN renders of a solid (walls, ceiling,
obstacles), read at float precision from the renderer's position buffer, lies in an occupied voxel
or outside the grid (which counts as occupied). Faces on voxel boundaries are the case a grid of
overlapped interiors missed: about 9 % of the rendered points of a corridor, just outside."""

from __future__ import annotations

import numpy as np
import pytest

from datagen.config import config_from_dict
from datagen.families.aerial.episode import plan_aerial_episode
from datagen.families.aerial.values import draw_aerial_scene
from datagen.families.aerial.world import AERIAL_CLASS_ID, build_aerial_scene
from datagen.sensing.render import keep_renderer_alive

pytestmark = [pytest.mark.sim]
SOLIDS = [AERIAL_CLASS_ID[c] for c in ("wall", "ceiling", "obstacle")]


def _world_points(scene, camera) -> np.ndarray:
    """(n, 3) world points of the solids' pixels of one rendered camera."""
    camera.take_picture()
    position = camera.get_picture("Position")  # (H, W, 4): OpenGL camera xyz, w < 1 on surfaces
    _, classes = scene.label_maps(camera.get_picture("Segmentation")[..., 1])
    points = position[(position[..., 3] < 1) & np.isin(classes, SOLIDS)][:, :3].astype(float)
    to_world = np.asarray(camera.get_model_matrix(), float)
    return points @ to_world[:3, :3].T + to_world[:3, 3]


@pytest.mark.parametrize(("family", "index"), [("corridor", 0), ("rooms", 1), ("maze", 2)])
def test_every_rendered_point_of_a_solid_is_in_an_occupied_voxel(family, index):
    keep_renderer_alive()
    config = config_from_dict(
        {
            "scene": "aerial",
            "render": {"width": 160, "height": 120, "far": 20.0},
            "aerial": {"family": family, "down_camera": True},
        }
    )
    episode = plan_aerial_episode(config.aerial, 5, index)
    volume = episode.volume
    values = draw_aerial_scene(config, 5, index, volume.layout, volume.height, 1)
    scene = build_aerial_scene(config, episode, values)
    occupancy, r = volume.occupancy, volume.resolution
    checked = 0
    for t in np.linspace(0.0, episode.duration, 6):
        states = episode.agents[0].states(np.array([t]))
        scene.pose_drones(states.position, states.rotation)
        scene.scene.update_render()
        for camera in scene.cameras.values():
            cells = np.floor(_world_points(scene, camera)[:, ::-1] / r).astype(int)
            inside = np.all((cells >= 0) & (cells < occupancy.shape), axis=1)
            outside = cells[inside][~occupancy[tuple(cells[inside].T)]]
            assert len(outside) == 0, f"{len(outside)} points in free voxels, e.g. {outside[:3]}"
            checked += len(cells)
    assert checked > 10_000
