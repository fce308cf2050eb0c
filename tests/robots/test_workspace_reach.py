"""The workspace scales of the small arms: docs/robots.md's commands, run as printed from the
repository, print the reach figures the page gives beside them."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
pytestmark = [pytest.mark.sim, pytest.mark.slow]


def printed_commands() -> list[tuple[str, str]]:
    """(command, the figure in its comment) of the block marked as tested here."""
    page = (REPO / "docs" / "robots.md").read_text()
    marker = "<!-- snippet: tested by tests/robots/test_workspace_reach.py -->"
    block = page.split(marker, 1)[1].split("```bash\n", 1)[1].split("```", 1)[0]
    lines = [line.strip() for line in block.strip().splitlines()]
    return [tuple(part.strip() for part in line.split("#", 1)) for line in lines]


@pytest.mark.parametrize(("command", "figure"), printed_commands())
def test_the_printed_scale_reaches_what_the_page_says(command, figure):
    argv = command.split()
    assert argv[:2] == [".venv/bin/python", "scripts/workspace_reach.py"]
    done = subprocess.run(
        [sys.executable, *argv[1:]], cwd=REPO, capture_output=True, text=True, timeout=600
    )
    assert done.returncode == 0, done.stderr[-2000:]
    reached = re.search(r"(\d+/\d+) top-down poses reached", done.stdout)
    assert reached and reached[1] == figure.split()[0], done.stdout
