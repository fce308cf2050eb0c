"""Errors that reach a user: each message names the file or key and what was expected."""

from __future__ import annotations


class UserInputError(ValueError):
    """The user's input (a config, an option, a path) is wrong; the message says where and why.
    The CLI prints it on one line and exits with status 2, before anything starts."""


class ConfigError(UserInputError):
    """A user's configuration is wrong; the message says where and why."""


class OutDirError(UserInputError):
    """The output directory cannot be used as asked; the message says what was found there."""


class BuildError(RuntimeError):
    """The build cannot finish; the message says what is missing and why."""
