"""Objects launched by the physics engine (issue 39): the contact generation that launched the
bowl of campaign seed 0, attempt 2, and the ``disturbed`` outcome of what remains, with its own
count in campaign statistics. Real SAPIEN physics; exact distances from FCL (mplib)."""

from __future__ import annotations

import numpy as np
import pytest
import sapien
from mplib.pymp.collision_detection import fcl
from test_grasp_execute import CONFIG, PARAMS, box_scene, top_down

from datagen.assets.shapes import build_geometry
from datagen.campaign_stats import campaign_stats
from datagen.families.grasp_attempts.contacts import convex_box, sat_contacts, sat_twin
from datagen.families.grasp_attempts.disturbance import (
    PUSH_FACTOR,
    SPEED_FLOOR,
    WINDOW,
    pushed_speed,
)
from datagen.families.grasp_attempts.execute import execute_grasp
from datagen.families.grasp_attempts.grasps import FAILURE_MODES

pytestmark = pytest.mark.sim

# Panda, campaign seed 0, attempt 2, the step before the bowl left the tray (physics step 874)
BOWL = {
    "family": "bowl",
    "parts": [
        {
            "kind": "shell",
            "base": 0.003,
            "thickness": 0.003,
            "profile": [[0.017799, -0.010744], [0.030238, 0.0], [0.035391, 0.010744]],
        }
    ],
}
BOWL_POSE = sapien.Pose([0.0604968, -0.1118377, 0.770744], [0.8793592, 0.0, 0.0, 0.476159])
FINGER_POSE = sapien.Pose(
    [0.0792076, -0.0712554, 0.835539], [0.2038755, 0.9389025, -0.2756876, 0.0298889]
)
FINGER_BOX = (sapien.Pose([0.0, 0.00758, 0.04525]), np.array([0.00875, 0.0076, 0.00925]))
FINGER_VELOCITY = np.array([-0.0200, -0.0413, -0.0959])  # m/s
TIMESTEP = 0.005


def _one_step(scene: sapien.Scene) -> float:
    """The bowl (dynamic, its convex parts) and the finger's box (kinematic, moving on at its
    velocity) after one step: the smallest separation PhysX reports between them, metres."""
    scene.set_timestep(TIMESTEP)
    material = sapien.physx.PhysxMaterial(0.7, 0.7, 0.0)
    bowl = sapien.physx.PhysxRigidDynamicComponent()
    for part in build_geometry(BOWL).parts:
        vertices = np.asarray(part.vertices, np.float32)
        shape = sapien.physx.PhysxCollisionShapeConvexMesh(vertices, np.ones(3), material)
        shape.set_density(500.0)
        bowl.attach(shape)
    bowl.disable_gravity = True
    finger = sapien.physx.PhysxRigidDynamicComponent()
    finger.kinematic = True
    box = sapien.physx.PhysxCollisionShapeBox(FINGER_BOX[1], material)
    box.set_local_pose(FINGER_BOX[0])
    finger.attach(box)
    for body, pose in ((bowl, BOWL_POSE), (finger, FINGER_POSE)):
        entity = sapien.Entity()
        entity.add_component(body)
        entity.set_pose(pose)
        scene.add_entity(entity)
    finger.kinematic_target = sapien.Pose(FINGER_POSE.p + FINGER_VELOCITY * TIMESTEP, FINGER_POSE.q)
    scene.step()
    return min(point.separation for c in scene.get_contacts() for point in c.points)


def _exact_distance() -> float:
    """Metres between the finger's box and the nearest part of the bowl before the step."""
    box_pose = FINGER_POSE * FINGER_BOX[0]
    box = fcl.CollisionObject(fcl.Box(2 * FINGER_BOX[1]), box_pose.p, box_pose.q)
    distances = []
    for part in build_geometry(BOWL).parts:
        hull = fcl.Convex(np.asarray(part.vertices, float), np.asarray(part.faces, np.int32))
        body = fcl.CollisionObject(hull, BOWL_POSE.p, BOWL_POSE.q)
        distances.append(fcl.distance(body, box, fcl.DistanceRequest()).min_distance)
    return min(distances)


def test_sat_contacts_report_the_distance_where_pcm_reported_a_deep_penetration():
    exact = _exact_distance()
    assert exact == pytest.approx(0.0071, abs=0.0005)  # apart: nothing touches the bowl
    with sat_contacts():
        sat = _one_step(sapien.Scene())
    assert sapien.physx.get_scene_config().enable_pcm  # restored for other families
    pcm = _one_step(sapien.Scene())
    assert sat > exact - 0.001  # moved 0.5 mm nearer
    assert pcm < -0.02  # the cause: a contact 2-3 cm deep between shapes 7 mm apart


