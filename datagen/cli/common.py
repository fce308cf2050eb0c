"""What every command shares: argument types and exit codes (a datagen error's own: its
``exit_status``, ``datagen.errors``)."""

from __future__ import annotations

import argparse
import os

EXIT_INTERRUPTED = 130


def positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a number >= 1, got {value}")
    return value


def seed(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
    if not 0 <= value < 2**63:
        raise argparse.ArgumentTypeError(f"expected a seed in [0, 2^63), got {value}")
    return value


MAX_WORKERS = 1024  # worker processes or Ray actors of one build


def whole_number(lo: int, hi: int):
    """argparse type: a whole number in decimal digits, ``lo`` <= n <= ``hi``; '1e3', '2.0' or
    '-1' are errors, and a number is never larger than ``hi`` (nothing is allocated for it)."""

    def parse(text: str) -> int:
        digits = text.strip()
        if not (digits.isascii() and digits.isdigit()) or len(digits) > 30:
            shown = text if len(text) <= 40 else text[:40] + "..."
            raise argparse.ArgumentTypeError(
                f"expected a whole number from {lo} to {hi}, got {shown!r}"
            )
        value = int(digits)
        if not lo <= value <= hi:
            raise argparse.ArgumentTypeError(
                f"expected a whole number from {lo} to {hi}, got {value}"
            )
        return value

    return parse


def broker_url(text: str) -> str:
    """argparse type: an ``mqtt://`` or ``mqtts://`` URL; the error shows it without password."""
    from datagen.transport.broker_url import parse_broker_url, redact

    try:
        parse_broker_url(text)
    except ValueError as exc:
        message = str(exc).replace(repr(text), repr(redact(text)))
        raise argparse.ArgumentTypeError(message) from None
    return text


def build_id(text: str) -> str:
    from datagen.transport.topics import valid_build_id

    if not valid_build_id(text):
        raise argparse.ArgumentTypeError(f"expected 1-64 of [A-Za-z0-9_.-], got {text[:80]!r}")
    return text


def writer_ids(text: str) -> str:
    """argparse type: comma-separated distinct writer ids (the text, checked)."""
    from datagen.shards import valid_writer_id

    ids = [w.strip() for w in text.split(",") if w.strip()]
    bad = [w for w in ids if not valid_writer_id(w)]
    if not ids or bad or len(set(ids)) != len(ids):
        raise argparse.ArgumentTypeError(
            f"expected comma-separated distinct ids of 1-32 of [A-Za-z0-9_-], got {text[:80]!r}"
        )
    return text


def readable_file(text: str) -> str:
    """argparse type: a regular file that can be opened for reading."""
    try:
        if not os.path.isfile(text):
            raise argparse.ArgumentTypeError(f"no such file: {text[:200]!r}")
        with open(text, "rb"):
            pass
    except (OSError, ValueError) as exc:
        reason = getattr(exc, "strerror", None) or exc
        raise argparse.ArgumentTypeError(f"cannot read {text[:200]!r}: {reason}") from None
    return text


def one_line(text: str) -> str:
    """``text`` with control characters (from a user's path or file: newlines, carriage returns,
    terminal escapes) shown escaped, so that an error message stays one harmless line."""
    return "".join(
        c if c.isprintable() or c == " " else c.encode("unicode_escape").decode("ascii")
        for c in text
    )
