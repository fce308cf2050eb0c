"""The output directory of a build and its identity (``DIR/build.json``): a build id that names
its MQTT topics and a secret that signs its samples. An interrupted build resumes with the same
identity; a directory holding something else is never mixed into."""

from __future__ import annotations

import fnmatch
import os
import re
import secrets
import shutil
import tempfile
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from datagen.config import BuildConfig, config_from_dict
from datagen.config.versions import as_current_version
from datagen.errors import BuildError, ConfigError, OutDirError
from datagen.pipeline import finished_build
from datagen.registries import EXPORTS
from datagen.safe_json import loads_bounded
from datagen.shards import DATASET_FORMAT, MANIFEST, write_json_durably
from datagen.transport.wire import SECRET_ENV, parse_secret

BUILD_STATE = "build.json"
# What datagen writes in a dataset directory (names, or shell patterns), and so all that
# --overwrite deletes; a folder among them (an export, inspect/) is datagen's as a whole.
DATAGEN_FILES = (
    MANIFEST,
    BUILD_STATE,
    "shard-*.tar",
    "preview.png",
    "replay-*.png",
    "inspect",
    "README.md",
    "croissant.json",  # the dataset card
    ".writer-*.journal",
    ".writer-*.lock",
    "writer-*.json",  # the writers' journals, locks, parts
    # written, then renamed into place or removed
    f"{MANIFEST}.tmp",
    f"{BUILD_STATE}.tmp",
    "writer-*.json.tmp",
    ".shard-*.tar.rewrite",
    ".datagen-write-test-*",
)
MAX_MANIFEST_BYTES = 2**30  # 89 bytes a sample (docs/dataset-format.md): 10^7 samples fit
SHOWN = 5  # names listed in a message; the count says how many more there are


def _read_json(path: Path) -> dict[str, Any] | None:
    """The object in ``path``; None if it cannot be read or is not bounded JSON (safe_json)."""
    try:
        doc = loads_bounded(path.read_bytes(), what=str(path), max_bytes=MAX_MANIFEST_BYTES)
    except (OSError, ValueError):
        return None
    return doc if isinstance(doc, dict) else None


@dataclass(frozen=True)
class BuildIdentity:
    build_id: str
    secret: bytes = field(repr=False)  # signs every sample and message; never printed


