"""How often a grasp campaign's objects move faster than the hand could push them, per arm.

    .venv/bin/python benchmarks/grasp_disturbances.py                     # panda and iiwa14, 200
    .venv/bin/python benchmarks/grasp_disturbances.py --robot panda --attempts 50 --workers 2
    .venv/bin/python benchmarks/grasp_disturbances.py --contacts 3000   # the cause, no campaign

Runs attempts 0..N-1 of the campaign config (seed and scenes as a campaign makes them; the
post-grasp frame off, as it changes no physics) for each arm and prints, per arm, the attempts
an object moved faster than the hand could push it (``datagen.families.grasp_attempts.disturbance``: the
``disturbed`` outcome), with the peak object and hand speeds of each, the outcome counts, how
far the executed grasp frame was from the planned one at closure, the largest gap between each
arm joint's command and its state through lift and hold, the CPU and the time taken.

``--contacts N`` measures the cause instead: N random poses of a Panda finger box (half sizes
8.75, 7.6, 9.25 mm) within 3 cm of a wall segment of the bowl of campaign seed 0, attempt 2,
each stepped once in SAPIEN with PCM and with SAT contact generation, at contact offsets 10 mm
(SAPIEN's default) and 2 mm; a contact is *deep* when PhysX reports the shapes more than 5 mm
nearer than their exact distance (FCL) while they are apart (an exact separating-axis test).
"""

from __future__ import annotations

import argparse
import collections
import dataclasses
import json
import multiprocessing
import sys
import time
from pathlib import Path

import numpy as np
import sapien
from machine import cpu_model  # benchmarks/machine.py
from mplib.pymp.collision_detection import fcl
from scipy.spatial.transform import Rotation

from datagen.assets.shapes import build_geometry
from datagen.config import BuildConfig, load_config
from datagen.convex import ConvexBody, box_hits_body
from datagen.dataset.trajectory import decode_trajectory
from datagen.registries import FAMILIES

REPO = Path(__file__).resolve().parents[1]
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
FINGER_HALF = np.array([0.00875, 0.0076, 0.00925])  # m, the Panda finger's largest box
DEEP = 0.005  # m nearer than the exact distance


def _pair(scene, material, offset, part, where: np.ndarray, pose: sapien.Pose):
    """A wall segment (dynamic, gravity off) at ``where`` and the finger box (kinematic)."""
    bodies = []
    for shape in (
        sapien.physx.PhysxCollisionShapeConvexMesh(
            np.asarray(part.vertices, np.float32), np.ones(3), material
        ),
        sapien.physx.PhysxCollisionShapeBox(FINGER_HALF, material),
    ):
        shape.set_contact_offset(offset)
        body = sapien.physx.PhysxRigidDynamicComponent()
        body.attach(shape)
        bodies.append(body)
    bodies[0].disable_gravity, bodies[1].kinematic = True, True
    ids = []
    for body, at in zip(bodies, (sapien.Pose(where), sapien.Pose(where) * pose), strict=True):
        entity = sapien.Entity()
        entity.add_component(body)
        entity.set_pose(at)
        scene.add_entity(entity)
        ids.append(entity.per_scene_id)
    return tuple(sorted(ids))


def _apart_distance(part, pose: sapien.Pose) -> float | None:
    """Metres between the segment and the box at ``pose`` in its frame; None if they overlap."""
    transform = pose.to_transformation_matrix()
    if box_hits_body(transform, 2 * FINGER_HALF, ConvexBody.from_mesh(part)):
        return None
    hull = fcl.Convex(np.asarray(part.vertices, float), np.asarray(part.faces, np.int32))
    box = fcl.CollisionObject(fcl.Box(2 * FINGER_HALF), pose.p, pose.q)
    return fcl.distance(fcl.CollisionObject(hull), box, fcl.DistanceRequest()).min_distance


def _deep_contacts(trials: int, pcm: bool, offset: float) -> tuple[int, int, int]:
    """(pairs apart, pairs PhysX reports a contact for, deep contacts among the apart)."""
    config = sapien.physx.get_scene_config()
    config.enable_pcm = pcm
    sapien.physx.set_scene_config(config)
    rng, parts = np.random.default_rng(0), build_geometry(BOWL).parts
    scene, material = sapien.Scene(), sapien.physx.PhysxMaterial(0.7, 0.7, 0.0)
    exact: dict[tuple[int, int], float] = {}
    for i in range(trials):
        part = parts[int(rng.integers(len(parts)))]
        rotation = Rotation.random(random_state=int(rng.integers(2**31)))
        pose = sapien.Pose(
            part.centroid + rng.uniform(-0.03, 0.03, 3), rotation.as_quat()[[3, 0, 1, 2]]
        )
        key = _pair(scene, material, offset, part, np.array([i * 0.5, 0.0, 0.0]), pose)
        distance = _apart_distance(part, pose)
        if distance is not None:
            exact[key] = distance
    scene.step()
    reported: dict[tuple[int, int], float] = {}
    for contact in scene.get_contacts():
        key = tuple(sorted(body.entity.per_scene_id for body in contact.bodies))
        for point in contact.points:
            reported[key] = min(reported.get(key, np.inf), point.separation)
    deep = sum(1 for key, d in exact.items() if reported.get(key, np.inf) < d - DEEP)
    return len(exact), len(reported), deep


