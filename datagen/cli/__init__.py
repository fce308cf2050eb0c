"""The ``datagen`` command line: one parser, one module per group of commands. The CLI owns the
terminal (progress bars, messages, exit codes); library code only logs and reports through
callbacks.

Each command module has ``add_parsers(commands)`` (its sub-commands, each with
``set_defaults(run=...)``) and the ``run`` functions that return the exit code.
"""

from __future__ import annotations

import argparse
import logging
import signal
import sys
from pathlib import Path

from datagen.cli import (
    build_commands,
    campaign_commands,
    dataset_commands,
    evaluate_commands,
    library_commands,
    monitor_commands,
    service_commands,
    train_commands,
)
from datagen.cli.common import EXIT_INTERRUPTED, one_line
from datagen.errors import ConfigError, UserInputError

COMMAND_MODULES = (
    build_commands,
    campaign_commands,
    service_commands,
    dataset_commands,
    monitor_commands,
    library_commands,
    train_commands,
    evaluate_commands,
)


def version() -> str:
    """The installed package's version, else the one in the source tree."""
    from importlib import metadata

    try:
        return metadata.version("datagen")
    except metadata.PackageNotFoundError:
        import datagen

        return datagen.__version__


def parser() -> argparse.ArgumentParser:
    root = argparse.ArgumentParser(
        prog="datagen",
        description="Synthetic, annotated, reproducible datasets for robot learning.",
    )
    root.add_argument("-v", "--verbose", action="store_true", help="log what every part does")
    root.add_argument("--version", action="version", version=f"datagen {version()}")
    commands = root.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for module in COMMAND_MODULES:
        module.add_parsers(commands)
    return root


class _CurrentStderr(logging.StreamHandler):
    """Writes to whatever ``sys.stderr`` is when a record comes (tests redirect it)."""

    @property
    def stream(self):
        return sys.stderr

    @stream.setter
    def stream(self, _value) -> None:
        pass


def _report_plugins_on_stderr() -> None:
    """A skipped plug-in as one line, ``datagen: plug-in 'X' (from distribution Y) skipped: why``,
    whatever the log level (the registries load plug-ins while the parser is built)."""
    plugins = logging.getLogger("datagen.plugins")
    if not any(isinstance(h, _CurrentStderr) for h in plugins.handlers):
        handler = _CurrentStderr()
        handler.setFormatter(logging.Formatter("datagen: %(message)s"))
        plugins.addHandler(handler)
        plugins.propagate = False


def _asks_version(argv: list[str]) -> bool:
    """Whether the options before the command hold ``--version``: answered without building the
    commands' parsers, whose help lists the plug-ins (so no plug-in is imported)."""
    for token in argv:
        if token == "--version":
            return True
        if not token.startswith("-"):
            return False
    return False


def main(argv: list[str] | None = None) -> int:
    # a parent may hand us SIGINT blocked (it is then never delivered): Ctrl-C must work
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
    argv = sys.argv[1:] if argv is None else list(argv)
    if _asks_version(argv):
        print(f"datagen {version()}")
        return 0
    _report_plugins_on_stderr()
    args = parser().parse_args(argv)
    logging.basicConfig(
        level=logging.INFO if args.verbose else logging.WARNING,
        format="%(levelname)s %(name)s: %(message)s",
    )
    from datagen.errors import DatagenError, disk_full_message, is_disk_full

    try:
        return args.run(args)
    except DatagenError as exc:
        print(_reported(args, exc), file=sys.stderr)
        return exc.exit_status
    except OSError as exc:
        if not is_disk_full(exc):
            raise
        where = disk_full_message(exc, getattr(args, "out", None) or ".")
        print(f"datagen: {args.command} failed: {where}{_resume_hint(args)}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        hint = ""
        if args.command in ("build", "campaign"):
            hint = f" Finish it with: {build_commands.resume_command(args)}"
        print(
            f"\ndatagen: interrupted; the output is incomplete (no manifest).{hint}",
            file=sys.stderr,
        )
        return EXIT_INTERRUPTED


def _reported(args: argparse.Namespace, exc: Exception) -> str:
    """What the CLI prints of a datagen error: a user's input on one line (nothing has started),
    else what failed, with the command that finishes a started build."""
    if isinstance(exc, ConfigError):
        return f"datagen: config error: {one_line(str(exc))}"
    if isinstance(exc, UserInputError):  # an option, --out, a dataset directory
        return f"datagen {args.command}: error: {one_line(str(exc))}"
    return f"datagen: {args.command} failed: {exc}{_resume_hint(args)}"


def _resume_hint(args: argparse.Namespace) -> str:
    """For a build or campaign that failed after it started (its ``DIR/build.json`` exists, so
    what is durable stays): the whole command that finishes it."""
    from datagen.pipeline.out_dir import BUILD_STATE

    out = getattr(args, "out", None)
    if (
        args.command not in ("build", "campaign")
        or not out
        or not (Path(out) / BUILD_STATE).is_file()
    ):
        return ""
    return f"\nOnce the cause is fixed, finish it with: {build_commands.resume_command(args)}"
