"""Every snippet runs alone (issue 23): each ```python and ```bash block of README.md and
docs/**/*.md is run here as printed, on its own, or carries a marker saying why not.

A marker is a one-line HTML comment in the run of comment lines just above the block
(docs/testing.md, 'Snippets'):

- ``<!-- snippet: needs dataset PATH [PATH ...] -->``: run, with a small real dataset at each PATH
  (built once per session through the CLI; each block gets its own copy);
- ``<!-- test: TAG -->`` or ``<!-- snippet: tested by tests/FILE.py -->``: another test runs it
  as printed;
- ``<!-- snippet: same as DOC -->``: every line of it is printed in a block of DOC, which is run
  or marked there;
- ``<!-- snippet: excerpt of FILE -->``: an abridged quote of a file that tests run;
- ``<!-- snippet: runs elsewhere: REASON -->`` (a second machine, a cluster, a public broker) and
  ``<!-- snippet: too long: REASON -->`` (hours of building, the whole suite): not run.

A block with no marker is run: python with this venv's python in a fresh process, bash with
``bash -euo pipefail``; both in a temporary working directory holding ``.venv`` and ``configs/``
(links to the repository's), with the venv's bin first on PATH."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import textwrap
from dataclasses import dataclass
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
DOCS = [REPO / "README.md", *sorted((REPO / "docs").rglob("*.md"))]
LANGUAGES = {"python", "bash"}
# Fences a reader would take for code to run: label them python or bash so they are checked.
RUNNABLE_LOOKING = {"py", "python3", "sh", "shell", "console", "zsh", "pycon"}
FENCE = re.compile(r"^(\s*)```(\w*)\s*$")
COMMENT = re.compile(r"^\s*<!--\s*(.*?)\s*-->\s*$")
NOT_RUN = ("tested by ", "same as ", "excerpt of ", "runs elsewhere: ", "too long: ")
# The small real datasets a block may name, and the build that makes each.
GRASP, CAMPAIGN, NAV, AERIAL = "grasp", "campaign", "nav", "aerial"
DATASETS = {
    "datasets/grasp_tabletop": GRASP, "datasets/mine": GRASP, "datasets/grasps": CAMPAIGN,
    "datasets/nav_rooms": NAV, "datasets/aerial_corridor": AERIAL,
}  # fmt: skip


@dataclass(frozen=True)
class Block:
    doc: Path
    line: int  # of the opening fence, 1-based
    language: str
    code: str
    markers: tuple[str, ...]  # the comment lines just above, innermost last

    @property
    def name(self) -> str:
        return f"{self.doc.relative_to(REPO)}:{self.line}"

    @property
    def snippet(self) -> str | None:
        found = [
            m.removeprefix("snippet:").strip() for m in self.markers if m.startswith("snippet:")
        ]
        assert len(found) <= 1, f"{self.name}: more than one snippet marker"
        return found[0] if found else None

    @property
    def tagged(self) -> bool:
        return any(re.fullmatch(r"test: [\w-]+", m) for m in self.markers)

    @property
    def datasets(self) -> list[str]:
        snippet = self.snippet or ""
        return (
            snippet.removeprefix("needs dataset ").split()
            if snippet.startswith("needs dataset ")
            else []
        )

    @property
    def runs_here(self) -> bool:
        return not self.tagged and not (self.snippet or "").startswith(NOT_RUN)


def blocks(doc: Path) -> list[Block]:
    lines = doc.read_text().splitlines()
    found, i = [], 0
    while i < len(lines):
        opening = FENCE.match(lines[i])
        if not opening:
            i += 1
            continue
        end = next(j for j in range(i + 1, len(lines)) if re.match(r"^\s*```\s*$", lines[j]))
        markers, k = [], i - 1
        while k >= 0 and COMMENT.match(lines[k]):
            markers.insert(0, COMMENT.match(lines[k])[1])
            k -= 1
        code = textwrap.dedent("\n".join(lines[i + 1 : end])) + "\n"
        found.append(Block(doc, i + 1, opening[2], code, tuple(markers)))
        i = end + 1
    return found


ALL = [b for doc in DOCS for b in blocks(doc)]
CODE = [b for b in ALL if b.language in LANGUAGES]
RUN = [b for b in CODE if b.runs_here]


def test_every_code_block_is_run_here_or_says_why():
    """A new block without a marker is run (below); a marker must be one this file understands and
    what it points to must exist."""
    assert len(CODE) > 30, "the parser found too few blocks"
    for b in ALL:
        assert b.language not in RUNNABLE_LOOKING, f"{b.name}: label the block python or bash"
    for b in CODE:
        snippet = b.snippet
        if snippet is None:
            continue
        if snippet.startswith("needs dataset "):
            for path in b.datasets:
                assert path in DATASETS, (
                    f"{b.name}: no dataset {path!r} here; known: {list(DATASETS)}"
                )
                assert path in b.code, f"{b.name}: the block does not use {path}"
        elif snippet.startswith("tested by "):
            test = REPO / snippet.removeprefix("tested by ")
            assert test.is_file(), f"{b.name}: no test file {test}"
            assert b.doc.name in test.read_text(), f"{test.name} does not read {b.doc.name}"
        elif snippet.startswith("same as "):
            other = REPO / "docs" / snippet.removeprefix("same as ").removeprefix("docs/")
            assert other.is_file(), f"{b.name}: no doc {other}"
            mine = {line.strip() for line in b.code.splitlines() if line.strip()}
            assert any(
                mine <= {line.strip() for line in o.code.splitlines()} for o in blocks(other)
            ), f"{b.name}: not every line of it is in one block of {other.name}"
        elif snippet.startswith("excerpt of "):
            source = REPO / snippet.removeprefix("excerpt of ")
            assert source.is_file(), f"{b.name}: no file {source}"
        elif snippet.startswith(("runs elsewhere: ", "too long: ")):
            assert len(snippet.split(": ", 1)[1]) > 10, f"{b.name}: give the reason"
        else:
            pytest.fail(f"{b.name}: unknown marker <!-- snippet: {snippet} -->")


def _build(out: Path, *command: str) -> None:
    result = subprocess.run(
        [str(Path(sys.executable).parent / "datagen"), *command],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert result.returncode == 0, (
        f"preparing {out}: {result.stdout[-2000:]}{result.stderr[-3000:]}"
    )


@pytest.fixture(scope="session")
def doc_datasets(tmp_path_factory, request):
    """The datasets blocks name, copied once per session (and only when one is needed) from the
    session's datasets (tests/conftest.py): grasp frames with every frame export made, a filmed
    grasp campaign with the episode exports, navigation episodes with the hdf5 export, aerial
    episodes as built."""
    root = tmp_path_factory.mktemp("doc-datasets")
    sources = {GRASP: "frames_dataset", CAMPAIGN: "campaign_dataset", NAV: "navigation_dataset",
               AERIAL: "aerial_dataset"}  # fmt: skip
    exports = {
        GRASP: "coco,hdf5,pointcloud,usd,yolo,bop",
        CAMPAIGN: "lerobot,robomimic",
        NAV: "hdf5",
        AERIAL: "",
    }
    made: dict[str, Path] = {}

    def get(kind: str) -> Path:
        if kind not in made:
            out = root / kind
            shutil.copytree(request.getfixturevalue(sources[kind]), out, symlinks=True)
            if exports[kind]:
                _build(out, "export", str(out), "--to", exports[kind])
            made[kind] = out
        return made[kind]

    return get


def _marks(b: Block) -> list:
    builds = b.datasets or re.search(r"\bdatagen (build|campaign|preview|inspect)\b", b.code)
    return [pytest.mark.sim, pytest.mark.mqtt, pytest.mark.slow] if builds else []


@pytest.mark.parametrize("block", [pytest.param(b, id=b.name, marks=_marks(b)) for b in RUN])
def test_the_block_runs_alone_as_printed(block: Block, tmp_path, request):
    (tmp_path / ".venv").symlink_to(REPO / ".venv")
    (tmp_path / "configs").symlink_to(REPO / "configs")
    if block.datasets:
        get = request.getfixturevalue("doc_datasets")
        for path in block.datasets:
            shutil.copytree(get(DATASETS[path]), tmp_path / path, symlinks=True)
    venv_bin = Path(sys.executable).parent
    env = {k: v for k, v in os.environ.items() if k not in ("VIRTUAL_ENV", "PYTHONPATH")}
    env["PATH"] = f"{venv_bin}{os.pathsep}{env.get('PATH', '')}"
    if block.language == "python":
        (tmp_path / "snippet.py").write_text(block.code)
        command = [str(venv_bin / "python"), "snippet.py"]
    else:
        (tmp_path / "snippet.sh").write_text(block.code)
        command = ["bash", "-euo", "pipefail", "snippet.sh"]
    result = subprocess.run(
        command, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600
    )
    assert result.returncode == 0, (
        f"{block.name} failed when run alone (exit {result.returncode}):\n{block.code}\n"
        f"--- stdout\n{result.stdout[-3000:]}\n--- stderr\n{result.stderr[-4000:]}"
    )
