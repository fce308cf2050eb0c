"""Commands on a finished dataset: ``inspect``, ``export``, ``replay``, ``preview``."""

from __future__ import annotations

import argparse
import functools
import logging
import sys
from pathlib import Path

from datagen.cli.common import whole_number
from datagen.errors import UserInputError
from datagen.registries import EXPORTS
from datagen.registry import choices

log = logging.getLogger(__name__)
MAX_PREVIEW = 256  # samples in a preview grid
LEROBOT_ROBOTS = ("koch_follower", "so100_follower")  # datagen.exports.lerobot_robots.ARMS
LEROBOT_UNITS = ("degrees", "range_m100_100")  # datagen.exports.lerobot_robots.UNITS


def add_parsers(commands) -> None:
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
        "--out",
        type=_image_path,
        help="PNG: stored | replayed | difference (default: DATASET/replay-KEY.png)",
    )

    export = commands.add_parser(
        "export",
        help=f"write a finished dataset's samples in other formats ({', '.join(EXPORTS)})",
    )
    export.add_argument("dataset", help="dataset directory (with manifest.json)")
    export.add_argument(
        "--to",
        required=True,
        type=_format_list,
        help=f"comma-separated formats: {','.join(EXPORTS)}",
    )
    export.add_argument("--force", action="store_true", help="redo exports already done")
    export.add_argument(
        "--lerobot-robot",
        choices=LEROBOT_ROBOTS,
        help="lerobot: write states and actions with this lerobot arm's motor names, order and "
        "units (a so100 or koch campaign; docs/export-lerobot.md)",
    )
    export.add_argument(
        "--lerobot-units",
        choices=LEROBOT_UNITS,
        help="with --lerobot-robot: its body joints' lerobot mode (default: the arm's own)",
    )

    preview = commands.add_parser(
        "preview", help="draw annotated samples of a dataset into a PNG grid"
    )
    preview.add_argument("dataset", help="dataset directory (with manifest.json)")
    preview.add_argument("--out", type=_image_path, help="PNG path (default: DATASET/preview.png)")
    preview.add_argument(
        "--count",
        type=whole_number(1, MAX_PREVIEW),
        default=8,
        help=f"samples in the grid (1 .. {MAX_PREVIEW})",
    )

    inspect.set_defaults(run=_reading(run_inspect))
    replay.set_defaults(run=_reading(run_replay))
    export.set_defaults(run=_reading(run_export))
    preview.set_defaults(run=_reading(run_preview))
    verify = commands.add_parser(
        "verify",
        help="re-read every shard of a dataset and check each sample against its manifest",
        description="Re-read every shard once: its size and sha256, and each sample's sha256 "
        "against the manifest's; the shards must hold every sample the manifest lists exactly "
        "once, and nothing else. Exit 0 if all is intact; 1 listing the shards and the samples "
        "(by key) that are missing, extra, duplicated or altered; 2 if DATASET is not a "
        "dataset this datagen reads (docs/dataset-format.md).",
    )
    verify.add_argument("dataset", help="dataset directory (with manifest.json)")
    verify.set_defaults(run=run_verify)


def _image_path(text: str) -> str:
    """argparse type: an image file name OpenCV writes by its extension."""
    if Path(text).suffix.lower() not in (".png", ".jpg", ".jpeg"):
        raise argparse.ArgumentTypeError(f"expected a .png or .jpg file name, got {text[:200]!r}")
    return text


def _reading(run):
    """``run`` of a command that reads the user's dataset directory: whatever is wrong with the
    directory or its content (DatasetError, or a value of an unexpected type met while reading)
    is a UserInputError naming the directory: one line and exit status 2, no traceback (-v logs
    it)."""

    @functools.wraps(run)
    def checked(args: argparse.Namespace) -> int:
        from datagen.dataset.loader import DatasetError

        try:
            return run(args)
        except UserInputError:
            raise
        except DatasetError as exc:
            raise UserInputError(str(exc)) from None
        except OSError as exc:
            where = exc.filename or args.dataset
            raise UserInputError(f"{where}: {exc.strerror or exc}") from None
        except (KeyError, IndexError, TypeError, AttributeError, ValueError) as exc:
            log.info("reading %s failed", args.dataset, exc_info=True)
            raise UserInputError(
                f"{args.dataset}: the dataset's content is not what datagen writes "
                f"({type(exc).__name__}: {str(exc)[:200]}); -v shows where"
            ) from None

    return checked


def _format_list(text: str) -> list[str]:
    """``--to``: comma-separated names of EXPORTS; an unknown one is an error naming the choices."""
    names = [n.strip() for n in text.split(",") if n.strip()]
    if not names:
        raise argparse.ArgumentTypeError(
            f"expected a comma-separated list from {EXPORTS.names()}, got {text!r}"
        )
    return [choices(EXPORTS)(name) for name in names]


