"""Learning to grasp, measured in the loop: a grasp-quality model trained on an antipodal
campaign chooses among antipodal candidates, on scenes and on objects it never saw.

    .venv/bin/python benchmarks/grasp_learning.py --quick   # minutes: panda, a few dozen attempts
    .venv/bin/python benchmarks/grasp_learning.py           # panda and iiwa14, hours, in parts

Per arm: training campaigns (the antipodal sampler, ``configs/grasp_campaign.yaml`` with the
arm, the default procedural objects), of at most 2,000 attempts each (seed 0, then 1, ...: a
longer curve adds campaigns and keeps those made); models (``datagen.learning``, the code behind
``datagen train grasp``) trained on their first 250, 1,000, 2,000 and 4,000 attempts
(``--curve``); then evaluation campaigns, seed 1000, in two domains: ``scenes`` (held-out scenes
of the default objects) and ``objects`` (held-out objects: the picture library's real robosuite
meshes through ``objects.source: folder``, shapes no training scene drew). In each domain the
antipodal sampler and the learned one run on the same seed and indices, so the same scenes and
the same targets; the learned sampler's first candidate is the antipodal sampler's own. Each
sampler runs twice: as it is, and with ``campaign.check_reach`` (``-reach``: the candidates
planned before one is executed; the antipodal sampler then executes the first of K it draws
that the arm reaches, the learned one the best-scored the arm reaches), so the model's share
and the planning's are told apart. Every model runs in both domains: the learning curve on
scenes of the objects it learned from, and on shapes it never saw. With ``--per-scene 1 4``
a second curve of models is trained on campaigns of 4 grasps a scene
(``campaign.grasps_per_scene``: ``learned-NxK``) and runs on the same evaluation attempts, each
paired against the model of as many attempts of one grasp a scene. ``--domains`` and
``--learned-reach-only`` leave parts out, to fit a shorter run.

Printed per arm and domain: success ± binomial standard error per sampler, the paired
difference learned − antipodal ± its standard error over the same attempts, failure modes,
attempts/s, and the learning curve with the largest model's gain over the smallest, paired
over the same attempts; each model's held-out accuracy, ROC AUC and calibration error on
training attempts it never saw, and its ROC AUC on the grasps the antipodal sampler executed in
each domain, all of them and those the arm reached (the choice left to a model with the check).
Everything is kept under ``--out`` (campaigns, models, ``results.json``,
``grasp_learning.png``): a rerun continues an interrupted campaign and keeps what is finished,
so a run of hours can be done in parts.
"""

from __future__ import annotations

import argparse
import functools
import json
import math
import os
import sys
import time
from collections import Counter
from pathlib import Path

from dr_transfer.building import build
from dr_transfer.hardware import commit
from grasp_learning_report import REACH, draw, model_label, table
from machine import cpu_model

REPO = Path(__file__).resolve().parents[1]
EVAL_SEED = 1000
FULL = {
    "arms": ["panda", "iiwa14"],
    "curve": [250, 1000, 2000, 4000],
    "eval_attempts": 150,
    "epochs": 40,
    "size": "640x480",
}
QUICK = {"arms": ["panda"], "curve": [16, 32], "eval_attempts": 12, "epochs": 20, "size": "160x120"}
TRAINING_CHUNK = 2000  # attempts of one training campaign
DOMAINS = {"scenes": "held-out scenes", "objects": "held-out objects (real meshes)"}


def arguments() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help=f"minutes, not hours: {QUICK}")
    parser.add_argument("--arms", nargs="+", help=f"arms ({FULL['arms']})")
    parser.add_argument(
        "--curve", type=int, nargs="+", help=f"training attempts per model ({FULL['curve']})"
    )
    parser.add_argument(
        "--eval-attempts",
        type=int,
        help=f"attempts per sampler and domain ({FULL['eval_attempts']})",
    )
    parser.add_argument("--epochs", type=int, help=f"training epochs ({FULL['epochs']})")
    parser.add_argument("--size", help=f"camera width x height ({FULL['size']})")
    parser.add_argument(
        "--per-scene",
        type=int,
        nargs="+",
        default=[1],
        help="grasps a scene of the training campaigns (campaign.grasps_per_scene), one model "
        "curve each, side by side on the same evaluation attempts (1)",
    )
    parser.add_argument(
        "--domains", nargs="+", choices=list(DOMAINS), default=list(DOMAINS), help="(both)"
    )
    parser.add_argument(
        "--learned-reach-only",
        action="store_true",
        help="run the learned sampler with the check only (the antipodal sampler both ways)",
    )
    parser.add_argument("--candidates", type=int, default=16, help="K, candidates scored (16)")
    parser.add_argument("--workers", type=int, default=2, help="campaign workers (2)")
    parser.add_argument("--out", type=Path, default=REPO / "benchmarks/results/grasp_learning")
    args = parser.parse_args()
    for name, value in (QUICK if args.quick else FULL).items():
        if getattr(args, name) is None:
            setattr(args, name, value)
    args.curve = sorted(set(args.curve))
    args.per_scene = sorted(set(args.per_scene))
    args.chunk = min(TRAINING_CHUNK, args.curve[-1])
    if uneven := [n for n in args.curve if n > args.chunk and n % args.chunk]:
        parser.error(f"--curve {uneven}: sizes above {args.chunk} must be multiples of it")
    return args


