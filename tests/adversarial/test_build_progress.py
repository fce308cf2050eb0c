"""The progress a build prints counts durable samples only (issue 38, low 14): a sample that
failed on every attempt is no longer waited for, but it is not durable either. Before, a build
whose only sample failed printed ``1/1 durable`` and then ``build failed``.

Real builds of the ``example_blocks`` plug-in family (tests/plugins) with a fault injected in
some samples, by the real CLI in a subprocess; every progress update printed
(``$DATAGEN_PROGRESS_INTERVAL_S=0``)."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from datagen.cli.progress import INTERVAL_ENV
from datagen.shards import read_keys

pytestmark = [pytest.mark.adversarial]
REPO = Path(__file__).resolve().parents[2]
PROGRESS = re.compile(r"datagen: (\d+)/(\d+) durable")


def failing_build(tmp_path: Path, samples: int, failing: str) -> subprocess.CompletedProcess:
    """A build of ``samples`` samples, the samples listed in ``failing`` (``EXAMPLE_BLOCKS_FAIL``
    form) failing at every attempt; one attempt each."""
    config = tmp_path / "blocks.yaml"
    config.write_text(
        f"scene: example_blocks\nnum_samples: {samples}\nseed: 7\n"
        "render: {width: 32, height: 32, wrist_camera: false}\nbuild: {on_sample_error: retry, retries: 0}\n"
    )
    plugins = os.pathsep.join(filter(None, [str(REPO / "tests" / "plugins"), os.environ.get("PYTHONPATH")]))  # fmt: skip
    env = os.environ | {"PYTHONPATH": plugins, "EXAMPLE_BLOCKS_FAIL": failing, INTERVAL_ENV: "0"}
    return subprocess.run(
        [sys.executable, "-m", "datagen.cli", "build", str(config), "--out", str(tmp_path / "out"), "--workers", "1", "--no-preview"],
        capture_output=True, text=True, cwd=REPO, timeout=300, env=env,
    )  # fmt: skip


def durable_in_shards(out: Path) -> int:
    return sum(len(read_keys(shard)) for shard in out.glob("shard-*.tar"))


@pytest.mark.sim
@pytest.mark.mqtt
@pytest.mark.parametrize(("samples", "failing"), [(1, "0:99"), (3, "1:99")])
def test_a_failed_sample_is_never_counted_durable(tmp_path, samples, failing):
    run = failing_build(tmp_path, samples, failing)
    assert run.returncode == 1, run.stderr
    assert f"1 of {samples} samples failed on every attempt" in run.stderr
    counts = [(int(m[1]), int(m[2])) for m in PROGRESS.finditer(run.stderr)]
    durable = durable_in_shards(tmp_path / "out")
    assert durable == samples - 1
    assert all(total == samples for _, total in counts), counts
    assert max((done for done, _ in counts), default=0) == durable, run.stderr
    assert f"{samples}/{samples} durable" not in run.stderr
