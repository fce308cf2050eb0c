"""Commands printed in docs/testing.md, run exactly as printed; and every block the docs tag
``<!-- test: TAG -->`` is one a test runs (README's snippets, docs/deployment.md's ACL
commands: tests/adversarial/test_acl.py)."""

from __future__ import annotations

import os
import re
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
# Set for the command's own pytest: it must not run this test again (pytest inside pytest).
GUARD = "DATAGEN_DOCS_COMMAND_RUNNING"


def printed_command(tag: str) -> str:
    """The one-line command in the ```bash block right after ``<!-- tag -->`` in the doc."""
    doc = (REPO / "docs" / "testing.md").read_text()
    found = re.search(rf"<!-- {re.escape(tag)} -->\n```bash\n([^\n]+)\n```", doc)
    assert found, f"docs/testing.md has no command block tagged <!-- {tag} -->"
    return found[1]


@pytest.mark.slow
@pytest.mark.skipif(os.environ.get(GUARD) == "1", reason="inside the printed command's own run")
def test_the_printed_pure_selection_runs_and_passes():
    command = printed_command("pure-selection")
    assert '-m "not sim and not mqtt and not ray and not slow"' in command
    result = subprocess.run(
        ["bash", "-c", command],
        cwd=REPO,
        env=os.environ | {GUARD: "1"},
        capture_output=True,
        text=True,
        timeout=600,
    )
    output = result.stdout + result.stderr
    assert result.returncode == 0, output[-4000:]
    assert re.search(r"\d+ passed", output) and re.search(r"\d+ deselected", output), output[-4000:]


def test_every_block_tagged_for_a_test_is_run_by_one():
    tests = "".join(p.read_text() for p in (REPO / "tests").rglob("*.py"))
    for doc in [REPO / "README.md", *sorted((REPO / "docs").glob("*.md"))]:
        for tag in re.findall(r"<!-- test: ([\w-]+) -->", doc.read_text()):
            assert f'"{tag}"' in tests, f"{doc.name}: no test runs the block tagged {tag!r}"