def campaign_data(
    args,
    arm: str,
    seed: int,
    attempts: int,
    domain: str | None,
    model=None,
    reach=False,
    per_scene: int = 1,
):
    """The config dict of one campaign: ``configs/grasp_campaign.yaml`` with the arm, the
    camera size, no post-grasp frame and no step-by-step recording (not needed here); with
    ``reach``, the sampler executes a candidate the arm reaches (``campaign.check_reach``);
    ``per_scene`` grasps a scene (``campaign.grasps_per_scene``)."""
    from datagen.config.yaml_file import read_yaml

    data = read_yaml(REPO / "configs/grasp_campaign.yaml")
    width, height = (int(v) for v in args.size.split("x"))
    campaign = data["campaign"] | {"post_grasp_frame": False, "record_hz": 0}
    if model is not None:
        campaign |= {"sampler": "learned", "model": str(model), "candidates": args.candidates}
    if reach:
        campaign |= {"check_reach": True, "candidates": args.candidates}
    if per_scene > 1:
        campaign |= {"grasps_per_scene": per_scene}
    data |= {
        "num_samples": attempts,
        "seed": seed,
        "robot": {"name": arm},
        "render": {"width": width, "height": height, "wrist_camera": True},
        "campaign": campaign,
    }
    if domain == "objects":
        from datagen.library.catalogue import library_root

        folder = library_root() / "robosuite-objects"
        data["objects"] = {"source": "folder", "assets_dir": str(folder)}
    return data


def run_campaign(name: str, data: dict, args) -> dict:
    """The campaign ``name`` under ``--out/campaigns`` (built, continued or read): per attempt
    success and failure mode in index order, and attempts/s of the run that built it."""
    from datagen.dataset.loader import load
    from datagen.outcomes import sample_outcome

    out = args.out / "campaigns" / name
    print(f"  campaign {name}: {data['num_samples']} attempts", flush=True)
    built = build(f"grasp_learning:{name}", data, out, args.workers)
    timing = out / "timing.json"
    if built is not None:
        timing.write_text(
            json.dumps({"seconds": built.seconds, "steady": built.steady_s_per_frame})
        )
    seconds = json.loads(timing.read_text()) if timing.is_file() else {}
    dataset = load(out)
    metadata = [dataset.metadata(i) for i in range(len(dataset))]
    dataset.close()
    outcomes = [sample_outcome(meta) for meta in metadata]
    steady = seconds.get("steady")
    return {
        "success": [bool(o["success"]) for o in outcomes],
        # whether the sampler found a grasp at all: no choice among candidates mends one it did not
        "found": [o["failure_mode"] != "no_candidate" for o in outcomes],
        "failure_modes": dict(
            sorted(Counter(o["failure_mode"] for o in outcomes if not o["success"]).items())
        ),
        "modes": [o["failure_mode"] for o in outcomes],
        "classes": [str((meta["attempt"]["target"] or {}).get("class")) for meta in metadata],
        "attempts_per_s": round(1 / steady, 4) if steady else None,
        "reach_m": [round(reach(meta), 4) for meta in metadata],
        "ik_failed": [
            (meta["attempt"]["outcome"]["details"].get("transit") or {}).get("status")
            == "IK failed"
            for meta in metadata
        ],
    }


def reach(meta: dict) -> float:
    """Metres from the robot's base to the target, in the horizontal plane."""
    base = meta["robot"]["base_pose"]["position"]
    target = meta["attempt"]["target"]["pose_world"]["position"]
    return math.hypot(target[0] - base[0], target[1] - base[1])


