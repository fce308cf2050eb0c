"""``datagen build`` and ``datagen campaign grasp``: a build with a progress bar."""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import os
import shlex
import sys
from pathlib import Path

from datagen.cli.common import (
    MAX_WORKERS,
    broker_url,
    build_id,
    one_line,
    readable_file,
    seed,
    whole_number,
    writer_ids,
)
from datagen.cli.monitor_commands import build_monitor
from datagen.cli.progress import progress
from datagen.config import BuildConfig, load_config
from datagen.registries import EXECUTORS, FAMILIES
from datagen.registry import choices
from datagen.transport.broker_url import (
    BROKER_URL_ENV,
    SAMPLE_BROKER_URLS_ENV,
    WORKER_BROKER_URL_ENV,
)

_SAMPLES = {f.name: f for f in dataclasses.fields(BuildConfig)}["num_samples"].metadata
NUM_SAMPLES = whole_number(_SAMPLES["min"], _SAMPLES["max"])
WORKERS = whole_number(1, MAX_WORKERS)
DEFAULT_WORKERS = min(os.cpu_count() or 1, MAX_WORKERS)
OVERWRITE_HELP = (
    "replace what is in --out: only a datagen output (its build.json or datagen manifest.json) "
    "or an empty directory; anything else is refused"
)
CHECK_HELP = (
    "only validate: the config, the options and --out (exists or can be created, is writable, "
    "and what the build would do with it); print the result and exit 0 (2 on an error) without "
    "starting anything or leaving anything on disk"
)

MONITOR_HELP = (
    "watch it live in the browser: serves the monitor page for the build's own broker and "
    "prints its URL (an external broker: 'datagen monitor --broker ws://...', docs/monitor.md)"
)


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
    build.add_argument(
        "--num-samples",
        type=NUM_SAMPLES,
        help="override the config's num_samples (1 .. 10^9-1)",
    )
    build.add_argument(
        "--workers",
        type=WORKERS,
        default=DEFAULT_WORKERS,
        help=f"scene worker processes or Ray actors (1 .. {MAX_WORKERS}; default: number of cores)",
    )
    build.add_argument("--seed", type=seed, help="override the config's seed")
    build.add_argument("--overwrite", action="store_true", help=OVERWRITE_HELP)
    build.add_argument(
        "--resume",
        action="store_true",
        help="finish an interrupted build in --out (same config): only missing samples are made",
    )
    build.add_argument(
        "--broker",
        metavar="URL",
        type=broker_url,
        help="use this MQTT v5 broker (mqtt://[user:pass@]host:port or mqtts://...) instead of "
        "starting Mosquitto; default: $DATAGEN_BROKER_URL (prefer it: arguments show in ps), "
        "else a private Mosquitto",
    )
    build.add_argument(
        "--worker-broker",
        metavar="URL",
        type=broker_url,
        help="the scene workers' own URL for the --broker broker, e.g. with a user that may "
        "only publish samples (docs/deployment.md, 'Least privilege'); default: "
        "$DATAGEN_WORKER_BROKER_URL, else the --broker URL",
    )
    build.add_argument(
        "--sample-broker",
        metavar="URL",
        type=broker_url,
        action="append",
        help="spread the samples over several brokers: give this once per broker, in the same "
        "order on every run; sample i goes to the (i mod count)-th. Each needs writers of its "
        "own ('datagen writer --sample-broker URL', named in --writers); commands, acks and "
        f"status stay on --broker. Default: ${SAMPLE_BROKER_URLS_ENV} (comma-separated), else "
        "the --broker alone (docs/scale-out.md, 'Several brokers')",
    )
    build.add_argument(
        "--writers",
        metavar="IDS",
        type=writer_ids,
        help="comma-separated ids of writers started elsewhere ('datagen writer') to use instead "
        "of starting one; they must write into the same directory (shared file system)",
    )
    build.add_argument(
        "--build-id",
        type=build_id,
        help="topic namespace of the build (default: random); external writers need it",
    )
    build.add_argument(
        "--ca-file", type=readable_file, help="CA certificate to verify an mqtts:// broker"
    )
    build.add_argument("--no-preview", action="store_true", help="skip writing preview.png")
    build.add_argument("--check", action="store_true", help=CHECK_HELP)
    build.add_argument("--monitor", action="store_true", help=MONITOR_HELP)

    build.add_argument(
        "--executor",
        type=choices(EXECUTORS),
        default="local",
        help="where workers run: processes of this machine, Ray actors, or simulated workers "
        "that replay --replay's samples (default: local)",
    )
    build.add_argument(
        "--replay",
        default=None,
        metavar="DATASET",
        help="with --executor simulated: a finished dataset whose samples the workers publish "
        "re-keyed, rendering nothing (a transport and coordinator load test)",
    )
    build.add_argument(
        "--ray-address",
        default=None,
        help="with --executor ray: 'auto' or ray://HOST:PORT to join a cluster (default: a "
        "local Ray instance); a cluster needs --broker",
    )

    build.set_defaults(run=run_build_command, command_parser=build)