def _config(path: str, robot: str) -> BuildConfig:
    loaded = load_config(path).replace(scene="grasp_attempts")
    campaign = dataclasses.replace(loaded.campaign, post_grasp_frame=False, frame_hz=0.0)
    return loaded.replace(robot=dataclasses.replace(loaded.robot, name=robot), campaign=campaign)


def _hold_gap(trajectory: dict) -> dict[str, float] | None:
    """Per arm joint: the largest |command - achieved| through lift and hold (rad); None if
    the attempt never lifted."""
    names = trajectory["names"]
    rows = np.isin(trajectory["phase"], [names["phases"].index(p) for p in ("lift", "hold")])
    if not rows.any():
        return None
    arm = names["action_names"][:-1]
    achieved = trajectory["qpos"][rows][:, [names["joint_names"].index(j) for j in arm]]
    gap = np.abs(trajectory["action"][rows][:, : len(arm)] - achieved).max(axis=0)
    return {joint: round(float(g), 4) for joint, g in zip(arm, gap, strict=True)}


def _attempt(job: tuple[BuildConfig, int]) -> dict:
    config, index = job
    sample = FAMILIES[config.scene].produce_sample(config, config.seed, index)
    attempt = sample.metadata["attempt"]
    outcome = attempt["outcome"]
    recorded = sample.parts.get("trajectory.npz")
    return {
        "hold_gap": _hold_gap(decode_trajectory(recorded)) if recorded else None,
        "index": index,
        "class": attempt["target"]["class"],
        "failure_mode": outcome["failure_mode"],
        "success": outcome["success"],
        "disturbance": outcome.get("details", {}).get("disturbance"),
        "executed_offset": (attempt["grasp"] or {}).get("executed_offset"),
    }


def _report_offsets(offsets: list[dict]) -> None:
    """Executed minus planned grasp frame at closure, in the planned frame (mm, degrees)."""
    if not offsets:
        return
    mm = np.array([o["position"] for o in offsets]) * 1000
    angle = np.array([o["angle_deg"] for o in offsets])
    print(
        f"  executed vs planned grasp over {len(offsets)} closures: approach (z) "
        f"{mm[:, 2].min():.1f} to {mm[:, 2].max():.1f} mm (median {np.median(mm[:, 2]):.1f}), "
        f"closing (y) |{np.abs(mm[:, 1]).max():.1f}| mm at most, x |{np.abs(mm[:, 0]).max():.1f}|"
        f" mm, {angle.max():.2f} degrees at most"
    )


def _report(robot: str, rows: list[dict], seconds: float) -> None:
    disturbed = [r for r in rows if r["failure_mode"] == "disturbed"]
    counts = collections.Counter(r["failure_mode"] or "success" for r in rows)
    print(
        f"{robot}: {len(disturbed)} of {len(rows)} attempts disturbed "
        f"({len(disturbed) / max(len(rows), 1):.1%}); {seconds:.0f} s"
    )
    print(f"  outcomes: {dict(sorted(counts.items()))}")
    for r in disturbed:
        d = r["disturbance"]
        print(
            f"  attempt {r['index']} ({r['class']}): object {d['instance_id']} at "
            f"{d['object_speed']} m/s, hand {d['hand_speed']} m/s, {d['phase']} at {d['time']} s; "
            f"else {d['label']}"
        )
    _report_offsets([r["executed_offset"] for r in rows if r.get("executed_offset")])
    gaps = [r["hold_gap"] for r in rows if r["hold_gap"]]
    if gaps:
        worst = {joint: max(g[joint] for g in gaps) for joint in gaps[0]}
        print(f"  command - achieved through lift and hold, rad, most over {len(gaps)}: {worst}")
    nearest = sorted(
        (r["disturbance"]["object_speed"] - r["disturbance"]["limit"], r["index"])
        for r in rows
        if r["disturbance"] and r not in disturbed
    )[-5:]
    print(
        f"  undisturbed nearest their limit (m/s below it, attempt): "
        f"{[(round(-e, 3), i) for e, i in reversed(nearest)]}"
    )


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--config", default=str(REPO / "configs/grasp_campaign.yaml"))
    parser.add_argument("--robot", action="append", help="repeatable; default panda and iiwa14")
    parser.add_argument("--attempts", type=int, default=200)
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--json", help="also write every attempt's row to this file")
    parser.add_argument("--contacts", type=int, help="measure the contact generation instead")
    args = parser.parse_args()
    print("command:", " ".join([Path(sys.executable).name, *sys.argv]))
    print(f"cpu: {cpu_model()}, {multiprocessing.cpu_count()} cores; workers {args.workers}")
    if args.contacts:
        for pcm, offset in ((True, 0.01), (True, 0.002), (False, 0.01), (False, 0.002)):
            apart, touching, deep = _deep_contacts(args.contacts, pcm, offset)
            print(
                f"{'PCM' if pcm else 'SAT'}, contact offset {offset * 1000:g} mm: {apart} of "
                f"{args.contacts} poses apart, {touching} reported in contact, {deep} deep"
            )
        return 0
    everything: dict[str, list[dict]] = {}
    for robot in args.robot or ["panda", "iiwa14"]:
        config = _config(args.config, robot)
        jobs = [(config, i) for i in range(args.attempts)]
        start = time.monotonic()
        with multiprocessing.get_context("spawn").Pool(args.workers) as pool:
            rows = pool.map(_attempt, jobs, chunksize=1)
        _report(robot, rows, time.monotonic() - start)
        everything[robot] = rows
    if args.json:
        Path(args.json).write_text(json.dumps(everything, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