def test_the_sat_twin_is_the_settled_scene_with_sat_contacts():
    settled = box_scene()
    twin = sat_twin(CONFIG, settled)
    assert settled.scene.physx_system.config.enable_pcm
    assert not twin.scene.physx_system.config.enable_pcm
    assert twin.params is settled.params
    for a, b in zip(settled.objects, twin.objects, strict=True):
        assert (a.instance_id, a.class_name) == (b.instance_id, b.class_name)
        np.testing.assert_array_equal(a.entity.pose.p, b.entity.pose.p)
        np.testing.assert_array_equal(a.entity.pose.q, b.entity.pose.q)
    np.testing.assert_array_equal(settled.robot.get_qpos(), twin.robot.get_qpos())
    statics = [
        shape
        for entity in twin.scene.get_entities()
        for body in [entity.find_component_by_type(sapien.physx.PhysxRigidStaticComponent)]
        if body is not None
        for shape in body.get_collision_shapes()
    ]
    assert statics and not any(isinstance(s, sapien.physx.PhysxCollisionShapeBox) for s in statics)


def test_a_convex_box_is_the_box():
    material = sapien.physx.PhysxMaterial(0.4, 0.3, 0.1)
    box = sapien.physx.PhysxCollisionShapeBox(np.array([0.1, 0.2, 0.3]), material)
    box.set_local_pose(sapien.Pose([1.0, 2.0, 3.0], [0.0, 1.0, 0.0, 0.0]))
    box.set_contact_offset(0.004)
    convex = convex_box(box)
    vertices = np.asarray(convex.get_vertices())
    np.testing.assert_allclose(vertices.min(axis=0), [-0.1, -0.2, -0.3], atol=1e-6)
    np.testing.assert_allclose(vertices.max(axis=0), [0.1, 0.2, 0.3], atol=1e-6)
    assert len(vertices) == 8 and convex.contact_offset == pytest.approx(0.004)
    np.testing.assert_array_equal(convex.local_pose.p, box.local_pose.p)
    assert convex.physical_material.static_friction == pytest.approx(0.4)


def test_an_object_thrown_faster_than_the_hand_could_push_it_is_disturbed_its_label_kept():
    scene = box_scene()
    body = scene.objects[0].entity.find_component_by_type(sapien.physx.PhysxRigidDynamicComponent)
    body.set_linear_velocity([0.0, 0.0, 3.0])  # m/s, as the bad contact threw the bowl
    out = execute_grasp(scene, 1, top_down(scene), PARAMS)
    assert (out.success, out.failure_mode) == (False, "disturbed")
    seen = out.details["disturbance"]
    window = round(WINDOW / TIMESTEP)  # steps: the first full window is the fastest
    assert seen["disturbed"] and (seen["phase"], seen["step"], seen["instance_id"]) == (
        "open",
        window,
        1,
    )
    # semi-implicit Euler: the mean of 3 - k g dt over the window's k = 1 .. window
    assert seen["object_speed"] == pytest.approx(3.0 - 9.81 * TIMESTEP * (window + 1) / 2, abs=0.01)
    assert seen["limit"] == pytest.approx(PUSH_FACTOR * seen["hand_speed"] + SPEED_FLOOR, abs=1e-3)
    assert seen["label"]["success"] or seen["label"]["failure_mode"] in FAILURE_MODES


def test_an_ordinary_grasp_is_not_disturbed():
    scene = box_scene()
    out = execute_grasp(scene, 1, top_down(scene), PARAMS)
    assert out.success, out.to_json()
    seen = out.details["disturbance"]
    assert not seen["disturbed"] and seen["object_speed"] < seen["limit"]


def test_falling_is_not_pushing():
    assert pushed_speed(np.array([0.0, 0.0, -3.0])) == 0.0
    assert pushed_speed(np.array([0.3, 0.4, 1.2])) == pytest.approx(1.3)


def test_campaign_statistics_count_disturbed_attempts_apart():
    rows = [
        ("box", True, None),
        ("bowl", False, "disturbed"),
        ("bowl", False, "missed"),
        ("can", False, "disturbed"),
    ]
    stats = campaign_stats(
        {"sampler": "antipodal", "family": f, "success": s, "failure_mode": m} for f, s, m in rows
    )
    assert (stats["attempts"], stats["successes"], stats["disturbed"]) == (4, 1, 2)
    assert stats["failure_modes"] == {"disturbed": 2, "missed": 1}
    assert stats["success_rate"] == 0.25 and stats["success_rate_undisturbed"] == 0.5
