"""``datagen verify``, ``load(verify=True)`` and the coordinator's final check: success means
the data is there, sample by sample (docs/dataset-format.md)."""

from __future__ import annotations

import hashlib
import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from datagen.dataset.loader import DatasetError, check_complete, load
from datagen.sample import Sample
from datagen.shards import read_shard, sample_sha256
from datagen.writer.finalize import FinalizeError, combine, write_part
from datagen.writer.journal import recover
from datagen.writer.shard_writer import ShardWriter, remove_keys

REPO = Path(__file__).resolve().parents[2]


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


def test_a_build_needs_samples_0_to_n_and_an_altered_byte_is_named(
    tmp_path, make_dataset, make_sample
):
    short = make_dataset(tmp_path / "short", [make_sample(i) for i in (0, 1, 3, 7)])
    manifest = json.loads((short / "manifest.json").read_text())
    with pytest.raises(DatasetError, match=r"missing 1: 000000002.*extra 1: 000000007"):
        check_complete(short, 4)  # a build of 4 samples: keys 0..3
    result = verify(short)  # any keys, as long as they are the manifest's
    assert result.returncode == 0 and "4 samples in 1 shard verified" in result.stdout

    shard = short / manifest["shards"][0]["name"]
    data = bytearray(shard.read_bytes())
    data[700] ^= 0xFF  # one flipped byte inside the first member
    shard.write_bytes(bytes(data))
    result = verify(short)
    assert result.returncode == 1 and "Traceback" not in result.stderr
    assert "sha256 differs from the manifest" in result.stderr
    assert "altered 1: 000000000 (shard-0-000000.tar)" in result.stderr


def test_a_manifest_of_another_build_is_refused(tmp_path, make_dataset, make_sample):
    out = make_dataset(tmp_path / "ds", [make_sample(i) for i in range(2)])
    manifest = json.loads((out / "manifest.json").read_text())
    (out / "manifest.json").write_text(json.dumps(manifest | {"build_id": "other"}))
    with pytest.raises(DatasetError, match="of build 'other', not 'mine'"):
        check_complete(out, 2, build_id="mine")


def _documented(tag: str) -> str:
    doc = (REPO / "docs" / "dataset-format.md").read_text()
    found = re.search(rf"<!-- {tag} -->(?:\n```python\n(.*?)```|`([0-9a-f ]+)`)", doc, re.S)
    assert found, f"docs/dataset-format.md has nothing tagged <!-- {tag} -->"
    return found[1] or found[2]


def test_the_sample_digest_is_the_documented_one(make_sample):
    scope: dict = {}
    exec(_documented("sample-digest"), scope)
    example = {"json": b'{"n":1}', "note.txt": b"hi"}
    assert sample_sha256(example.items()) == _documented("sample-digest-example")
    assert scope["sample_sha256"](example) == _documented("sample-digest-example")
    hashed = bytes.fromhex(_documented("sample-digest-input"))
    assert len(hashed) == 39 and hashlib.sha256(hashed).hexdigest() == sample_sha256(
        example.items()
    )
    parts = make_sample(3).parts
    assert scope["sample_sha256"](parts) == sample_sha256(reversed(parts.items()))


def test_digests_written_recovered_and_rewritten_are_those_of_the_bytes_on_disk(
    tmp_path, make_sample
):
    samples = [make_sample(i) for i in range(5)]
    with ShardWriter(tmp_path, "w", max_count=10) as sink:
        for s in samples:
            sink.write(s)
    [written] = sink.shards
    path = tmp_path / written.name
    assert written.sample_sha256 == {s.key: sample_sha256(s.parts.items()) for s in samples}
    assert read_shard(path).info(written.name) == written
    assert recover(tmp_path, "w").shards == [written]  # a restarted writer's view
    rewritten = remove_keys(path, {"000000001", "000000003"})
    kept = {k: v for k, v in written.sample_sha256.items() if k not in ("000000001", "000000003")}
    assert rewritten.sample_sha256 == kept and rewritten.samples == 3
    assert rewritten == read_shard(path).info(written.name)


def test_a_digest_is_checked_from_the_loaded_parts(tmp_path, make_dataset, make_sample):
    out = make_dataset(tmp_path / "ds", [make_sample(i) for i in range(3)])
    dataset = load(out, verify=True)
    listed = {k: v for s in dataset.manifest["shards"] for k, v in s["sample_sha256"].items()}
    for i, key in enumerate(dataset.keys):
        assert sample_sha256(dataset.raw(i).items()) == listed[key]


