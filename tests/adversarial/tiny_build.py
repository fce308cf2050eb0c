"""The smallest real build the build-operation attacks run (test_resume_integrity,
test_build_operations): 3 grasp_tabletop samples at 64x48, one worker, no preview, about 10 s on
the 2-core CI machine."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import yaml

from datagen.writer.journal import journal_path

REPO = Path(__file__).resolve().parents[2]
N = 3
TINY = {"version": 1, "scene": "grasp_tabletop", "num_samples": N, "seed": 5}
TINY["render"] = {"width": 64, "height": 48, "wrist_camera": False}
TINY["objects"], TINY["physics"] = {"count": [1, 2]}, {"settle_time": 0.3}


def tiny_config(tmp_path: Path) -> Path:
    path = tmp_path / "tiny.yaml"
    path.write_text(yaml.safe_dump(TINY))
    return path


def build_command(config: Path, out: Path, *more: str, workers: int = 1) -> list[str]:
    """``datagen build CONFIG --out OUT --workers W --no-preview MORE...`` by this Python."""
    command = [sys.executable, "-m", "datagen.cli", "build", str(config), "--out", str(out)]
    return [*command, "--workers", str(workers), "--no-preview", *more]


def journalled_samples(out: Path) -> int:
    """Samples the local writer's journal says are durable (in its last line)."""
    try:
        lines = journal_path(out, "0").read_text().splitlines()
        return json.loads(lines[-1])["samples"] if lines else 0
    except (OSError, ValueError, KeyError):
        return 0  # not there yet, or a line being written
