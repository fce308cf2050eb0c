"""Grasp candidate samplers and the gripper collision check: pure geometry, no simulator."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import trimesh

from datagen.assets.shapes import build_geometry
from datagen.convex import CORNER_SIGNS, BodySet, ConvexBody
from datagen.errors import ConfigError
from datagen.families.grasp_attempts.grasps import GraspCandidate
from datagen.families.grasp_attempts.gripper_geometry import gripper_geometry
from datagen.families.grasp_attempts.samplers import GraspTarget, Obstacles, SampleResult
from datagen.families.grasp_attempts.samplers.antipodal import PAD_MARGIN
from datagen.families.grasp_attempts.samplers.base import REACH_ROUNDS, choose_reached
from datagen.registries import ROBOTS, SAMPLERS

TABLE = 0.75
PANDA_HAND = gripper_geometry(ROBOTS["panda"].load())
PANDA_MAX_WIDTH = PANDA_HAND.max_width
collides = PANDA_HAND.collides


def on_table(mesh: trimesh.Trimesh, xy=(0.0, 0.0)) -> GraspTarget:
    pose = np.eye(4)
    pose[:3, 3] = (*xy, TABLE - mesh.bounds[0, 2])
    return GraspTarget([mesh.copy().apply_transform(pose)], pose)


def check_antipodal(result, target: GraspTarget, mu: float = 0.5, clearance: float = 0.01):
    cand = result.candidate
    assert cand is not None, result.reason
    p1, p2 = cand.contacts_world
    surface = np.concatenate([b.depth(cand.contacts_world)[None] for b in target.bodies]).min(0)
    assert np.all(np.abs(surface) < 1e-6)  # both contacts on the surface
    closing = (p2 - p1) / np.linalg.norm(p2 - p1)
    assert np.allclose(cand.closing, closing)
    assert abs(cand.approach @ cand.closing) < 1e-9
    assert np.allclose(cand.pose_world[:3, :3].T @ cand.pose_world[:3, :3], np.eye(3))
    assert np.linalg.det(cand.pose_world[:3, :3]) == pytest.approx(1.0)
    # the grasp frame at the contacts' midpoint, or stood back along the approach, the contacts
    # still on the pads
    depth = cand.info["depth"]
    assert 0.0 <= depth <= PANDA_HAND.tip_reach(cand.width) - PAD_MARGIN + 1e-9
    assert np.allclose(cand.pose_world[:3, 3], (p1 + p2) / 2 - depth * cand.approach)
    assert cand.width == pytest.approx(np.linalg.norm(p2 - p1) + clearance)
    assert cand.width <= PANDA_MAX_WIDTH
    # the surface normals at the contacts oppose each other within the friction cone
    normals = []
    for p in (p1, p2):
        body = min(target.bodies, key=lambda b: abs(b.depth(p)[0]))
        normals.append(body.normals[np.argmax(body.normals @ p - body.offsets)])
    cone = np.cos(np.arctan(mu))
    assert closing @ -normals[0] >= cone - 1e-9
    assert -closing @ -normals[1] >= cone - 1e-9
    return cand


def test_antipodal_box_on_table_is_antipodal_and_clear_of_table():
    target = on_table(trimesh.creation.box(extents=(0.05, 0.04, 0.06)))
    obstacles = Obstacles([], TABLE)
    sampler = make_sampler("antipodal")
    for seed in range(5):
        cand = check_antipodal(
            sampler.sample(np.random.default_rng(seed), target, obstacles), target
        )
        assert abs(cand.closing[2]) < 0.5  # closing vertically would put a finger in the table
        assert not collides(cand.pose_world, cand.width, target.bodies, TABLE, 0.1)
        assert cand.approach[2] < -0.3  # from above


def test_antipodal_cylinder():
    cylinder = trimesh.creation.cylinder(radius=0.025, height=0.1, sections=32)
    target = on_table(cylinder)
    sampler = make_sampler("antipodal", friction=0.3)
    for seed in range(5):
        result = sampler.sample(np.random.default_rng(seed), target, Obstacles([], TABLE))
        check_antipodal(result, target, mu=0.3)


def test_antipodal_compound_contacts_are_outermost():
    shape = {
        "family": "compound",
        "parts": [
            {"kind": "box", "extents": [0.04, 0.04, 0.04]},
            {"kind": "box", "extents": [0.02, 0.06, 0.02], "offset": [0.0, 0.02, 0.0],
             "quat_wxyz": [1, 0, 0, 0]},
        ],
    }  # fmt: skip
    geometry = build_geometry(shape)
    pose = np.eye(4)
    pose[:3, 3] = (0.1, 0.0, TABLE + 0.02)
    target = GraspTarget.from_geometry(geometry, pose)
    sampler = make_sampler("antipodal")
    for seed in range(5):
        cand = check_antipodal(
            sampler.sample(np.random.default_rng(seed), target, Obstacles([])), target
        )
        # no contact inside the other part
        assert all(min(b.depth(p)[0] for b in target.bodies) > -1e-6 for p in cand.contacts_world)


def test_antipodal_too_wide_object_reports_why():
    target = on_table(trimesh.creation.box(extents=(0.2, 0.2, 0.2)))
    result = make_sampler("antipodal").sample(np.random.default_rng(0), target, Obstacles([]), 50)
    assert result.candidate is None and result.tries == 50
    assert "wider than" in result.reason


def test_antipodal_avoids_neighbours():
    target = on_table(trimesh.creation.box(extents=(0.04, 0.04, 0.08)))
    # walls 15 mm from the box on both sides along x, 10 mm higher: the fingers do not fit
    # between them, so the gripper must close along y
    walls = [
        trimesh.creation.box(
            (0.01, 0.2, 0.09), trimesh.transformations.translation_matrix((x, 0, 0.795))
        )
        for x in (-0.04, 0.04)
    ]
    obstacles = Obstacles(walls, TABLE)
    sampler = make_sampler("antipodal")
    for seed in range(5):
        cand = sampler.sample(np.random.default_rng(seed), target, obstacles, 500).candidate
        assert cand is not None
        assert not collides(cand.pose_world, cand.width, obstacles.bodies, TABLE, 0.1)
        assert abs(cand.closing[0]) < 0.5  # within the friction cone of the y faces
    # without the walls, the x faces are used too
    free = [sampler.sample(np.random.default_rng(s), target, Obstacles([])) for s in range(20)]
    assert any(abs(r.candidate.closing[0]) > 0.9 for r in free)


def test_samplers_are_deterministic():
    target = on_table(trimesh.creation.cylinder(radius=0.02, height=0.08, sections=24))
    for name in ("antipodal", "random"):
        a, b = (
            make_sampler(name).sample(np.random.default_rng(7), target, Obstacles([]))
            for _ in range(2)
        )
        assert a.candidate.to_json() == b.candidate.to_json()
        c = make_sampler(name).sample(np.random.default_rng(8), target, Obstacles([]))
        assert c.candidate.to_json() != a.candidate.to_json()


def test_random_sampler_near_object_above_table():
    target = on_table(trimesh.creation.box(extents=(0.05, 0.05, 0.05)), xy=(0.1, -0.1))
    lo, hi = target.parts_world[0].bounds
    sampler = make_sampler("random", margin=0.03)
    rng = np.random.default_rng(0)
    for _ in range(50):
        cand = sampler.sample(rng, target, Obstacles([], TABLE)).candidate
        pos = cand.pose_world[:3, 3]
        assert np.all(pos >= lo - 0.03) and np.all(pos <= hi + 0.03) and pos[2] > TABLE
        rot = cand.pose_world[:3, :3]
        assert np.allclose(rot.T @ rot, np.eye(3)) and np.linalg.det(rot) == pytest.approx(1)
        assert cand.width == PANDA_MAX_WIDTH and cand.contacts_world is None


def make_sampler(name: str, **params):
    return SAMPLERS[name].load()(PANDA_HAND, **params)


def test_unknown_sampler_name_lists_the_registered_ones():
    with pytest.raises(
        ConfigError, match=r"campaign.sampler: expected one of \['antipodal', 'random'.*got 'nope'"
    ):
        SAMPLERS.check("nope", "campaign.sampler")


def translated_box(extents, position):
    return trimesh.creation.box(extents, trimesh.transformations.translation_matrix(position))


def test_gripper_collision_check():
    pose = np.eye(4)
    pose[:3, 3] = (0, 0, 1)
    pose[:3, :3] = np.diag([1.0, -1.0, -1.0])  # approach straight down
    big = translated_box((0.1, 0.1, 0.1), (0, 0, 1))  # wider than the open fingers
    assert collides(pose, 0.08, [big])
    far = pose.copy()
    far[0, 3] += 0.2
    assert not collides(far, 0.08, [big])
    # open fingers around a small box clear it, and so does the straight approach from above
    small = translated_box((0.03, 0.03, 0.03), (0, 0, 1))
    assert not collides(pose, 0.06, [small], approach_distance=0.1)
    assert collides(pose, 0.02, [small])  # fingers closed into it
    # a lid above the grasp blocks the approach path, not the grasp pose
    lid = translated_box((0.2, 0.2, 0.01), (0, 0, 1.2))
    assert not collides(pose, 0.06, [small, lid])
    assert collides(pose, 0.06, [small, lid], approach_distance=0.1)
    # the table is the half-space below table_z; the pads reach 9 mm below the TCP
    assert collides(pose, 0.06, [], table_z=0.995)
    assert not collides(pose, 0.06, [], table_z=0.985)


def test_gripper_boxes_follow_the_width():
    """The Panda hand's boxes, read from panda_v2.urdf's collision shapes: four per finger (screw
    mount, sledge, diagonal, rubber tip) and the bounds of hand.stl."""
    boxes = PANDA_HAND.boxes(0.08)
    assert len(boxes) == 9
    pads = [t[:3, 3] for t, e in boxes if np.allclose(e, (0.0175, 0.0152, 0.0185))]
    assert sorted(p[1] for p in pads) == pytest.approx([-0.04758, 0.04758], abs=1e-6)  # URDF
    hand_transform, hand_extents = boxes[-1]
    assert hand_extents == pytest.approx((0.0634, 0.2045, 0.092), abs=2e-4)  # hand.stl's bounds
    assert hand_transform[2, 3] == pytest.approx(0.02 - 0.1034, abs=2e-4)  # behind the TCP
    swept = PANDA_HAND.boxes(0.08, approach_distance=0.1)
    for (t0, e0), (t1, e1) in zip(boxes, swept, strict=True):
        front = t0[2, 3] + np.abs(t0[2, :3]) @ (e0 / 2)
        back = t0[2, 3] - np.abs(t0[2, :3]) @ (e0 / 2)
        assert t1[2, 3] + np.abs(t1[2, :3]) @ (e1 / 2) >= front - 1e-9  # covers the pose
        assert t1[2, 3] - np.abs(t1[2, :3]) @ (e1 / 2) <= back - 0.1 + 1e-9  # and the approach
        # every corner of the box, anywhere on the approach, is inside its swept box; the
        # diagonal block's sweep reaches no further inwards than its own corners
        corners = (CORNER_SIGNS * e0 / 2) @ t0[:3, :3].T + t0[:3, 3]
        for back_by in (0.0, 0.03, 0.1):
            local = (corners - [0, 0, back_by] - t1[:3, 3]) @ t1[:3, :3]
            assert np.all(np.abs(local) <= e1 / 2 + 1e-9)
        swept_corners = (CORNER_SIGNS * e1 / 2) @ t1[:3, :3].T + t1[:3, 3]
        assert np.abs(swept_corners[:, 1]).min() >= np.abs(corners[:, 1]).min() - 1e-9


def _box_meets_body_lp(transform, extents, body) -> bool:
    """Whether the box and the body share a point: the feasibility of their joint half-spaces."""
    from scipy.optimize import linprog

    rot, centre = transform[:3, :3], transform[:3, 3]
    a_ub = np.concatenate([body.normals, rot.T, -rot.T])
    b_ub = np.concatenate(
        [body.offsets, rot.T @ centre + extents / 2, -(rot.T @ centre) + extents / 2]
    )
    return linprog(np.zeros(3), A_ub=a_ub, b_ub=b_ub, bounds=[(None, None)] * 3).status == 0


def test_box_vs_convex_matches_linear_programming():
    """The box test agrees with an exact LP feasibility test on random poses: compact boxes,
    long thin ones (a finger swept along its approach) and flat wide ones that cross the body
    with no corner in it and none of its vertices inside them, the cases only edges decide (a
    box edge through the body, a body edge through a plate)."""
    from datagen.convex import box_hits_body

    rng = np.random.default_rng(3)
    body = ConvexBody.from_mesh(trimesh.creation.cylinder(radius=0.03, height=0.05, sections=12))
    shapes = [([0.005] * 3, [0.05] * 3), ([0.002] * 2 + [0.1], [0.01] * 2 + [0.2])]
    shapes += [([0.08] * 2 + [0.001], [0.15] * 2 + [0.004])]
    hits, edges_only, cases = 0, 0, []
    for k in range(600):
        transform = np.eye(4)
        transform[:3, :3] = trimesh.transformations.random_rotation_matrix(rng.random(3))[:3, :3]
        transform[:3, 3] = rng.uniform(-0.06, 0.06, 3)
        low, high = shapes[k % 3]  # compact, long and thin, flat and wide
        extents = rng.uniform(low, high)
        feasible = _box_meets_body_lp(transform, extents, body)
        hits += feasible
        corners = (CORNER_SIGNS * extents / 2) @ transform[:3, :3].T + transform[:3, 3]
        inside = (body.vertices - transform[:3, 3]) @ transform[:3, :3]
        edges_only += feasible and not (
            body.depth(corners).min() <= 0 or (np.abs(inside) <= extents / 2).all(axis=1).any()
        )
        assert box_hits_body(transform, extents, body) == feasible
        cases.append((transform, extents, feasible))
    assert 60 < hits < 540 and edges_only > 20
    # tested together, in batches of any make-up, each box gets its own answer
    transforms, sizes, expected = (np.array(column) for column in zip(*cases, strict=True))
    together = BodySet((body,)).hit_by_boxes(transforms, sizes)
    assert np.array_equal(together, expected)
    order = rng.permutation(len(cases))
    halves = [BodySet((body,)).hit_by_boxes(transforms[k], sizes[k]) for k in np.split(order, 2)]
    assert np.array_equal(np.concatenate(halves), expected[order])
    # grouped (two boxes a group): a group meets the body when either of its boxes does
    owners = np.arange(len(cases)) // 2
    grouped = BodySet((body,)).hit_by_boxes(transforms, sizes, owners=owners)
    assert np.array_equal(grouped, expected.reshape(-1, 2).any(axis=1))


def test_a_flat_object_is_grasped_standing_back_with_the_fingertips_above_the_table():
    """A 9 mm tall box lying on the table: its side faces are in reach only with the grasp
    frame stood back along the approach (the fingertips reach 9.5 mm past it). The contacts stay
    on the pads and the gripper clear of the table; with no depth allowed there is no grasp."""
    target = on_table(trimesh.creation.box(extents=(0.08, 0.04, 0.009)))
    sampler = make_sampler("antipodal")
    depths = []
    for seed in range(6):
        cand = check_antipodal(
            sampler.sample(np.random.default_rng(seed), target, Obstacles([], TABLE)), target
        )
        assert not collides(cand.pose_world, cand.width, target.bodies, TABLE, 0.1)
        tips = cand.pose_world[:3, 3] + PANDA_HAND.tip_reach(cand.width) * cand.approach
        assert tips[2] >= TABLE
        depths.append(cand.info["depth"])
    assert min(depths) > 0
    flat = dataclasses.replace(sampler, pad_margin=1.0)  # no depth but the contacts' midpoint
    result = flat.sample(np.random.default_rng(0), target, Obstacles([], TABLE))
    assert result.candidate is None and "every approach collides" in result.reason


def test_a_five_joint_arm_gets_approaches_in_its_shoulder_plane_from_above():
    """``approach_plane_through``: every approach lies in the vertical plane through the
    shoulder axis and the grasp centre, within 10 degrees of straight down, and the jaws close
    level, so no try is spent on a top face or a tilted closing."""
    shoulder = (-0.3, 0.1)
    sampler = make_sampler("antipodal")
    found = 0
    for seed in range(8):
        box = trimesh.creation.box(extents=(0.03, 0.05, 0.04))
        target = on_table(box, xy=(0.05 * seed - 0.2, 0.03 * seed))
        target = GraspTarget(target.parts_world, target.pose_world, shoulder)
        result = sampler.sample(np.random.default_rng(seed), target, Obstacles([], TABLE))
        if result.candidate is None:
            continue
        found += 1
        cand = result.candidate
        radial = cand.pose_world[:3, 3] - np.array([*shoulder, cand.pose_world[2, 3]])
        normal = np.cross(radial, [0.0, 0.0, 1.0])
        assert abs(cand.approach @ normal) < 1e-9 * np.linalg.norm(normal) + 1e-12
        assert cand.approach[2] <= -np.cos(np.deg2rad(10.0)) + 1e-12
        assert abs(cand.closing[2]) < 1e-9  # closes level: from above, across the side faces
    assert found >= 6


def test_drawing_several_candidates_starts_with_the_single_one_and_keeps_to_the_budget():
    """``draw``: its first candidate is ``sample``'s from the same stream; a contact pair gives
    up to ``per_pair`` candidates (distinct clear approaches of the same contacts); it stops at
    ``count`` or after ``max_tries`` tries in all."""
    target = on_table(trimesh.creation.box(extents=(0.05, 0.04, 0.06)))
    sampler, obstacles = make_sampler("antipodal"), Obstacles([], TABLE)
    single = sampler.sample(np.random.default_rng(7), target, obstacles).candidate
    found, tries, _ = sampler.draw(np.random.default_rng(7), target, obstacles, 12, 200, 4)
    assert np.array_equal(found[0].pose_world, single.pose_world)
    assert len(found) == 12 and tries <= 200
    pairs: dict[bytes, list] = {}
    for cand in found:
        check_antipodal(SampleResult(cand, 1, ""), target)
        pairs.setdefault(cand.contacts_world.tobytes(), []).append(cand.approach)
    assert 3 <= len(pairs) < 12 and max(len(a) for a in pairs.values()) <= 4
    for approaches in pairs.values():
        assert len({tuple(np.round(a, 9)) for a in approaches}) == len(approaches)
    wide = on_table(trimesh.creation.box(extents=(0.12, 0.12, 0.12)))  # wider than the opening
    found, tries, reason = sampler.draw(np.random.default_rng(7), wide, obstacles, 12, 50, 4)
    assert found == [] and tries == 50 and "in 50 tries" in reason


def test_with_reach_checked_the_first_candidate_the_arm_reaches_is_chosen():
    """``reachable`` stands for the arm's planner (``grasp_attempts.reach``): here, only
    approaches within 20 degrees of straight down reach. The sampler draws its K candidates as
    for the learned sampler and executes the first that reaches, or its first if none does."""
    target = on_table(trimesh.creation.box(extents=(0.05, 0.04, 0.06)))
    sampler, obstacles = make_sampler("antipodal"), Obstacles([], TABLE)
    found, _, _ = sampler.draw(np.random.default_rng(7), target, obstacles, 16, 200, 4)
    steep = np.cos(np.deg2rad(20.0))
    checked = []

    def reachable(candidate) -> bool:
        checked.append(candidate)
        return bool(-candidate.approach[2] > steep)

    result = sampler.sample(np.random.default_rng(7), target, obstacles, reachable=reachable)
    first = next(i for i, c in enumerate(found) if -c.approach[2] > steep)
    assert np.array_equal(result.candidate.pose_world, found[first].pose_world)
    assert result.candidate.info["reach_checked"] == first + 1 == len(checked)
    assert result.candidate.info["reached"] is True

    assert result.candidate.info["reach_rounds"] == 1

    rounds = []  # the candidates of each round drawn while none is reached
    none = sampler.sample(
        np.random.default_rng(7), target, obstacles, reachable=lambda c: rounds.append(c) or False
    )
    assert np.array_equal(none.candidate.pose_world, found[0].pose_world)
    assert none.candidate.info["reached"] is False
    assert none.candidate.info["reach_rounds"] == REACH_ROUNDS
    assert none.candidate.info["reach_checked"] == len(rounds) == REACH_ROUNDS * len(found)
    assert len({c.pose_world.tobytes() for c in rounds}) == len(rounds)  # each round new ones


def test_while_no_candidate_drawn_is_reached_another_round_is_drawn():
    """The arm reaches none of the first round's candidates: the sampler draws a second round
    from the same stream and executes the first of it the arm reaches."""
    target = on_table(trimesh.creation.box(extents=(0.05, 0.04, 0.06)))
    sampler, obstacles = make_sampler("antipodal"), Obstacles([], TABLE)
    rng = np.random.default_rng(7)
    first = sampler.draw(rng, target, obstacles, 16, 200, 4)[0]
    second = sampler.draw(rng, target, obstacles, 16, 200, 4)[0]
    refused = {c.pose_world.tobytes() for c in first}

    result = sampler.sample(
        np.random.default_rng(7),
        target,
        obstacles,
        reachable=lambda c: c.pose_world.tobytes() not in refused,
    )
    assert np.array_equal(result.candidate.pose_world, second[0].pose_world)
    info = result.candidate.info
    assert (info["reached"], info["reach_rounds"], info["reach_checked"]) == (
        True,
        2,
        len(first) + 1,
    )


def test_choosing_among_rounds_keeps_the_best_of_the_first_when_none_is_reached():
    """``choose_reached`` as a pure function: rounds ranked by their own order, the first
    reached taken, and the best of the first round when none is."""
    rounds = iter([[_candidate(0), _candidate(1)], [_candidate(2), _candidate(3)], []])
    worst_first = choose_reached(lambda: (next(rounds), 5, "found"), lambda f: [1, 0], bool)
    assert worst_first.chosen == 1 and worst_first.tries == 5  # ranked first, reached

    rounds = iter([[_candidate(0), _candidate(1)], [_candidate(2), _candidate(3)], []])
    never = choose_reached(lambda: (next(rounds), 5, "found"), lambda f: [1, 0], lambda c: False)
    assert never.chosen == 1 and len(never.drawn) == 4 and never.tries == 15
    assert never.drawn[1].info == {"reach_checked": 4, "reached": False, "reach_rounds": 3}

    nothing = choose_reached(lambda: ([], 200, "no antipodal grasp"), lambda f: [], bool)
    assert (nothing.chosen, nothing.drawn, nothing.tries) == (-1, [], 600)
    assert nothing.reason == "no antipodal grasp, in each of 3 rounds"
    once = choose_reached(lambda: ([], 200, "no antipodal grasp"), lambda f: [], bool, rounds=1)
    assert (once.tries, once.reason) == (200, "no antipodal grasp")


def test_a_round_without_candidates_is_followed_by_another():
    """A round that found no candidate reached none either: the next round is drawn, and when
    none is reached the best of the first round that found any is kept."""
    rounds = iter([[], [_candidate(0), _candidate(1)], []])
    late = choose_reached(lambda: (next(rounds), 200, "r"), lambda f: [1, 0], bool)
    assert (late.chosen, late.tries, len(late.drawn)) == (1, 400, 2)
    assert late.drawn[1].info == {"reach_checked": 1, "reached": True, "reach_rounds": 2}

    rounds = iter([[], [_candidate(0), _candidate(1)], [_candidate(2)]])
    never = choose_reached(
        lambda: (next(rounds), 200, "r"), lambda f: list(range(len(f)))[::-1], _no
    )
    assert (never.chosen, never.tries, len(never.drawn)) == (1, 600, 3)
    assert never.drawn[1].info == {"reach_checked": 3, "reached": False, "reach_rounds": 3}


def _no(candidate: GraspCandidate) -> bool:
    return False


def _candidate(n: int) -> GraspCandidate:
    pose = np.eye(4)
    pose[0, 3] = n
    return GraspCandidate(pose, 0.05, "antipodal", np.zeros((2, 3)), {})
