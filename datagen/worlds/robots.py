"""Robot descriptions shipped inside the mani-skill package (no download needed)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

PANDA = "robots/panda/panda_v2.urdf"
FETCH = "robots/fetch/fetch.urdf"


def maniskill_asset(relative: str) -> Path:
    """``mani_skill/assets/<relative>``; a clear error if mani-skill is missing."""
    spec = importlib.util.find_spec("mani_skill")
    if spec is None or not spec.submodule_search_locations:
        raise RuntimeError(f"mani-skill is not installed: it provides {relative}")
    return Path(spec.submodule_search_locations[0]) / "assets" / relative