def run_replay(args: argparse.Namespace) -> int:
    import cv2

    from datagen.dataset.loader import load
    from datagen.exports.files import inside, replace_file, written
    from datagen.tools.replay import comparison_report, refusal, replay_differences

    if reason := refusal(args.dataset):
        print(f"datagen: {reason}", file=sys.stderr)
        return 2
    if args.key not in load(args.dataset).keys:
        print(f"datagen: {args.dataset} has no sample {args.key!r}", file=sys.stderr)
        return 2
    differences = replay_differences(args.dataset, args.key)  # every camera of the sample
    lines, picture = comparison_report(args.key, differences)
    for line in lines:
        print(f"datagen: {line}")
    if args.out:  # the user's path, written as named
        out = Path(args.out)
        written(cv2.imwrite(str(out), picture), out, "OpenCV")
    else:  # in the dataset: a link found at the name is replaced, never written through
        out = inside(Path(args.dataset), f"replay-{args.key}.png")
        replace_file(out, lambda tmp: written(cv2.imwrite(str(tmp), picture), out, "OpenCV"))
    print(f"datagen: wrote {out}")
    return 0


def run_export(args: argparse.Namespace) -> int:
    from datagen.cli.build_commands import write_card
    from datagen.cli.progress import progress as start_progress
    from datagen.exports.runner import run_exports

    bars: dict = {}

    def progress(name: str, done: int, total: int) -> None:  # one bar (or plain lines) per format
        bar = bars.get(name)
        if bar is None:
            bar = bars[name] = start_progress(total, f"exported to {name}", leave=False)
        bar.update_to(done)
        if done >= total:
            bar.close()

    options = _export_options(args)
    try:
        done = run_exports(
            args.dataset, args.to, force=args.force, on_progress=progress, options=options
        )
    finally:
        for bar in bars.values():
            bar.close()
    for name in args.to:
        record = done[name]
        path = Path(args.dataset) / record["path"]
        print(f"datagen: {name}: {path} ({record['bytes'] / 2**20:.1f} MiB)")
    write_card(Path(args.dataset))  # lists the exports
    return 0


def _export_options(args: argparse.Namespace) -> dict[str, dict[str, str]]:
    """The formats' options from their flags; UserInputError if a flag's format is not in --to."""
    if args.lerobot_units and not args.lerobot_robot:
        raise UserInputError("--lerobot-units needs --lerobot-robot")
    if not args.lerobot_robot:
        return {}
    if "lerobot" not in args.to:
        raise UserInputError("--lerobot-robot applies to the lerobot export: add lerobot to --to")
    units = {"units": args.lerobot_units} if args.lerobot_units else {}
    return {"lerobot": {"robot": args.lerobot_robot, **units}}


MAX_SKIP_LINES = 20  # skipped samples named one per line; the rest are counted


def _skip_reporter(command: str):
    """``on_skip`` of a tool: ``datagen COMMAND: sample KEY skipped: why`` on stderr, for the
    first MAX_SKIP_LINES samples, then one line that counts the others."""
    from datagen.cli.common import one_line

    seen = 0

    def report(key: str, reason: str) -> None:
        nonlocal seen
        seen += 1
        if seen <= MAX_SKIP_LINES:
            print(
                f"datagen {command}: sample {one_line(key)} skipped: {one_line(reason)}",
                file=sys.stderr,
            )
        elif seen == MAX_SKIP_LINES + 1:
            print(
                f"datagen {command}: more samples skipped (the first {MAX_SKIP_LINES} are named)",
                file=sys.stderr,
            )

    return report


def run_inspect(args: argparse.Namespace) -> int:
    import json

    from datagen.exports.files import inside, replace_file, tool_folder
    from datagen.tools.inspection import inspect_dataset

    summary, files = inspect_dataset(args.dataset, on_skip=_skip_reporter("inspect"))
    print(summary_table(summary))
    folder = tool_folder(Path(args.dataset), "inspect")
    text = json.dumps(summary, indent=2)
    summary_path = replace_file(inside(folder, "summary.json"), lambda tmp: tmp.write_text(text))
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


def run_preview(args: argparse.Namespace) -> int:
    from datagen.tools.preview import write_preview

    out = Path(args.out) if args.out else None  # None: DATASET/preview.png, links replaced
    path = write_preview(
        Path(args.dataset), out, count=args.count, on_skip=_skip_reporter("preview")
    )
    print(f"datagen: wrote {path}")
    return 0


def run_verify(args: argparse.Namespace) -> int:
    from datagen.cli.progress import progress
    from datagen.dataset.integrity import verify_dataset
    from datagen.dataset.manifest import DatasetError, read_manifest

    try:
        manifest = read_manifest(args.dataset)
    except DatasetError as exc:  # nothing to check against: a user error
        raise UserInputError(str(exc)) from None
    total = sum(record.get("samples", 0) for record in manifest["shards"])
    bar, done = progress(total, "samples verified", leave=False), 0

    def tick() -> None:
        nonlocal done
        done += 1
        bar.update_to(min(done, total))

    try:
        report = verify_dataset(args.dataset, manifest=manifest, on_sample=tick)
    finally:
        bar.close()
    if not report.problems:
        print(f"datagen: {report.summary()}")
        return 0
    print(f"datagen: {args.dataset}: {len(report.problems)} problems:", file=sys.stderr)
    for problem in report.problems:
        print(f"  {problem}", file=sys.stderr)
    return 1
