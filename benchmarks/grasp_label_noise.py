"""How repeatable a grasp's label is: the campaign's executed grasp, and the same grasp moved by
a few millimetres or turned by a few degrees, each executed in a rebuild of the settled scene.

    .venv/bin/python benchmarks/grasp_label_noise.py --quick      # a minute: 2 scenes
    .venv/bin/python benchmarks/grasp_label_noise.py              # panda, held-out objects

A grasp model sees the scene's depth around the grasp in pixels of about 5 mm (a 32-pixel crop
covering 0.16 m). Where a grasp's outcome changes when it moves by less than that, the label is
noise to any model of that input, however much data it has. Per scene index (seed 1000, the
evaluation scenes of ``benchmarks/grasp_learning.py``; ``campaign.check_reach`` on, so the
executed grasp is one the arm reaches), the campaign's attempt is made as the campaign makes
it; then its grasp is executed again, unchanged and under each perturbation, in a scene rebuilt
from the same (seed, index) (``benchmarks/grasp_labels.py`` shows a rebuild is the settled
scene again):

- ``none``: unchanged, from the pose as the attempt's record keeps it (to 10⁻⁷ m);
- ``closing±``, ``approach±``, ``side±``: the hand moved ``--offset`` metres along its closing
  axis, its approach axis, and the third axis;
- ``turn±``: the hand turned ``--angle`` degrees about its approach axis.

Printed, over the attempts whose grasp the arm reached: whether every rebuild of a scene left
its objects exactly where its first rebuild did; how often each perturbation keeps the label
(over the copies the arm still reached and that nothing disturbed: a copy's reach is planned,
not learned); how many grasps change their label under at least one, by outcome; and the ROC
AUC with which the perturbed copies' share of successes ranks the attempts' own labels: what a
model that knew each grasp's chance of holding within those tolerances, and nothing finer,
would score (the models of ``benchmarks/grasp_learning.py`` score 0.52-0.64 on reached grasps
of held-out objects).
"""

from __future__ import annotations

import argparse
import sys
from collections import Counter
from pathlib import Path

import numpy as np
from dr_transfer.hardware import commit
from grasp_labels import poses
from grasp_learning import campaign_data
from machine import cpu_model

REPO = Path(__file__).resolve().parents[1]
FULL = {"scenes": 40, "size": "320x240"}
QUICK = {"scenes": 2, "size": "160x120"}
SEED = 1000
NOT_EXECUTED = ("no_candidate", "unreachable", "disturbed")


def arguments() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help=f"a minute: {QUICK}")
    parser.add_argument("--arm", default="panda", help="robot (panda)")
    parser.add_argument("--domain", default="objects", choices=("objects", "scenes"))
    parser.add_argument("--scenes", type=int, help=f"scene indices ({FULL['scenes']})")
    parser.add_argument("--size", help=f"camera width x height ({FULL['size']})")
    parser.add_argument("--offset", type=float, default=0.002, help="metres (0.002)")
    parser.add_argument("--angle", type=float, default=3.0, help="degrees (3)")
    parser.add_argument("--candidates", type=int, default=16, help="K of the check (16)")
    args = parser.parse_args()
    for name, value in (QUICK if args.quick else FULL).items():
        if getattr(args, name) is None:
            setattr(args, name, value)
    return args


def perturbations(offset: float, angle_deg: float) -> dict[str, np.ndarray]:
    """name -> (4, 4) transform applied in the grasp's own frame (x: side, y: closing,
    z: approach)."""
    out = {"none": np.eye(4)}
    for name, axis in (("side", 0), ("closing", 1), ("approach", 2)):
        for sign in (1, -1):
            move = np.eye(4)
            move[axis, 3] = sign * offset
            out[f"{name}{'+' if sign > 0 else '-'}"] = move
    for sign in (1, -1):
        a = np.deg2rad(sign * angle_deg)
        turn = np.eye(4)
        turn[:2, :2] = [[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]]
        out[f"turn{'+' if sign > 0 else '-'}"] = turn
    return out


