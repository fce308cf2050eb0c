"""benchmarks/schedule_memory.py run as docs/scale-out.md prints it: a line per size and kind
of build, with what the schedule holds."""

from __future__ import annotations

import re
from pathlib import Path

from printed_commands import run_printed  # tests/printed_commands.py

REPO = Path(__file__).resolve().parents[2]
DOC = REPO / "docs" / "scale-out.md"


def test_the_schedule_memory_benchmark_prints_what_each_schedule_holds():
    done = run_printed(DOC, "schedule_memory.py", timeout=300)
    assert done.returncode == 0, done.stderr[-3000:]
    lines = re.findall(
        r"([\d,]+) samples, (fresh|half durable)\s*: holds\s+([\d.]+) MB", done.stdout
    )
    assert [(size, kind) for size, kind, _ in lines] == [
        ("100,000", "fresh"),
        ("100,000", "half durable"),
        ("1,000,000", "fresh"),
        ("1,000,000", "half durable"),
    ], done.stdout
