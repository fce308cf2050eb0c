"""The ``datagen`` command line. It owns the terminal: progress bars, messages, exit codes."""

from __future__ import annotations

import argparse
import logging
import os
import signal
import sys
from pathlib import Path

from datagen.config import ConfigError, load_config

EXIT_USER_ERROR = 2
EXIT_INTERRUPTED = 130


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a number >= 1, got {value}")
    return value


def _seed(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
    if not 0 <= value < 2**63:
        raise argparse.ArgumentTypeError(f"expected a seed in [0, 2^63), got {value}")
    return value


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="datagen",
        description="Synthetic, annotated, reproducible datasets for robot learning.",
    )
    parser.add_argument("-v", "--verbose", action="store_true", help="log what every part does")
    commands = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)

    build = commands.add_parser(
        "build",
        help="render a dataset from a config into WebDataset shards",
        description="Render a dataset: scene workers -> MQTT -> dataset writer -> tar shards + manifest.",
    )
    build.add_argument("config", help="YAML build config, e.g. configs/grasp_tabletop.yaml")
    build.add_argument(
        "--out", required=True, help="output directory for shards, manifest and preview"
    )
    build.add_argument(
        "--num-samples", type=_positive_int, help="override the config's num_samples"
    )
    build.add_argument(
        "--workers",
        type=_positive_int,
        default=os.cpu_count() or 1,
        help="scene worker processes (default: number of cores)",
    )
    build.add_argument("--seed", type=_seed, help="override the config's seed")
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
        choices=["local", "ray"],
        default="local",
        help="where workers run: processes of this machine, or Ray actors (default: local)",
    )
    build.add_argument(
        "--ray-address",
        default=None,
        help="with --executor ray: 'auto' or ray://HOST:PORT to join a cluster (default: a "
        "local Ray instance); a cluster needs --broker",
    )

    writer = commands.add_parser(
        "writer",
        help="run a dataset writer for a build on an external broker (e.g. on the storage machine)",
        add_help=False,
    )
    writer.add_argument("args", nargs=argparse.REMAINDER)
    broker = commands.add_parser(
        "broker", help="run Mosquitto with the settings datagen needs and print how to connect"
    )
    broker.add_argument("--host", default="127.0.0.1", help="address to listen on (0.0.0.0: all)")
    broker.add_argument("--port", type=_positive_int, default=1883)
    broker.add_argument("--data-dir", help="persistence directory (default: a temporary one)")
    broker.add_argument("--username", help="default: generated")
    broker.add_argument("--password", help="default: generated; prefer $DATAGEN_BROKER_PASSWORD")
    broker.add_argument("--tls-cert", help="server certificate (PEM): listen with TLS (mqtts://)")
    broker.add_argument("--tls-key", help="the certificate's private key (PEM)")
    broker.add_argument("--advertise-host", help="host name to print in the URL clients use")

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
        type=_positive_int,
        help="attempts to record (overrides num_samples)",
    )
    grasp.add_argument("--out", required=True, help="output directory")
    grasp.add_argument(
        "--sampler", choices=["antipodal", "random"], help="override campaign.sampler"
    )
    grasp.add_argument("--workers", type=_positive_int, default=os.cpu_count() or 1)
    grasp.add_argument("--seed", type=_seed, help="override the config's seed")
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

    inspect = commands.add_parser(
        "inspect", help="summarise a dataset, draw its annotations and plot its distributions"
    )
    inspect.add_argument("dataset", help="dataset directory (with manifest.json)")

    replay = commands.add_parser(
        "replay", help="re-render a sample from its stored USD description and compare"
    )
    replay.add_argument("dataset", help="dataset directory (with manifest.json and usd/)")
    replay.add_argument("key", help="sample key, e.g. 000000042")
    replay.add_argument(
        "--out", help="PNG: stored | replayed | difference (default: DATASET/replay-KEY.png)"
    )

    export = commands.add_parser(
        "export",
        help="write a finished dataset's samples in other formats (COCO, HDF5, point clouds, USD)",
    )
    export.add_argument("dataset", help="dataset directory (with manifest.json)")
    export.add_argument(
        "--to",
        required=True,
        type=_sink_list,
        help="comma-separated formats: coco,hdf5,pointcloud,usd",
    )
    export.add_argument("--force", action="store_true", help="redo exports already done")

    preview = commands.add_parser(
        "preview", help="draw annotated samples of a dataset into a PNG grid"
    )
    preview.add_argument("dataset", help="dataset directory (with manifest.json)")
    preview.add_argument("--out", help="PNG path (default: DATASET/preview.png)")
    preview.add_argument("--count", type=_positive_int, default=8, help="samples in the grid")
    return parser


