"""Contact generation for grasp attempts: PhysX's SAT-based contacts instead of its persistent
contact manifolds (PCM, SAPIEN's default).

PCM reported contacts 20-30 mm deep between a Panda finger box and a bowl's 3 mm wall segment
that the exact distance (FCL) put 15.6 mm apart (campaign seed 0, attempt 2); the solver pushed
the 8 g bowl out at 8 m/s. Of 3000 random poses of that box within 3 cm of the bowl's wall
segments (2590 of them apart), PCM reported 14 more than 5 mm deeper than the exact distance at
SAPIEN's contact offset of 10 mm and 1 at 2 mm, SAT none at either
(``benchmarks/grasp_disturbances.py --contacts 3000``). PCM is
a scene-wide setting read when a scene is created: a campaign settles its scene as
``grasp_tabletop`` does (PCM: the same scene for the same seed), then builds it again inside
:func:`sat_contacts`, each object and joint where it came to rest (:func:`sat_twin`), and
renders, plans and executes the attempt there.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator

import numpy as np
import sapien

from datagen.config import BuildConfig
from datagen.families.grasp_tabletop.world import GraspScene, construct_scene


@contextlib.contextmanager
def sat_contacts() -> Iterator[None]:
    """Scenes created inside use SAT contact generation (``enable_pcm`` off); the previous
    setting is restored on leaving."""
    config = sapien.physx.get_scene_config()
    previous = config.enable_pcm
    config.enable_pcm = False
    sapien.physx.set_scene_config(config)
    try:
        yield
    finally:
        config.enable_pcm = previous
        sapien.physx.set_scene_config(config)


def convex_box(box: sapien.physx.PhysxCollisionShapeBox) -> sapien.physx.PhysxCollisionShape:
    """The convex mesh of ``box``'s eight corners, with its pose, material, offsets and groups."""
    corners = np.array(np.meshgrid([-1, 1], [-1, 1], [-1, 1])).reshape(3, -1).T
    vertices = (corners * np.asarray(box.half_size, float)).astype(np.float32)
    shape = sapien.physx.PhysxCollisionShapeConvexMesh(
        vertices, np.ones(3, np.float32), box.physical_material
    )
    shape.set_local_pose(box.local_pose)
    shape.set_contact_offset(box.contact_offset)
    shape.set_rest_offset(box.rest_offset)
    shape.set_collision_groups(box.collision_groups)
    return shape


def convex_statics(scene: sapien.Scene) -> None:
    """Every static box (table, legs, tray) becomes the convex mesh of its corners: SAT's
    box-box contacts put a Panda finger box 0.5 mm deep in a tray wall 5.9 mm away (iiwa14,
    seed 0, attempt 40), where its box-convex contacts are exact."""
    for entity in scene.get_entities():
        body = entity.find_component_by_type(sapien.physx.PhysxRigidStaticComponent)
        shapes = body.get_collision_shapes() if body is not None else []
        if not shapes or not all(
            isinstance(s, sapien.physx.PhysxCollisionShapeBox) for s in shapes
        ):
            continue
        convex = sapien.physx.PhysxRigidStaticComponent()
        for shape in shapes:
            convex.attach(convex_box(shape))
        entity.remove_component(body)
        entity.add_component(convex)


def sat_twin(config: BuildConfig, settled: GraspScene) -> GraspScene:
    """``settled`` built again with SAT contacts and convex static boxes: its objects at their
    poses, its robot at its joint positions, the drawn values (``params``) its own."""
    poses = [{"position": o.entity.pose.p, "quat_wxyz": o.entity.pose.q} for o in settled.objects]
    with sat_contacts():
        twin = construct_scene(config, settled.params | {"drop_poses": poses}, settled.spec)
    convex_statics(twin.scene)
    twin.robot.set_qpos(settled.robot.get_qpos())
    twin.params = settled.params
    return twin
