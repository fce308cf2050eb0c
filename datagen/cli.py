"""The ``datagen`` command line. It owns the terminal: progress bars, messages, exit codes."""

from __future__ import annotations

import argparse
import logging
import os
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
    build.add_argument("--no-preview", action="store_true", help="skip writing preview.png")

    preview = commands.add_parser(
        "preview", help="draw annotated samples of a dataset into a PNG grid"
    )
    preview.add_argument("dataset", help="dataset directory (with manifest.json)")
    preview.add_argument("--out", help="PNG path (default: DATASET/preview.png)")
    preview.add_argument("--count", type=_positive_int, default=8, help="samples in the grid")
    return parser


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    logging.basicConfig(
        level=logging.INFO if args.verbose else logging.WARNING,
        format="%(levelname)s %(name)s: %(message)s",
    )
    try:
        if args.command == "build":
            return _build(args)
        return _preview(args)
    except ConfigError as exc:
        print(f"datagen: config error: {exc}", file=sys.stderr)
        return EXIT_USER_ERROR
    except KeyboardInterrupt:
        print(
            "\ndatagen: interrupted; the output directory is incomplete (no manifest).",
            file=sys.stderr,
        )
        return EXIT_INTERRUPTED


def _build(args: argparse.Namespace) -> int:
    from tqdm import tqdm

    from datagen.build import BuildError, run_build
    from datagen.preview import write_preview

    config = load_config(args.config)
    overrides = {}
    if args.num_samples is not None:
        overrides["num_samples"] = args.num_samples
    if args.seed is not None:
        overrides["seed"] = args.seed
    config = config.replace(**overrides)
    out = Path(args.out)
    print(
        f"datagen: building {config.num_samples} samples of '{config.scene}' (seed {config.seed}) with {args.workers} workers into {out}"
    )
    bar = tqdm(
        total=config.num_samples, unit="sample", dynamic_ncols=True, desc="durable", smoothing=0.1
    )

    def on_progress(done: int, total: int) -> None:
        bar.update(done - bar.n)

    try:
        result = run_build(
            config, out, args.workers, overwrite=args.overwrite, on_progress=on_progress
        )
    except BuildError as exc:
        bar.close()
        print(f"datagen: build failed: {exc}", file=sys.stderr)
        return 1
    finally:
        bar.close()
    if result.already_complete:
        print(f"datagen: {out} already holds this build ({result.samples} samples); nothing to do.")
    else:
        rate = result.samples / result.seconds if result.seconds else 0.0
        print(
            f"datagen: {result.samples} samples in {result.seconds:.1f} s ({rate:.2f} samples/s) -> {out}"
        )
    if not args.no_preview:
        path = write_preview(out, out / "preview.png")
        print(f"datagen: preview with annotation overlays: {path}")
    return 0


def _preview(args: argparse.Namespace) -> int:
    from datagen.preview import write_preview

    out = Path(args.out) if args.out else Path(args.dataset) / "preview.png"
    path = write_preview(Path(args.dataset), out, count=args.count)
    print(f"datagen: wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
