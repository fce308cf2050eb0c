"""Robots' parsed articulation builders, cached per process (descriptions are located by
:mod:`datagen.robot_specs`).

Parsing the Panda's URDF and SRDF (XML, link trees, mesh paths) costs about 6 ms a scene; the
parsed :class:`ArticulationBuilder` holds no physics state (every ``build`` makes new entities,
bodies and joints), so one builder serves every scene of a worker and the samples stay a
function of (seed, index): tests/pipeline/test_reproducible_history.py checks it. A build borrows the
builder (``set_scene``) for its duration: scenes of one process are built one at a time.
"""

from __future__ import annotations

import functools
from pathlib import Path

import sapien
from sapien.wrapper.articulation_builder import ArticulationBuilder

from datagen.worlds.robot_visuals import simplify_visuals

FETCH = "robots/fetch/fetch.urdf"  # under mani_skill/assets/


@functools.lru_cache(maxsize=4)
def _articulation_builder(
    urdf: Path, fix_root_link: bool, max_triangles: int
) -> ArticulationBuilder:
    loader = sapien.Scene().create_urdf_loader()  # the parser wants a scene; builds set their own
    loader.fix_root_link = fix_root_link
    builder = loader.load_file_as_articulation_builder(str(urdf))
    builder.set_scene(None)  # holds no scene between builds
    simplify_visuals(builder, max_triangles)
    return builder


def load_robot(
    scene: sapien.Scene, urdf: Path, fix_root_link: bool = True, max_triangles: int = 0
) -> sapien.physx.PhysxArticulation:
    """The robot described by ``urdf`` added to ``scene``: what
    ``scene.create_urdf_loader().load(...)`` gives, from the process's parsed builder, drawn
    with at most ``max_triangles`` triangles (``render.robot_triangles``; 0: its own meshes)."""
    builder = _articulation_builder(Path(urdf), fix_root_link, max_triangles)
    builder.set_scene(scene)
    try:
        return builder.build()
    finally:
        builder.set_scene(None)