def train_model(arm: str, attempts: int, campaigns, args, per_scene: int = 1) -> dict:
    """The model trained on the first ``attempts`` of the training campaigns (``campaigns(n)``
    builds or reads the first n; the model is kept under --out/models)."""
    from datagen.learning.examples import campaign_examples
    from datagen.learning.fit import fit
    from datagen.learning.report import save_model

    # kept by what makes it: a rerun with other epochs trains anew
    path = (
        args.out / "models" / f"{arm}-{model_label(attempts, per_scene)}-{args.epochs}epochs.onnx"
    )
    report = path.with_suffix(".json")
    if path.is_file() and report.is_file() and keeps_contract(path):
        return json.loads(report.read_text()) | {"path": str(path)}
    roots = campaigns(-(-attempts // args.chunk))
    start = time.perf_counter()
    examples = campaign_examples(roots, "wrist", limit=min(attempts, args.chunk))
    fitted = fit(examples, args.epochs, seed=0)
    facts = {"attempts": attempts, "examples": len(examples), "epochs": args.epochs}
    save_model(fitted, path, facts | {"train_s": round(time.perf_counter() - start, 1)})
    print(f"  model {path.name}: held-out ROC AUC {fitted.scores['roc_auc']}", flush=True)
    return json.loads(report.read_text()) | {"path": str(path)}


def training_name(arm: str, attempts: int, seed: int, per_scene: int = 1) -> str:
    """The folder of one training campaign (the first keeps the name it had before there were
    several)."""
    shared = f"-x{per_scene}" if per_scene > 1 else ""
    return f"{arm}-train-{attempts}{shared}" + (f"-seed{seed}" if seed else "")


def keeps_contract(path: Path) -> bool:
    """Whether a kept model still takes the learned sampler's inputs (a model trained before
    the contract changed is trained anew)."""
    from datagen.grasp_model.model_file import ModelFileError, load_model

    try:
        load_model(path)
    except ModelFileError as error:
        print(f"  model {path.name}: trained anew ({error})", flush=True)
        return False
    return True


def run_arm(arm: str, args) -> dict:
    from datagen.learning.transfer import campaign_auc

    print(f"{arm}:", flush=True)

    @functools.cache  # each campaign built or read once, whichever models need it
    def training_campaign(seed: int, k: int) -> Path:  # built only when a model is to be trained
        name = training_name(arm, args.chunk, seed, k)
        run_campaign(name, campaign_data(args, arm, seed, args.chunk, None, per_scene=k), args)
        return args.out / "campaigns" / name

    def training_campaigns(k: int):  # the first ``count`` of k grasps a scene
        return lambda count: [training_campaign(seed, k) for seed in range(count)]

    models = {  # by model_label
        model_label(n, k): train_model(arm, n, training_campaigns(k), args, k)
        for k in args.per_scene
        for n in args.curve
    }
    result: dict = {"models": {n: _model_summary(m) for n, m in models.items()}, "domains": {}}
    checks = [REACH] if args.learned_reach_only else ["", REACH]
    for domain in args.domains:
        samplers = {"antipodal": None, f"antipodal{REACH}": None}
        for label, model in models.items():
            samplers |= {f"learned-{label}{suffix}": model for suffix in checks}
        runs, folders = {}, {}
        for sampler, model in samplers.items():
            path = model and model["path"]
            reach = sampler.endswith(REACH)
            data = campaign_data(args, arm, EVAL_SEED, args.eval_attempts, domain, path, reach)
            scored_by = f"-{model['model_sha256'][:12]}" if model else ""  # a new model, anew
            name = f"{arm}-{domain}-{sampler}{scored_by}-{args.eval_attempts}"
            runs[sampler], folders[sampler] = run_campaign(name, data, args), name
        result["domains"][domain] = runs
        antipodal = args.out / "campaigns" / folders["antipodal"]
        for label, model in models.items():  # on the grasps the antipodal sampler tried
            transfer = result["models"][label].setdefault("transfer", {})
            transfer[domain] = campaign_auc(model["path"], antipodal)
    return result


def _model_summary(report: dict) -> dict:
    held = report["held_out"]
    return {
        "examples": report.get("examples"),
        "sha256": report["model_sha256"],
        "accuracy": held["accuracy"],
        "roc_auc": held["roc_auc"],
        "ece": held["calibration"]["ece"],
        "within_scene": held.get("within_scene"),
        "train_s": report.get("train_s"),
    }


def main() -> int:
    args = arguments()
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    python = os.path.relpath(sys.executable) if sys.executable.startswith(os.getcwd()) else "python"
    result = {
        "command": " ".join([python, *sys.argv]),
        "commit": commit(REPO),
        "cpu": f"{cpu_model()}, {len(os.sched_getaffinity(0))} cores",
        "settings": {
            k: getattr(args, k)
            for k in ("curve", "per_scene", "domains", "eval_attempts", "epochs", "size")
        }
        | {"candidates": args.candidates, "workers": args.workers},
        "arms": {},
    }
    print(result["cpu"], flush=True)
    for arm in args.arms:
        result["arms"][arm] = run_arm(arm, args)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "results.json").write_text(json.dumps(result, indent=1) + "\n")
    draw(result, args.out / "grasp_learning.png")
    print("\n" + table(result), flush=True)
    print(f"\nresults: {args.out / 'results.json'}, picture: {args.out / 'grasp_learning.png'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
