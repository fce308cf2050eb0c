"""The command lines a doc prints, found and run as printed (tests of benchmarks' quick modes)."""

from __future__ import annotations

import subprocess
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def printed_line(doc: Path, ending: str) -> str:
    """The first line of ``doc`` that ends with ``ending``: a command as the doc prints it."""
    return next(line for line in doc.read_text().splitlines() if line.endswith(ending))


def run_printed(doc: Path, ending: str, timeout: float) -> subprocess.CompletedProcess[str]:
    """That command run by bash in the repository, as a reader would paste it."""
    return subprocess.run(
        ["bash", "-c", printed_line(doc, ending)],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=timeout,
        check=False,
    )
