"""Errors that reach a user: each message names the file or key and what was expected."""

from __future__ import annotations


class ConfigError(ValueError):
    """A user's configuration is wrong; the message says where and why."""


class BuildError(RuntimeError):
    """The build cannot finish; the message says what is missing and why."""