def test_every_shard_and_sample_problem_is_reported_at_once(tmp_path, make_dataset, make_sample):
    out = make_dataset(tmp_path / "ds", [make_sample(i) for i in range(8)], shard_size=4)
    (out / "shard-0-000001.tar").unlink()  # samples 4..7
    shutil.copy(out / "shard-0-000000.tar", out / "shard-9-000000.tar")  # not in the manifest
    result = verify(out)
    assert result.returncode == 1 and "Traceback" not in result.stderr
    assert result.stderr.splitlines()[0] == f"datagen: {out}: 3 problems:"
    assert result.stderr.splitlines()[1:] == [
        "  shard-0-000001.tar: missing",
        "  missing 4: 000000004, 000000005, 000000006, 000000007",
        "  shards not in the manifest: shard-9-000000.tar",
    ]


def test_a_manifest_without_sample_digests_is_checked_by_shard_checksums(
    tmp_path, make_dataset, make_sample
):
    out = make_dataset(tmp_path / "ds", [make_sample(i) for i in range(3)])
    manifest = json.loads((out / "manifest.json").read_text())
    for shard in manifest["shards"]:
        del shard["sample_sha256"]
    (out / "manifest.json").write_text(json.dumps(manifest))
    result = verify(out)
    assert result.returncode == 0, result.stderr
    assert "3 samples in 1 shard verified (shard sha256 and keys only" in result.stdout
    assert "predates per-sample digests" in result.stdout


@pytest.mark.parametrize(
    ("dataset_format", "refusal"),
    [
        ("datagen.dataset/2", "is newer than this datagen, which reads datagen.dataset/1"),
        ("datagen.dataset/0", "is not a datagen dataset format (expected 'datagen.dataset/1')"),
        ("webdataset/1", "is not a datagen dataset format"),
        (1, "dataset_format 1 is not a datagen dataset format"),
    ],
)
def test_a_manifest_of_an_unknown_format_is_refused_with_exit_2(
    tmp_path, make_dataset, make_sample, dataset_format, refusal
):
    out = make_dataset(tmp_path / "ds", [make_sample(0)])
    manifest = json.loads((out / "manifest.json").read_text())
    assert "dataset_format" not in manifest  # written without one: read as version 1
    assert len(load(out)) == 1
    (out / "manifest.json").write_text(json.dumps(manifest | {"dataset_format": dataset_format}))
    with pytest.raises(DatasetError, match=re.escape(refusal)):
        load(out)
    result = verify(out)
    assert result.returncode == 2 and refusal in result.stderr
    assert result.stderr.count("\n") == 1 and "Traceback" not in result.stderr


def test_verify_of_what_is_not_a_dataset_is_a_user_error(tmp_path):
    result = verify(tmp_path)
    assert result.returncode == 2
    assert (
        result.stderr
        == f"datagen verify: error: {tmp_path} is not a datagen dataset: no manifest.json (not finalized?)\n"
    )


def test_finalize_refuses_a_part_file_whose_digests_do_not_match_its_shard(tmp_path):
    with ShardWriter(tmp_path, "A", max_count=10) as sink:
        for i in range(3):
            sink.write(Sample(i, {"json": b"{}"}))
    [shard] = sink.shards
    del shard.sample_sha256["000000002"]
    write_part(tmp_path, "A", "r1", shards=[shard.to_json()], samples=3)
    with pytest.raises(FinalizeError, match="sample digests do not match its samples"):
        combine(tmp_path, ["A"], "r1", 3)


def test_a_manifest_that_contradicts_itself_is_reported(tmp_path, make_dataset, make_sample):
    out = make_dataset(tmp_path / "ds", [make_sample(i) for i in range(4)], shard_size=2)
    manifest = json.loads((out / "manifest.json").read_text())
    first, second = manifest["shards"]
    second["sample_sha256"]["000000000"] = first["sample_sha256"]["000000000"]
    (out / "manifest.json").write_text(json.dumps(manifest))
    result = verify(out)
    assert result.returncode == 1
    assert result.stderr.splitlines()[-2:] == [
        "  the manifest lists 3 sample digests for shard-0-000001.tar, which it says holds 2 "
        "samples",
        "  listed twice in the manifest 1: 000000000",
    ]