def prepare_out_dir(
    out_dir: Path, config: BuildConfig, overwrite: bool, resume: bool, build_id: str | None
) -> tuple[BuildIdentity | None, bool]:
    """Returns (build identity, already complete). Refuses to mix builds in one directory. A
    finished build whose shards differ from its manifest is named (OutDirError), or with
    ``resume`` reopened and resumed: what differs is made again."""
    plan = plan_out_dir(out_dir, config, overwrite, resume)
    if plan == "complete":
        if not finished_build_problems(out_dir, config, resume):
            return None, True
        finished_build.reopen(out_dir, (_read_json(out_dir / MANIFEST) or {})["shards"])
        plan = "resume"
    if plan == "resume":
        state = _read_json(out_dir / BUILD_STATE) or {}
        return BuildIdentity(state["build_id"], parse_secret(state["secret"])), False
    if plan == "overwrite":
        _clear(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    try:
        secret = parse_secret(os.environ[SECRET_ENV]) if os.environ.get(SECRET_ENV) else None
    except ValueError as exc:
        raise BuildError(str(exc)) from None
    identity = BuildIdentity(build_id or secrets.token_hex(6), secret or secrets.token_bytes(32))
    state = {
        "build_id": identity.build_id,
        "secret": identity.secret.hex(),
        "config": config.to_dict(),
        "started_utc": now_utc(),
    }
    write_json_durably(out_dir, state, name=BUILD_STATE, mode=0o600)  # it holds the secret
    return identity, False


def plan_out_dir(out_dir: Path, config: BuildConfig, overwrite: bool, resume: bool) -> str:
    """What a build of ``config`` with these options does with ``out_dir``, changing nothing:
    ``complete`` (it holds this build, finished: ``prepare_out_dir`` reads it against its
    manifest before nothing is done), ``resume``, ``overwrite`` (a datagen
    output, cleared first) or ``new`` (absent or empty). Raises OutDirError, saying what it
    found, for a directory the build must not use: not a directory, not writable, holding
    something else (without ``--overwrite``), not a datagen output or holding files datagen
    did not write (with it), or both ``--resume`` and ``--overwrite``."""
    if resume and overwrite:
        raise OutDirError(
            f"{out_dir}: --resume finishes the build in it, --overwrite deletes it: give one of "
            "them, not both"
        )
    _check_writable(out_dir)
    manifest = _read_json(out_dir / MANIFEST)
    finished = manifest.get("config") if manifest else None
    if isinstance(finished, dict):
        finished = _as_read_now(finished, str(out_dir / MANIFEST))
    if (
        not overwrite
        and manifest
        and finished == config.to_dict()
        and manifest.get("samples") == config.num_samples
    ):
        return "complete"
    state = _read_json(out_dir / BUILD_STATE)
    if resume:
        check_build_state(out_dir, config)
        return "resume"
    entries = _entries(out_dir)
    if not entries or _only_waiting_writers(out_dir, entries):
        return "new"
    if not overwrite:
        hint = " or pass --resume to finish it" if state else ""
        raise OutDirError(
            f"{out_dir} is not empty and does not hold a complete build of this config "
            f"(same config, seed and sample count); choose another --out{hint}, "
            f"or pass --overwrite to replace it"
        )
    if not _is_datagen_output(manifest, state):
        raise OutDirError(
            f"{out_dir}: --overwrite deletes only a datagen output (with its {BUILD_STATE}, or a "
            f"{MANIFEST} of format {DATASET_FORMAT!r}) or an empty directory; this one holds "
            f"{_first_few(entries)} and neither, so it is left as it is: choose another --out"
        )
    if foreign := [name for name in entries if not _written_by_datagen(name)]:
        raise OutDirError(
            f"{out_dir}: --overwrite would delete {len(foreign)} files datagen did not write: "
            f"{_first_few(foreign)}; nothing was deleted: move them out of it (or delete them) "
            "and run the command again"
        )
    return "overwrite"


def check_build_state(out_dir: Path, config: BuildConfig) -> None:
    """Raises OutDirError unless ``out_dir``'s build state lets a build of ``config`` resume:
    readable, of that config, with its build id and secret."""
    state = _read_json(out_dir / BUILD_STATE)
    if state is None:
        raise OutDirError(
            f"{out_dir}: nothing to resume (no {BUILD_STATE}); start it without --resume"
        )
    started = state.get("config")
    if isinstance(started, dict) and started.get("version") == 1:  # started by an older datagen
        started = as_current_version(started, str(out_dir / BUILD_STATE))
    if isinstance(started, dict):
        started = _as_read_now(started, str(out_dir / BUILD_STATE))
    if started != config.to_dict():
        previous = started if isinstance(started, dict) else {}
        differing = sorted(k for k, v in config.to_dict().items() if previous.get(k) != v)
        raise OutDirError(
            f"{out_dir} was started with another config (differs in: {', '.join(differing)}); "
            "resume with the same config, seed and sample count"
        )
    try:
        parse_secret(state["secret"])
        if not isinstance(state["build_id"], str):
            raise ValueError("build_id is not a string")
    except (KeyError, TypeError, ValueError) as exc:
        raise OutDirError(f"{out_dir / BUILD_STATE}: unreadable build state ({exc})") from None


def _as_read_now(recorded: dict[str, Any], source: str) -> dict[str, Any]:
    """A build's recorded config (build state or manifest) as this datagen reads it: a key added
    since takes its default, so a build made before the key existed is still this build (kept
    when finished, resumed when not) while the key keeps its default."""
    try:
        return config_from_dict(recorded, source).to_dict()
    except ConfigError:  # compared as it is, and found different
        return recorded


def finished_build_problems(out_dir: Path, config: BuildConfig, resume: bool) -> list[str]:
    """What differs from its manifest in the finished build of ``config`` in ``out_dir`` (its
    shards read whole: ``finished_build``); raises OutDirError, naming it and what to run,
    unless ``resume`` and a resume can make it again there."""
    problems = finished_build.differences(out_dir, config)
    if problems:
        _check_remake(out_dir, config, problems, resume)
    return problems


def _check_remake(out_dir: Path, config: BuildConfig, problems: list[str], resume: bool) -> None:
    found = finished_build.described(out_dir, problems)
    if not finished_build.remakeable(problems):
        raise OutDirError(f"{found}; build it anew with --overwrite, or into another --out")
    if not resume:
        raise OutDirError(
            f"{found}; pass --resume to make what differs again (from each sample's seed and "
            "index), or --overwrite to build it all anew"
        )
    try:
        check_build_state(out_dir, config)
    except OutDirError:
        raise OutDirError(
            f"{found}; its {BUILD_STATE} (the build's id and secret) is missing or not this "
            "build's, so nothing can be made again in place: build it anew with --overwrite, "
            "or into another --out"
        ) from None


def _written_by_datagen(name: str) -> bool:
    exports = [fmt.path for fmt in EXPORTS.values()]
    temporary = (f".{path}.{end}" for path in exports for end in ("partial", "old"))
    patterns = (*DATAGEN_FILES, *exports, *temporary)
    return any(fnmatch.fnmatchcase(name, pattern) for pattern in patterns)


def _first_few(names: list[str]) -> str:
    more = f" and {len(names) - SHOWN} more" if names[SHOWN:] else ""
    return ", ".join(names[:SHOWN]) + more


def _is_datagen_output(manifest: dict[str, Any] | None, state: dict[str, Any] | None) -> bool:
    """A directory a build made: its build state (id, secret, config) or a datagen manifest."""
    if isinstance(state, dict) and {"build_id", "secret", "config"} <= state.keys():
        return True
    return isinstance(manifest, dict) and manifest.get("dataset_format") == DATASET_FORMAT


_WRITER_FILE = re.compile(r"^\.writer-[A-Za-z0-9_-]{1,32}\.(lock|journal)$")


def _only_waiting_writers(out_dir: Path, entries: list[str]) -> bool:
    """Writers started before the build (``datagen writer``) hold a lock and an empty journal
    in the directory and have written nothing yet: it is still a fresh one."""
    return all(
        (match := _WRITER_FILE.match(name))
        and (match[1] == "lock" or (out_dir / name).stat().st_size == 0)
        for name in entries
    )


def _entries(out_dir: Path) -> list[str]:
    try:
        return sorted(p.name for p in out_dir.iterdir()) if out_dir.is_dir() else []
    except OSError as exc:
        raise OutDirError(f"{out_dir}: cannot list it: {exc.strerror}") from None


def _check_writable(out_dir: Path) -> None:
    """``out_dir`` is a directory, or can be made one, and a file can be created in it: checked
    by creating (and deleting) one, as permission bits do not stop root but a read-only file
    system does."""
    try:
        if out_dir.exists() and not out_dir.is_dir():
            raise OutDirError(
                f"{out_dir}: exists and is not a directory; --out names the dataset's directory"
            )
        nearest = next(p for p in (out_dir.absolute(), *out_dir.absolute().parents) if p.exists())
        if not nearest.is_dir():
            raise OutDirError(f"{out_dir}: cannot be created: {nearest} is not a directory")
        try:
            fd, probe = tempfile.mkstemp(dir=nearest, prefix=".datagen-write-test-")
        except OSError as exc:
            raise OutDirError(
                f"{out_dir}: cannot create files in {nearest}: {exc.strerror or exc}"
            ) from None
        os.close(fd)
        os.unlink(probe)
        if not os.access(nearest, os.W_OK | os.X_OK):  # for the real user id as well
            raise OutDirError(f"{out_dir}: cannot create files in {nearest}: permission denied")
    except OutDirError:
        raise
    except OSError as exc:
        raise OutDirError(f"{out_dir}: {exc.strerror or exc} ({exc.filename or out_dir})") from None
    except ValueError as exc:  # a NUL character in the path
        raise OutDirError(f"{out_dir!r}: not a usable path: {exc}") from None


def _clear(out_dir: Path) -> None:
    """Deletes what is in ``out_dir`` (a datagen output), keeping the directory itself."""
    for entry in out_dir.iterdir():
        if entry.is_dir() and not entry.is_symlink():
            shutil.rmtree(entry)
        else:
            entry.unlink()


def now_utc() -> str:
    return datetime.now(UTC).isoformat(timespec="seconds")
