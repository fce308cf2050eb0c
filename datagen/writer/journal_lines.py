"""Reading a writer's journal (``datagen.writer.journal``) as input from disk: bounded, and every
bad line named by file and line number.

A line that is not JSON at all is what a crash or a full disk leaves when it cuts an append
short: that append's fsync never returned, so no sample of it was acknowledged, and the line
is skipped (with a warning). Any other bad line (JSON nested too deep, too large, a lone
surrogate, an object that is not a journal entry) is not something a crash makes: skipping it
could cut a shard back past samples already acknowledged, so reading one's own journal stops
there with a ``JournalError`` and nothing is repaired. Reading another writer's journal (to
count the keys it holds) skips such a line instead: counting fewer keys is the safe side there.
"""

from __future__ import annotations

import logging
import os
import stat
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from datagen.safe_json import JsonInputError, JsonSyntaxError, loads_bounded

log = logging.getLogger(__name__)
# one line lists at most the digests of one shard's samples (~90 bytes a sample)
MAX_LINE_BYTES = 16 * 2**20
_CHUNK = 2**20
_NOT_A_CRASH = "; a crash leaves no such line, so the writer repairs nothing until it is fixed"


class JournalError(ValueError):
    """A journal line no crash leaves, or a journal that is not a regular file; the text names
    the file, the line and what was expected."""


def journal_entries(path: Path, strict: bool = True) -> Iterator[dict[str, Any]]:
    """The entries of journal ``path`` in file order (none if there is no journal). ``strict``:
    a bad line other than a cut-short append raises ``JournalError``; else it is skipped."""
    try:
        # no symlink followed, never blocked by a FIFO: only a regular file is a journal
        fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK)
    except FileNotFoundError:
        return
    except OSError as exc:
        yield from _refuse(f"journal {path}: cannot be read ({exc.strerror})", strict)
        return
    with os.fdopen(fd, "rb") as f:
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            yield from _refuse(f"journal {path}: not a regular file", strict)
            return
        number = 0
        while line := f.readline(MAX_LINE_BYTES + 1):
            number += 1
            what = f"journal {path} line {number}"
            if len(line) > MAX_LINE_BYTES and not line.endswith(b"\n"):
                _skip_to_next_line(f)
                yield from _refuse(f"{what}: longer than {MAX_LINE_BYTES} bytes", strict)
            elif line.strip():
                yield from _parsed(line, what, strict)


def _parsed(line: bytes, what: str, strict: bool) -> Iterator[dict[str, Any]]:
    try:
        yield parse_entry(loads_bounded(line, what=what, max_bytes=MAX_LINE_BYTES), what)
    except JsonSyntaxError as exc:
        log.warning("%s; skipped: an append that a crash or a full disk cut short", exc)
    except (JsonInputError, JournalError) as exc:
        yield from _refuse(str(exc), strict)


def check_within_shards(journal: dict[str, dict], shards: list[Path], path: Path) -> None:
    """``JournalError`` if an unfinished shard's last journalled durable offset lies past its
    end: a shard is fsynced before its line is written, so no crash leaves that, and cutting it
    back to that offset would extend it instead (a line saying 2**40 bytes: a 1 TiB file)."""
    for shard in shards:
        entry = journal.get(shard.name)
        if entry is not None and not entry["closed"] and entry["offset"] > shard.stat().st_size:
            raise JournalError(
                f"journal {path}: {shard.name} durable up to byte {entry['offset']}, but it "
                f"holds {shard.stat().st_size} bytes{_NOT_A_CRASH}"
            )


def _refuse(problem: str, strict: bool) -> Iterator[dict[str, Any]]:
    if strict:
        raise JournalError(problem + _NOT_A_CRASH)
    log.warning("%s; skipped", problem)
    yield from ()


def parse_entry(value: Any, what: str) -> dict[str, Any]:
    """``value`` if it is a journal entry (``journal_entry``), else ``JournalError``."""
    expected = (
        "expected an object with 'shard' (a name), 'offset' and 'samples' (counts >= 0), "
        "'closed' (true or false) and 'sample_sha256' (names to digests, if present)"
    )
    if not isinstance(value, dict):
        raise JournalError(f"{what}: a JSON {type(value).__name__}; {expected}")
    digests = value.get("sample_sha256", {})
    valid = (
        isinstance(value.get("shard"), str)
        and _is_count(value.get("offset"))
        and _is_count(value.get("samples"))
        and isinstance(value.get("closed"), bool)
        and isinstance(digests, dict)
        and all(isinstance(d, str) for d in digests.values())
    )
    if not valid:
        raise JournalError(f"{what}: {expected}")
    return value


def _is_count(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool) and value >= 0


def _skip_to_next_line(f) -> None:
    while chunk := f.readline(_CHUNK):
        if chunk.endswith(b"\n"):
            return
