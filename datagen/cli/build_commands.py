"""``datagen build`` and ``datagen campaign grasp``: a build with a progress bar."""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
from pathlib import Path

from datagen.cli.common import positive_int, seed
from datagen.config import load_config
from datagen.registries import EXECUTORS, FAMILIES, SAMPLERS, choices


def add_parsers(commands) -> None:
    build = commands.add_parser(
        "build",
        help="render a dataset from a config into WebDataset shards",
        description="Render a dataset: scene workers -> MQTT -> dataset writer -> tar shards + manifest.",
        epilog="scene families (the config's 'scene'): "
        + "; ".join(f"{f.name}: {f.summary}" for f in FAMILIES.values()),
    )
    build.add_argument("config", help="YAML build config, e.g. configs/grasp_tabletop.yaml")
    build.add_argument(
        "--out", required=True, help="output directory for shards, manifest and preview"
    )
    build.add_argument("--num-samples", type=positive_int, help="override the config's num_samples")
    build.add_argument(
        "--workers",
        type=positive_int,
        default=os.cpu_count() or 1,
        help="scene worker processes (default: number of cores)",
    )
    build.add_argument("--seed", type=seed, help="override the config's seed")
    build.add_argument("--overwrite", action="store_true", help="replace whatever is in --out")
    build.add_argument(
        "--resume",
        action="store_true",
        help="finish an interrupted build in --out (same config): only missing samples are made",
    )
    build.add_argument(
        "--broker",
        metavar="URL",
        help="use this MQTT v5 broker (mqtt://[user:pass@]host:port or mqtts://...) instead of "
        "starting Mosquitto; default: $DATAGEN_BROKER_URL, else a private Mosquitto",
    )
    build.add_argument(
        "--writers",
        metavar="IDS",
        help="comma-separated ids of writers started elsewhere ('datagen writer') to use instead "
        "of starting one; they must write into the same directory (shared file system)",
    )
    build.add_argument(
        "--build-id",
        help="topic namespace of the build (default: random); external writers need it",
    )
    build.add_argument("--ca-file", help="CA certificate to verify an mqtts:// broker")
    build.add_argument("--no-preview", action="store_true", help="skip writing preview.png")

    build.add_argument(
        "--executor",
        type=choices(EXECUTORS),
        default="local",
        help="where workers run: processes of this machine, or Ray actors (default: local)",
    )
    build.add_argument(
        "--ray-address",
        default=None,
        help="with --executor ray: 'auto' or ray://HOST:PORT to join a cluster (default: a "
        "local Ray instance); a cluster needs --broker",
    )

    build.set_defaults(run=run_build_command)

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
        type=positive_int,
        help="attempts to record (overrides num_samples)",
    )
    grasp.add_argument("--out", required=True, help="output directory")
    grasp.add_argument("--sampler", type=choices(SAMPLERS), help="override campaign.sampler")
    grasp.add_argument("--workers", type=positive_int, default=os.cpu_count() or 1)
    grasp.add_argument("--seed", type=seed, help="override the config's seed")
    grasp.add_argument(
        "--resume", action="store_true", help="finish an interrupted campaign in --out"
    )
    grasp.add_argument("--overwrite", action="store_true", help="replace whatever is in --out")
    # a campaign is a build: the build options it does not expose take their defaults
    grasp.set_defaults(
        broker=None,
        writers=None,
        build_id=None,
        ca_file=None,
        no_preview=False,
        executor="local",
        ray_address=None,
    )

    grasp.set_defaults(run=run_campaign)


def run_campaign(args: argparse.Namespace) -> int:
    config = load_config(args.config)
    campaign = config.campaign
    if args.sampler:
        campaign = dataclasses.replace(campaign, sampler=args.sampler)
    config = config.replace(scene="grasp_attempts", campaign=campaign)
    result = run_build_command(args, config)
    if result == 0:
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


def run_build_command(args: argparse.Namespace, config=None) -> int:
    from tqdm import tqdm

    from datagen.build.run import run_build
    from datagen.tools.preview import write_preview

    config = config or load_config(args.config)
    overrides = {}
    if args.num_samples is not None:
        overrides["num_samples"] = args.num_samples
    if args.seed is not None:
        overrides["seed"] = args.seed
    config = config.replace(**overrides)
    out = Path(args.out)
    if args.ca_file:  # read by every MQTT client of the build, workers and writer included
        os.environ["DATAGEN_MQTT_CA_FILE"] = args.ca_file
    writers = [w.strip() for w in args.writers.split(",") if w.strip()] if args.writers else None
    print(
        f"datagen: building {config.num_samples} samples of '{config.scene}' "
        f"(seed {config.seed}) with {args.workers} workers into {out}"
    )
    with tqdm(
        total=config.num_samples, unit="sample", dynamic_ncols=True, desc="durable", smoothing=0.1
    ) as bar:

        def on_progress(done: int, total: int) -> None:
            bar.update(done - bar.n)

        result = run_build(
            config,
            out,
            args.workers,
            overwrite=args.overwrite,
            on_progress=on_progress,
            resume=args.resume,
            broker_url=args.broker or os.environ.get("DATAGEN_BROKER_URL"),
            writers=writers,
            build_id=args.build_id,
            executor=args.executor,
            ray_address=args.ray_address,
            on_export_progress=_export_bars(),
        )
    if result.already_complete:
        print(f"datagen: {out} already holds this build ({result.samples} samples); nothing to do.")
    else:
        made = result.samples - result.resumed_from
        rate = made / result.seconds if result.seconds else 0.0
        resumed = f"; {result.resumed_from} were already durable" if result.resumed_from else ""
        print(
            f"datagen: {made} samples in {result.seconds:.1f} s ({rate:.2f} samples/s){resumed} -> {out}"
        )
        recovered = {k: v for k, v in result.restarts.items() if v}
        if recovered or result.reissued:
            print(
                f"datagen: recovered from faults: restarts {recovered or 'none'}, "
                f"samples issued again {result.reissued}"
            )
    from datagen.dataset.loader import read_manifest

    for name, record in read_manifest(out).get("exports", {}).items():
        print(f"datagen: {name} export: {out / record['path']}")
    if not args.no_preview:
        path = write_preview(out, out / "preview.png")
        print(f"datagen: preview with annotation overlays: {path}")
    return 0


def _export_bars():
    """A progress bar per export format the build runs after its samples are durable."""
    from tqdm import tqdm

    bars: dict = {}

    def on_progress(name: str, done: int, total: int) -> None:
        if name not in bars:
            bars[name] = tqdm(total=total, unit="sample", desc=f"export {name}", leave=False)
        bars[name].update(done - bars[name].n)
        if done >= total:
            bars.pop(name).close()

    return on_progress