# options a resumed build must not repeat; options repeated even at their default
_NOT_RESUMED = {"help", "resume", "overwrite"}
_ALWAYS_RESUMED = {"workers"}  # its default is the number of cores: one value may be given
_URLS = {"broker", "worker_broker", "sample_broker"}  # printed without their passwords


def resume_command(args: argparse.Namespace) -> str:
    """The command that finishes the interrupted build or campaign of ``args``: every option
    given (those at their default omitted, but for ``--workers``) plus ``--resume``, values
    shell-quoted, the broker URL's password replaced by ``***``."""
    from datagen.transport.broker_url import redact

    words = ["datagen", *(["-v"] if args.verbose else [])]
    words += ["build"] if args.command == "build" else ["campaign", args.kind]
    note = ""
    for action in args.command_parser._actions:
        value = getattr(args, action.dest, None)
        if action.dest in _NOT_RESUMED or value is None or value is False:
            continue
        if not action.option_strings:  # positional
            words.append(shlex.quote(str(value)))
            continue
        if value == action.default and action.dest not in _ALWAYS_RESUMED:
            continue
        flag = max(action.option_strings, key=len)
        if action.nargs == 0:  # a switch
            words.append(flag)
            continue
        for item in value if isinstance(value, list) else [value]:  # list: given repeatedly
            if action.dest in _URLS and redact(item) != item:
                item, note = redact(item), " (put the broker's password back in place of ***)"
            words += [flag, shlex.quote(str(item))]
    return " ".join([*words, "--resume"]) + note


def run_build_command(args: argparse.Namespace, config=None) -> int:
    from datagen.pipeline.run import run_build
    from datagen.tools.preview import write_preview

    config = config or load_config(args.config)
    overrides = {}
    if args.num_samples is not None:
        overrides["num_samples"] = args.num_samples
    if args.seed is not None:
        overrides["seed"] = args.seed
    config = config.replace(**overrides)
    out = Path(args.out)
    plan = check_build(args, config, out)  # before anything starts: UserInputError -> exit 2
    if args.check:
        print(f"datagen: check passed: {args.config}: {_check_report(args, config, out, plan)}")
        return 0
    if args.ca_file:  # read by every MQTT client of the build, workers and writer included
        os.environ["DATAGEN_MQTT_CA_FILE"] = args.ca_file
    writers = [w.strip() for w in args.writers.split(",") if w.strip()] if args.writers else None
    workers = min(args.workers, config.num_samples)  # a worker more would have nothing to make
    capped = "" if workers == args.workers else f" (--workers {args.workers}: one per sample)"
    print(
        f"datagen: building {config.num_samples} samples of '{config.scene}' "
        f"(seed {config.seed}) with {workers} workers{capped} into {out}"
    )
    bar = progress(config.num_samples, "durable")
    pages = contextlib.ExitStack()
    try:
        result = run_build(
            config,
            out,
            workers,
            overwrite=args.overwrite,
            on_progress=lambda done, _total: bar.update_to(done),
            resume=args.resume,
            broker_url=args.broker or os.environ.get(BROKER_URL_ENV),
            worker_broker_url=args.worker_broker or os.environ.get(WORKER_BROKER_URL_ENV),
            sample_broker_urls=sample_brokers(args),
            writers=writers,
            build_id=args.build_id,
            executor=args.executor,
            executor_options={"recorded": args.replay} if args.executor == "simulated" else None,
            ray_address=args.ray_address,
            on_export_progress=_export_bars(),
            monitor=build_monitor(pages) if args.monitor else None,
        )
    finally:
        bar.close()
        pages.close()
    if result.already_complete:
        print(f"datagen: {out} already holds this build ({result.samples} samples); nothing to do.")
    else:
        made = result.samples - result.resumed_from
        rate = made / result.seconds if result.seconds else 0.0
        resumed = f"; {result.resumed_from} were already durable" if result.resumed_from else ""
        if result.changed:
            shown = ", ".join(result.changed_keys) + (" ..." if result.changed > 10 else "")
            print(
                f"datagen: made again {result.changed} samples whose bytes on disk were not those "
                f"recorded when they were made durable (changed since): {shown}"
            )
        print(
            f"datagen: {made} samples in {result.seconds:.1f} s ({rate:.2f} samples/s){resumed} -> {out}"
        )
        recovered = {k: v for k, v in result.restarts.items() if v}
        if recovered or result.reissued:
            print(
                f"datagen: recovered from faults: restarts {recovered or 'none'}, "
                f"samples issued again {result.reissued}"
            )
        if result.rejected:
            print(
                "datagen: dropped control-plane messages that were not the build's "
                f"(unsigned, forged or replayed): {result.rejected}"
            )
    from datagen.dataset.loader import read_manifest

    for name, record in read_manifest(out).get("exports", {}).items():
        print(f"datagen: {name} export: {out / record['path']}")
    if not args.no_preview:
        path = write_preview(out)
        print(f"datagen: preview with annotation overlays: {path}")
    write_card(out)
    return 0


