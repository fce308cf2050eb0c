"""Errors that reach a user: each message names the file or key and what was expected."""

from __future__ import annotations

import errno
import os
from typing import TypeGuard


class DatagenError(Exception):
    """Every error datagen reports to its user, the one class the CLI catches: the message says
    what went wrong, naming the file, key or what is missing; ``exit_status`` is the CLI's."""

    exit_status = 1


class UserInputError(DatagenError, ValueError):
    """The user's input (a config, an option, a path) is wrong; the message says where and why.
    The CLI prints it on one line and exits with status 2, before anything starts."""

    exit_status = 2


class ConfigError(UserInputError):
    """A user's configuration is wrong; the message says where and why."""


class OutDirError(UserInputError):
    """The output directory cannot be used as asked; the message says what was found there."""


class DatasetError(DatagenError, ValueError):
    """The directory is not a (valid) datagen dataset; the text says why, naming the file."""


class BuildError(DatagenError, RuntimeError):
    """The build cannot finish; the message says what is missing and why."""


def is_disk_full(exc: BaseException) -> TypeGuard[OSError]:
    """An OSError of a full file system or an exhausted quota (ENOSPC, EDQUOT)."""
    return isinstance(exc, OSError) and exc.errno in (errno.ENOSPC, errno.EDQUOT)


def disk_full_message(exc: OSError, where: str | os.PathLike) -> str:
    """One line: ``disk full: PATH (No space left on device)``; PATH is the file when the error
    names one, else ``where``."""
    return f"disk full: {exc.filename or where} ({exc.strerror or exc})"
