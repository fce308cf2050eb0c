"""Commands printed in docs/testing.md, run exactly as printed; every block the docs tag
``<!-- test: TAG -->`` is one a test runs (README's snippets, docs/deployment.md's ACL
commands: tests/adversarial/test_acl.py); the README is a front page of at most 250 lines; and
the documentation site (mkdocs.yml, docs/) builds with ``--strict``, its configuration
reference generated from the config schema with every key."""

from __future__ import annotations

import itertools
import re
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
HOOK = REPO / "docs" / "hooks" / "config_reference.py"
MKDOCS = Path(sys.executable).parent / "mkdocs"


def printed_command(tag: str) -> str:
    """The one-line command in the ```bash block right after ``<!-- tag -->`` in the doc."""
    doc = (REPO / "docs" / "testing.md").read_text()
    found = re.search(rf"<!-- {re.escape(tag)} -->\n```bash\n([^\n]+)\n```", doc)
    assert found, f"docs/testing.md has no command block tagged <!-- {tag} -->"
    return found[1]


def _selection(command: str) -> str:
    found = re.search(r'-m "([^"]+)"', command)
    assert found, command
    return found[1]


def test_the_test_command_runs_the_printed_pure_selection_and_then_all_it_leaves_out():
    """scripts/test.sh (the README's test command, .ci/run) runs the quick loop exactly as
    printed, then the complementary selection: together every test, each once."""
    printed = printed_command("pure-selection")
    assert '-m "not sim and not mqtt and not ray and not slow"' in printed
    lines = [line.strip() for line in (REPO / "scripts" / "test.sh").read_text().splitlines()]
    assert printed in lines, "scripts/test.sh does not run the printed pure selection as printed"
    rest = next((line for line in lines[lines.index(printed) + 1 :] if "-m " in line), None)
    assert rest and rest.startswith("exec .venv/bin/pytest -n 2 -m "), rest
    # marker expressions are Python's boolean syntax: every marker combination is selected by
    # exactly one of the two
    first, second = (compile(_selection(c), "-m", "eval") for c in (printed, rest))
    markers = sorted(set(first.co_names) | set(second.co_names))
    assert markers == ["mqtt", "ray", "sim", "slow"], markers
    for values in itertools.product((False, True), repeat=len(markers)):
        names = dict(zip(markers, values, strict=True))
        assert eval(first, {}, names) != eval(second, {}, names), names


def test_every_block_tagged_for_a_test_is_run_by_one():
    tests = "".join(p.read_text() for p in (REPO / "tests").rglob("*.py"))
    for doc in [REPO / "README.md", *sorted((REPO / "docs").glob("*.md"))]:
        for tag in re.findall(r"<!-- test: ([\w-]+) -->", doc.read_text()):
            assert f'"{tag}"' in tests, f"{doc.name}: no test runs the block tagged {tag!r}"


def test_the_readme_is_a_front_page_of_at_most_250_lines():
    lines = (REPO / "README.md").read_text().splitlines()
    assert len(lines) <= 250, f"README.md has {len(lines)} lines; move sections into docs/"


def test_the_generated_configuration_reference_has_every_config_key():
    """docs/hooks/config_reference.py (an MkDocs hook) renders the reference from the schema:
    every key of ``BuildConfig``, its default and range, so the page cannot drift."""
    import dataclasses
    import importlib.util
    import typing

    from datagen.config import BuildConfig

    spec = importlib.util.spec_from_file_location("config_reference", HOOK)
    hook = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(hook)
    page = hook.render()

    def keys(cls, prefix=""):
        hints = typing.get_type_hints(cls)
        for f in dataclasses.fields(cls):
            if dataclasses.is_dataclass(hints[f.name]):
                yield from keys(hints[f.name], f"{prefix}{f.name}.")
            else:
                yield f"{prefix}{f.name}", f

    for key, f in keys(BuildConfig):
        row = next((line for line in page.splitlines() if line.startswith(f"| `{key}` |")), None)
        assert row, f"the generated reference has no row for {key}"
        if "min" in f.metadata:
            assert f"{hook._number(f.metadata['min'])} .. {hook._number(f.metadata['max'])}" in row
    assert hook.MARKER in (REPO / "docs" / "configuration.md").read_text()
    assert "docs/hooks/config_reference.py" in (REPO / "mkdocs.yml").read_text()


@pytest.mark.skipif(not MKDOCS.exists(), reason="mkdocs (the dev extras, scripts/install.sh)")
def test_the_site_builds_strictly_outside_the_tree(tmp_path):
    """What scripts/test.sh runs: a broken link, a missing page or a page outside the nav fails."""
    result = subprocess.run(
        [str(MKDOCS), "build", "--strict", "--quiet", "-d", str(tmp_path / "site")],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 0, result.stdout + result.stderr
    config_page = (tmp_path / "site" / "configuration" / "index.html").read_text()
    assert (
        "objects.max_mesh_faces" in config_page and "<!-- config-reference -->" not in config_page
    )
    assert not (REPO / "site").exists()
