"""``datagen campaign grasp``: grasp-attempt campaigns, builds whose samples are executed grasps
labelled by their outcome (the sampler and its model may be given on the command line)."""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path

from datagen.cli.build_commands import (
    CHECK_HELP,
    DEFAULT_WORKERS,
    MONITOR_HELP,
    NUM_SAMPLES,
    OVERWRITE_HELP,
    WORKERS,
    run_build_command,
)
from datagen.cli.common import MAX_WORKERS, seed
from datagen.config import config_from_dict
from datagen.config.yaml_file import read_yaml
from datagen.errors import UserInputError
from datagen.registries import SAMPLERS
from datagen.registry import choices


def add_parsers(commands) -> None:
    campaign = commands.add_parser(
        "campaign",
        help="record physically executed grasp attempts with success labels",
        description="Grasp-attempt campaigns: one executed Panda grasp per sample, same workers, "
        "MQTT transport and writers as every build.",
    )
    kinds = campaign.add_subparsers(dest="kind", metavar="KIND", required=True)
    grasp = kinds.add_parser("grasp", help="grasp attempts in randomised tray scenes")
    grasp.add_argument("config", help="YAML config, e.g. configs/grasp_campaign.yaml")
    grasp.add_argument(
        "--attempts",
        dest="num_samples",
        metavar="N",
        type=NUM_SAMPLES,
        help="attempts to record (overrides num_samples; 1 .. 10^9-1)",
    )
    grasp.add_argument("--out", required=True, help="output directory")
    grasp.add_argument("--sampler", type=choices(SAMPLERS), help="override campaign.sampler")
    grasp.add_argument(
        "--model",
        metavar="FILE",
        help="override campaign.model: the learned sampler's ONNX grasp model "
        "(docs/campaigns.md, 'Learning to grasp')",
    )
    grasp.add_argument(
        "--grasps-per-scene",
        metavar="K",
        type=int,
        help="override campaign.grasps_per_scene: K attempts a scene, each its own candidate "
        "(training data with pairs to rank; docs/campaigns.md, 'Learning to grasp')",
    )
    grasp.add_argument(
        "--workers",
        type=WORKERS,
        default=DEFAULT_WORKERS,
        help=f"scene worker processes (1 .. {MAX_WORKERS}; default: number of cores)",
    )
    grasp.add_argument("--seed", type=seed, help="override the config's seed")
    grasp.add_argument(
        "--resume", action="store_true", help="finish an interrupted campaign in --out"
    )
    grasp.add_argument("--overwrite", action="store_true", help=OVERWRITE_HELP)
    grasp.add_argument("--check", action="store_true", help=CHECK_HELP)
    grasp.add_argument("--monitor", action="store_true", help=MONITOR_HELP)
    # a campaign is a build: the build options it does not expose take their defaults
    grasp.set_defaults(
        broker=None,
        worker_broker=None,
        sample_broker=None,
        writers=None,
        build_id=None,
        ca_file=None,
        no_preview=False,
        executor="local",
        ray_address=None,
    )

    grasp.set_defaults(run=run_campaign, command_parser=grasp)


def run_campaign(args: argparse.Namespace) -> int:
    data = read_yaml(Path(args.config))
    data = data if data is not None else {}
    if isinstance(data, dict):  # anything else: config_from_dict says what was expected
        overrides = {"sampler": args.sampler} if args.sampler else {}
        if args.model:  # relative to the working directory, as every path on the command line
            overrides |= {"model": os.path.abspath(args.model), "model_sha256": None}
        if args.grasps_per_scene is not None:
            overrides |= {"grasps_per_scene": args.grasps_per_scene}
        campaign = data.get("campaign")
        if overrides and (campaign is None or isinstance(campaign, dict)):
            data = data | {"campaign": (campaign or {}) | overrides}
        data = data | {"scene": "grasp_attempts"}
    config = config_from_dict(data, source=args.config)
    if args.model and config.campaign.sampler != "learned":
        raise UserInputError(
            f"--model is the learned sampler's model, but the sampler is "
            f"{config.campaign.sampler!r}: add --sampler learned"
        )
    result = run_build_command(args, config)
    if result == 0 and not args.check:
        _print_campaign(Path(args.out))
    return result


def _print_campaign(out: Path) -> None:
    stats = json.loads((out / "manifest.json").read_text()).get("campaign", {})
    if not stats:
        return
    print(f"datagen: {stats['attempts']} grasp attempts, success rate {stats['success_rate']:.1%}")
    for name, row in {**stats["per_sampler"], **stats["per_family"]}.items():
        print(f"  {name:<10} {row['attempts']:>6} attempts  {row['success_rate']:>6.1%} success")
    print(f"  failures: {stats['failure_modes']}")