def repeated(config, index: int, moves: dict[str, np.ndarray]) -> dict | None:
    """The attempt at ``index`` and its grasp under each of ``moves``: {"attempt": its failure
    mode, name: failure mode}; None when the attempt executed no reached grasp."""
    from datagen.families.grasp_attempts import produce as attempt
    from datagen.families.grasp_attempts.execute import execute_grasp
    from datagen.families.grasp_attempts.grasps import GraspCandidate

    record = attempt.produce(config, SEED, index).metadata["attempt"]
    mode = record["outcome"]["failure_mode"]
    if record["grasp"] is None or mode in NOT_EXECUTED:
        return None
    pose = np.asarray(record["grasp"]["pose_world"], float)
    params = attempt.execution_params(config.campaign)
    modes: dict = {"attempt": mode, "settled": True}
    first = None  # where the first rebuild left the objects
    for name, move in moves.items():
        scene = attempt.attempt_scene(config, SEED, index)
        now = poses(scene)
        first = now if first is None else first
        modes["settled"] &= now == first
        target = next(o for o in scene.objects if o.instance_id == record["target"]["instance_id"])
        candidate = GraspCandidate(pose @ move, record["grasp"]["width"], "perturbed")
        outcome = execute_grasp(scene, target.instance_id, candidate, params, None)
        modes[name] = None if outcome.success else outcome.failure_mode
    return modes


def main() -> None:
    args = arguments()
    from datagen.config import config_from_dict

    command = "benchmarks/grasp_label_noise.py " + " ".join(sys.argv[1:])
    print(f"{cpu_model()}; {command}; commit {commit(REPO)}", flush=True)
    domain = None if args.domain == "scenes" else "objects"
    data = campaign_data(args, args.arm, SEED, args.scenes, domain, reach=True)
    config = config_from_dict(data, "label noise")
    moves = perturbations(args.offset, args.angle)
    rows = []
    for index in range(args.scenes):
        modes = repeated(config, index, moves)
        print(f"  scene {index}: {modes}", flush=True)
        if modes is not None:
            rows.append(modes)
    report(args, moves, rows)


def report(args, moves: dict, rows: list[dict]) -> None:
    n = len(rows)
    print(
        f"{args.arm}, held-out {args.domain}, {args.scenes} scene indices, {n} with a reached "
        f"grasp; perturbations of {args.offset * 1000:g} mm and {args.angle:g} degrees"
    )
    print(f"  rebuilt scenes matching the first build: {sum(r['settled'] for r in rows)} of {n}")
    held = np.array([r["attempt"] is None for r in rows], bool)
    print(f"  attempts that held: {int(held.sum())} of {n}")
    for name in moves:
        copies = [r for r in rows if r[name] not in NOT_EXECUTED]
        same = sum((r[name] is None) == (r["attempt"] is None) for r in copies)
        not_executed = Counter(r[name] for r in rows if r[name] in NOT_EXECUTED)
        print(
            f"  {name:9}: label equal to the attempt's {same} of {len(copies)} executed "
            f"({n - len(copies)} not: {dict(not_executed)})"
        )
    moved = [name for name in moves if name != "none"]
    executed = [[r[m] for m in moved if r[m] not in NOT_EXECUTED] for r in rows]
    flips = np.array(
        [
            any((m is None) != (r["attempt"] is None) for m in e)
            for r, e in zip(rows, executed, strict=True)
        ]
    )
    print(
        f"  label changed under at least one executed perturbation: {int(flips[held].sum())} "
        f"of {int(held.sum())} that held, {int(flips[~held].sum())} of {int((~held).sum())} "
        "that failed"
    )
    from datagen.learning.metrics import roc_auc

    share = np.array([np.mean([m is None for m in e]) if e else 0.5 for e in executed])
    auc = roc_auc(share, held) if n else None
    shown = "n/a (one outcome only)" if auc is None else f"{auc:.3f}"
    print(f"  ROC AUC of the perturbed copies' share of successes on the attempts' labels: {shown}")


if __name__ == "__main__":
    main()