def write_card(out: Path) -> None:
    """The dataset card (README.md, croissant.json) unless it is newer than the manifest."""
    from datagen.dataset.manifest import DatasetError
    from datagen.exports.card import card_is_current, write_dataset_card
    from datagen.tools.inspection import metadata_summary

    if card_is_current(out):
        return
    try:
        card, _ = write_dataset_card(out, metadata_summary(out))
    except DatasetError as exc:  # the samples are there; the card of unreadable ones is not
        print(f"datagen: no dataset card: {one_line(str(exc))}", file=sys.stderr)
        return
    print(f"datagen: dataset card: {card}")


def _export_bars():
    """A progress bar (or plain lines) per export format the build runs after its samples are
    durable."""
    bars: dict = {}

    def on_progress(name: str, done: int, total: int) -> None:
        if name not in bars:
            bars[name] = progress(total, f"exported to {name}", leave=False)
        bars[name].update_to(done)
        if done >= total:
            bars.pop(name).close()

    return on_progress


# what ``--check`` reports a build would do with --out
_PLANS = {
    "new": "the config and options are valid; {out} is new or empty and writable",
    "complete": "{out} already holds this build (same config, seed and sample count): "
    "nothing to do",
    "resume": "the config and options are valid; the interrupted build in {out} can be resumed",
    "overwrite": "the config and options are valid; {out} holds a datagen output that "
    "--overwrite would replace",
    "remake": "the config and options are valid; {out} holds this build, but its shards differ "
    "from its manifest ({problems}): --resume would make them again",
}


def _check_report(args: argparse.Namespace, config: BuildConfig, out: Path, plan: str) -> str:
    """What ``--check`` says of ``out`` (a finished build's shards are read whole, as built)."""
    from datagen.pipeline.out_dir import finished_build_problems

    if plan == "complete" and (problems := finished_build_problems(out, config, args.resume)):
        return _PLANS["remake"].format(out=out, problems="; ".join(problems))
    return _PLANS[plan].format(out=out)


def sample_brokers(args: argparse.Namespace) -> list[str] | None:
    """The brokers the samples are spread over: ``--sample-broker`` URLs, else
    ``$DATAGEN_SAMPLE_BROKER_URLS`` (comma-separated), else None (the build's broker)."""
    from datagen.errors import UserInputError
    from datagen.transport.broker_url import parse_broker_url

    if args.sample_broker:
        return list(args.sample_broker)
    listed = [u.strip() for u in os.environ.get(SAMPLE_BROKER_URLS_ENV, "").split(",")]
    for k, url in enumerate(u for u in listed if u):
        try:
            parse_broker_url(url)
        except ValueError as exc:  # the message shows the URL without its password
            raise UserInputError(f"${SAMPLE_BROKER_URLS_ENV}, URL {k + 1}: {exc}") from None
    return [u for u in listed if u] or None


def check_build(args: argparse.Namespace, config: BuildConfig, out: Path) -> str:
    """What a build with ``args`` would do with ``out`` (a key of ``_PLANS``), after checking
    everything that can be checked before anything starts; raises UserInputError (exit 2)."""
    from datagen.errors import UserInputError
    from datagen.pipeline.out_dir import plan_out_dir
    from datagen.transport.broker_url import parse_broker_url

    urls = {}
    for option, env in (("broker", BROKER_URL_ENV), ("worker_broker", WORKER_BROKER_URL_ENV)):
        urls[option] = getattr(args, option) or os.environ.get(env)
        if not getattr(args, option) and os.environ.get(env):
            try:
                parse_broker_url(os.environ[env])
            except ValueError as exc:  # the message shows the URL without its password
                raise UserInputError(f"${env}: {exc}") from None
    if urls["worker_broker"] and not urls["broker"]:
        raise UserInputError(
            f"--worker-broker (or ${WORKER_BROKER_URL_ENV}) names the workers' user on an "
            f"external broker: give that broker with --broker (or ${BROKER_URL_ENV}) too"
        )
    if (several := sample_brokers(args)) and not (urls["broker"] and args.writers):
        raise UserInputError(
            f"{len(several)} sample brokers (--sample-broker or ${SAMPLE_BROKER_URLS_ENV}) need "
            "the build's own broker (--broker) and a writer set per sample broker started with "
            "'datagen writer --sample-broker URL' and named in --writers "
            "(docs/scale-out.md, 'Several brokers')"
        )
    if getattr(args, "monitor", False) and urls["broker"]:
        raise UserInputError(
            "--monitor serves the page for the build's own broker; with an external broker run "
            "'datagen monitor --broker ws://HOST:PORT' (its WebSockets listener: docs/monitor.md)"
        )
    if args.executor == "ray" and args.ray_address and not urls["broker"]:
        raise UserInputError(
            "--executor ray on a cluster needs a broker every node can reach: pass --broker "
            "mqtt://HOST:PORT (see docs/deployment.md, 'Ray cluster')"
        )
    return plan_out_dir(out, config, args.overwrite, args.resume)
