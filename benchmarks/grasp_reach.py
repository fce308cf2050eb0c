"""Attempts that no choice among the antipodal sampler's candidates could mend: whether the arm
reaches any of them.

    .venv/bin/python benchmarks/grasp_reach.py CAMPAIGN [--modes unreachable] [--tries 400]

For each attempt of the campaign folder CAMPAIGN that ended in one of ``--modes``, its scene is
rebuilt from the campaign's config, seed and index, the target chosen again, and the antipodal
sampler asked for every candidate it finds in ``--tries`` tries: every clear approach of every
contact pair, from the attempt's own ``grasp`` stream. Each is planned as the campaign executes
it (``datagen.families.grasp_attempts.reach``, what ``campaign.check_reach`` asks): collision-free
IK at the pre-grasp pose, a straight approach to the grasp pose and a straight lift. Printed per
attempt: the target, its extents, its horizontal distance from the base, the candidates, the
range of their approach's tilt from straight down and how many the arm reaches (and, for an
attempt whose sampler found none, the reasons it recorded); then how many attempts have none,
which bounds any sampler that chooses among these candidates.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from dr_transfer.hardware import commit
from machine import cpu_model

REPO = Path(__file__).resolve().parents[1]
EVERY_APPROACH = 24  # the antipodal sampler's approach_angles: every approach of a pair


def arguments() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("campaign", type=Path, help="a campaign folder (datagen campaign grasp)")
    parser.add_argument(
        "--modes", nargs="+", default=["unreachable"], help="failure modes to look at"
    )
    parser.add_argument("--tries", type=int, default=400, help="contact pairs tried (400)")
    return parser.parse_args()


def reach_of(config, seed: int, index: int, tries: int) -> dict:
    """The candidates of attempt ``index``'s scene and how many of them the arm reaches."""
    import numpy as np

    from datagen.families.grasp_attempts import produce as attempt
    from datagen.families.grasp_attempts.gripper_geometry import gripper_geometry
    from datagen.families.grasp_attempts.reach import ArmReach
    from datagen.families.grasp_attempts.samplers.antipodal import AntipodalSampler
    from datagen.seeding import sample_rng

    scene = attempt.attempt_scene(config, seed, index)
    campaign, _, target = attempt.observe_attempt(config, seed, index, 0, scene)
    geometry = gripper_geometry(scene.spec)
    sampler = AntipodalSampler.from_campaign(campaign, geometry)
    found, _, _ = sampler.draw(
        sample_rng(seed, index, "grasp"),
        *attempt.grasp_problem(scene, target),
        tries * EVERY_APPROACH,
        tries,
        EVERY_APPROACH,
    )
    reach = ArmReach(scene, attempt.execution_params(campaign))
    reached = sum(reach(candidate) for candidate in found)
    tilts = [math.degrees(math.acos(float(np.clip(-c.approach[2], -1, 1)))) for c in found]
    base = scene.robot.get_root_pose().p
    centre = target.entity.pose.p
    return {
        "class": target.class_name,
        "distance_m": math.hypot(centre[0] - base[0], centre[1] - base[1]),
        "extents_m": sorted(float(e) for e in target.geometry.obb_extents),
        "candidates": len(found),
        "tilts": (min(tilts), max(tilts)) if tilts else None,
        "reached": reached,
    }


def main() -> None:
    args = arguments()
    from datagen.config import config_from_dict
    from datagen.dataset.loader import load

    print(
        f"{cpu_model()}; benchmarks/grasp_reach.py {' '.join(sys.argv[1:])}; commit {commit(REPO)}"
    )
    dataset = load(args.campaign)
    config = config_from_dict(dataset.manifest["config"], str(args.campaign / "manifest.json"))
    chosen, reasons = [], {}
    for i in range(len(dataset)):
        record = dataset.metadata(i)["attempt"]
        if (record["outcome"]["failure_mode"] or "success") in args.modes:
            # the scene's index: the attempt's own, or the one it shares (grasps_per_scene)
            index = int((record.get("shared_scene") or {}).get("scene_index", record["index"]))
            chosen.append((int(record["scene_seed"]), index))
            # why a sampler found none: its rejections, most frequent first
            reasons[index] = record["outcome"]["details"].get("reason", "")
    dataset.close()
    chosen = list(dict.fromkeys(chosen))  # a shared scene once
    none = 0
    for seed, index in chosen:
        found = reach_of(config, seed, index, args.tries)
        none += found["reached"] == 0
        tilts = "-".join(f"{t:.0f}" for t in found["tilts"]) if found["tilts"] else "-"
        why = f"; the campaign's sampler: {reasons[index]}" if reasons[index] else ""
        print(
            f"  attempt {index}: {found['class']} "
            f"({' x '.join(f'{e:.3f}' for e in found['extents_m'])} m) "
            f"{found['distance_m']:.3f} m from the base, "
            f"{found['candidates']} candidates ({tilts} deg from straight down), "
            f"{found['reached']} reached{why}",
            flush=True,
        )
    print(
        f"{args.campaign.name}: {none} of {len(chosen)} attempts ({', '.join(args.modes)}) have "
        "no candidate the arm reaches"
    )


if __name__ == "__main__":
    main()