def main(argv: list[str] | None = None) -> int:
    # a parent may hand us SIGINT blocked (it is then never delivered): Ctrl-C must work
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
    args = _parser().parse_args(argv)
    logging.basicConfig(
        level=logging.INFO if args.verbose else logging.WARNING,
        format="%(levelname)s %(name)s: %(message)s",
    )
    from datagen.build.coordinator import BuildError
    from datagen.dataset.loader import DatasetError
    from datagen.engines.transfer.connection import MqttConnectError
    from datagen.engines.transfer.mosquitto import BrokerError

    try:
        if args.command == "build":
            return _build(args)
        if args.command == "writer":
            from datagen.sinks.writer import main as writer_main

            return writer_main(args.args)
        if args.command == "broker":
            return _broker(args)
        if args.command == "campaign":
            return _campaign(args)
        if args.command == "inspect":
            return _inspect(args)
        if args.command == "export":
            return _export(args)
        if args.command == "replay":
            return _replay(args)
        return _preview(args)
    except ConfigError as exc:
        print(f"datagen: config error: {exc}", file=sys.stderr)
        return EXIT_USER_ERROR
    except (BuildError, BrokerError, MqttConnectError, DatasetError) as exc:
        print(f"datagen: {args.command} failed: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        hint = ""
        if args.command in ("build", "campaign"):
            command = "build" if args.command == "build" else "campaign grasp"
            hint = f" Finish it with: datagen {command} {args.config} --out {args.out} --resume"
        print(
            f"\ndatagen: interrupted; the output is incomplete (no manifest).{hint}",
            file=sys.stderr,
        )
        return EXIT_INTERRUPTED


def _campaign(args: argparse.Namespace) -> int:
    import dataclasses

    config = load_config(args.config)
    campaign = config.campaign
    if args.sampler:
        campaign = dataclasses.replace(campaign, sampler=args.sampler)
    config = config.replace(scene="grasp_attempts", campaign=campaign)
    result = _build(args, config)
    if result == 0:
        _print_campaign(Path(args.out))
    return result


def _print_campaign(out: Path) -> None:
    import json

    stats = json.loads((out / "manifest.json").read_text()).get("campaign", {})
    if not stats:
        return
    print(f"datagen: {stats['attempts']} grasp attempts, success rate {stats['success_rate']:.1%}")
    for name, row in {**stats["per_sampler"], **stats["per_family"]}.items():
        print(f"  {name:<10} {row['attempts']:>6} attempts  {row['success_rate']:>6.1%} success")
    print(f"  failures: {stats['failure_modes']}")


def _sink_list(text: str) -> list[str]:
    from datagen.exports.runner import EXPORTS

    names = [n.strip() for n in text.split(",") if n.strip()]
    unknown = [n for n in names if n not in EXPORTS]
    if unknown or not names:
        raise argparse.ArgumentTypeError(
            f"expected a comma-separated list from {sorted(EXPORTS)}, got {text!r}"
        )
    return names


def _replay(args: argparse.Namespace) -> int:
    import cv2
    import numpy as np

    from datagen.dataset.loader import load
    from datagen.tools.replay import replay

    dataset = load(args.dataset)
    if args.key not in dataset.keys:
        print(f"datagen: {args.dataset} has no sample {args.key!r}", file=sys.stderr)
        return 2
    stored = dataset[dataset.keys.index(args.key)]["rgb"]
    replayed = replay(args.dataset, args.key)["workspace"]
    diff = np.abs(stored.astype(int) - replayed.astype(int)).max(axis=2)
    same = float((diff == 0).mean())
    print(
        f"datagen: replayed {args.key}: {same:.2%} of pixels identical, "
        f"mean difference {diff.mean():.3f}, largest {diff.max()} (0-255)"
    )
    out = Path(args.out or Path(args.dataset) / f"replay-{args.key}.png")
    heat = cv2.applyColorMap(np.clip(diff * 8, 0, 255).astype(np.uint8), cv2.COLORMAP_INFERNO)
    rgb = [cv2.cvtColor(a, cv2.COLOR_RGB2BGR) for a in (stored, replayed)]
    cv2.imwrite(str(out), np.hstack([*rgb, heat]))
    print(f"datagen: wrote {out}")
    return 0


def _export(args: argparse.Namespace) -> int:
    from datagen.exports.runner import run_exports

    done = run_exports(args.dataset, args.to, force=args.force)
    for name in args.to:
        record = done[name]
        path = Path(args.dataset) / record["path"]
        print(f"datagen: {name}: {path} ({record['bytes'] / 2**20:.1f} MiB)")
    return 0


def _inspect(args: argparse.Namespace) -> int:
    import json

    from datagen.tools.inspection import inspect_dataset

    summary, files = inspect_dataset(args.dataset)
    print(summary_table(summary))
    summary_path = Path(args.dataset) / "inspect" / "summary.json"
    summary_path.write_text(json.dumps(summary, indent=2))
    for path in [*files, summary_path]:
        print(f"datagen: wrote {path}")
    return 0


def summary_table(summary: dict, indent: int = 0) -> str:
    """Nested summary -> aligned two-column text, sub-tables indented."""
    width = max((len(str(k)) for k in summary), default=0)
    lines = []
    for key, value in summary.items():
        if isinstance(value, dict) and value:
            lines.append(f"{' ' * indent}{key}")
            lines.append(summary_table(value, indent + 2))
        else:
            shown = f"{value:.4g}" if isinstance(value, float) else value
            lines.append(f"{' ' * indent}{key!s:<{width}}  {shown}")
    return "\n".join(lines)


def _build(args: argparse.Namespace, config=None) -> int:
    from tqdm import tqdm

    from datagen.build.coordinator import run_build
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


def _broker(args: argparse.Namespace) -> int:
    from datagen.engines.transfer.mosquitto import run_broker_forever

    password = args.password or os.environ.get("DATAGEN_BROKER_PASSWORD")

    def ready(broker) -> None:
        print("datagen: broker ready; connect builds and writers with:", flush=True)
        print(f"  {broker.public_url}", flush=True)
        print("datagen: Ctrl-C stops it.", flush=True)

    return run_broker_forever(
        host=args.host,
        port=args.port,
        data_dir=args.data_dir,
        username=args.username,
        password=password,
        tls_cert=args.tls_cert,
        tls_key=args.tls_key,
        advertise_host=args.advertise_host,
        on_ready=ready,
    )


def _preview(args: argparse.Namespace) -> int:
    from datagen.tools.preview import write_preview

    out = Path(args.out) if args.out else Path(args.dataset) / "preview.png"
    path = write_preview(Path(args.dataset), out, count=args.count)
    print(f"datagen: wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
