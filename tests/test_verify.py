"""``datagen verify`` and the coordinator's final check: success means the data is there."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from datagen.dataset.loader import DatasetError, check_complete

REPO = Path(__file__).resolve().parents[1]


def verify(path: Path) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "datagen.cli", "verify", str(path)],
        capture_output=True,
        text=True,
        cwd=REPO,
        timeout=120,
    )


def test_a_complete_dataset_verifies(tmp_path, make_dataset, make_sample):
    out = make_dataset(tmp_path / "ds", [make_sample(i) for i in range(6)])
    result = verify(out)
    assert result.returncode == 0, result.stderr
    assert "6 samples in 2 shards verified" in result.stdout


def test_missing_extra_and_altered_samples_are_named(tmp_path, make_dataset, make_sample):
    short = make_dataset(tmp_path / "short", [make_sample(i) for i in (0, 1, 3, 7)])
    manifest = json.loads((short / "manifest.json").read_text())
    with pytest.raises(DatasetError, match=r"missing 1: 000000002.*extra 1: 000000007"):
        check_complete(short, 4)
    result = verify(short)
    assert result.returncode != 0 and "Traceback" not in result.stderr
    assert "missing 1: 000000002" in result.stderr and "extra 1: 000000007" in result.stderr

    shard = short / manifest["shards"][0]["name"]
    data = bytearray(shard.read_bytes())
    data[700] ^= 0xFF  # one flipped byte inside a member
    shard.write_bytes(bytes(data))
    result = verify(short)
    assert result.returncode != 0 and "sha256 differs from the manifest" in result.stderr


def test_a_manifest_of_another_build_is_refused(tmp_path, make_dataset, make_sample):
    out = make_dataset(tmp_path / "ds", [make_sample(i) for i in range(2)])
    manifest = json.loads((out / "manifest.json").read_text())
    (out / "manifest.json").write_text(json.dumps(manifest | {"build_id": "other"}))
    with pytest.raises(DatasetError, match="of build 'other', not 'mine'"):
        check_complete(out, 2, build_id="mine")
