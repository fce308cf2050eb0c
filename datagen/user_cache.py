"""Where datagen keeps what it computes or copies once per machine: ``$XDG_CACHE_HOME/datagen``,
else ``~/.cache/datagen`` (never the repository, never a dataset)."""

from __future__ import annotations

import os
from pathlib import Path


def user_cache(name: str) -> Path:
    """The cache folder ``name`` (``robots``, ``render``, ...); not created here."""
    root = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(root) / "datagen" / name
