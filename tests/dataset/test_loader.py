"""Shards (datagen.shards) and reading them back (datagen.dataset.loader)."""

from __future__ import annotations

import json
import pickle
import tarfile

import numpy as np
import pytest

from datagen.dataset.loader import DatasetError, load, verify
from datagen.sample import Sample
from datagen.shard_members import scan_members
from datagen.shards import file_sha256, keys_sha256, read_keys
from datagen.writer.finalize import (
    FinalizeError,
    combine,
    drop_copies_held_by_smaller,
    write_part,
)
from datagen.writer.journal import durable_keys, recover
from datagen.writer.lock import WriterLock, WriterLocked
from datagen.writer.shard_writer import ShardWriter, remove_keys


def test_items_are_decoded_arrays(tmp_path, make_sample, make_arrays, make_dataset):
    samples = [make_sample(i) for i in (3, 1, 2)]
    samples[0].parts["extra.bin"] = b"\x00\x01raw"
    ds = load(make_dataset(tmp_path, samples, shard_size=2))
    assert len(ds) == 3 and ds.keys == ["000000001", "000000002", "000000003"]
    for i, index in enumerate((1, 2, 3)):
        item, want = ds[i], make_arrays(index)
        assert item["key"] == f"{index:09d}"
        assert item["rgb"].dtype == np.uint8 and item["rgb"].shape == (24, 32, 3)
        np.testing.assert_array_equal(item["rgb"], want["rgb"])
        assert item["depth"].dtype == np.uint16
        np.testing.assert_array_equal(item["depth"], want["depth"])
        assert item["seg"].dtype == np.uint16
        np.testing.assert_array_equal(item["seg"], want["seg"])
        np.testing.assert_array_equal(item["semantic"], want["semantic"])
        assert item["meta"] == want["meta"]
    assert ds[2]["extra.bin"] == b"\x00\x01raw"
    assert [item["key"] for item in ds] == ds.keys


def test_shards_are_byte_reproducible_and_normalised(tmp_path, make_sample, make_dataset):
    samples = [make_sample(i) for i in range(5)]
    a = verify(make_dataset(tmp_path / "a", samples, shard_size=2))
    b = verify(make_dataset(tmp_path / "b", samples, shard_size=2))
    assert [s["sha256"] for s in a["shards"]] == [s["sha256"] for s in b["shards"]]
    assert [s["samples"] for s in a["shards"]] == [2, 2, 1]
    with tarfile.open(tmp_path / "a" / "shard-0-000000.tar") as tar:
        members = tar.getmembers()
    assert members[0].name == "000000000.rgb.png"
    assert {(m.mtime, m.uid, m.gid, m.uname, m.gname, m.mode) for m in members} == {
        (0, 0, 0, "", "", 0o644)
    }


def test_webdataset_reads_the_same_keys(tmp_path, make_sample, make_dataset):
    import webdataset as wds

    ds = load(make_dataset(tmp_path, [make_sample(i) for i in range(7)], shard_size=3))
    seen = [
        (s["__key__"], json.loads(s["json"])["index"])
        for s in wds.WebDataset(ds.shard_paths(), shardshuffle=False)
    ]
    assert [k for k, _ in seen] == ds.keys
    assert [int(k) for k, _ in seen] == [i for _, i in seen]


def test_torch_dataloader_with_two_workers_sees_every_sample_once(
    tmp_path, make_sample, make_dataset
):
    torch = pytest.importorskip("torch")
    ds = load(make_dataset(tmp_path, [make_sample(i) for i in range(10)], shard_size=3))
    ds[0]  # handles opened in the parent must not leak into the workers
    loader = torch.utils.data.DataLoader(ds, num_workers=2, batch_size=None)
    keys = []
    for item in loader:
        assert tuple(item["rgb"].shape) == (24, 32, 3)
        keys.append(item["key"])
    assert sorted(keys) == ds.keys and len(keys) == 10


def test_dataset_pickles(tmp_path, make_sample, make_dataset):
    ds = load(make_dataset(tmp_path, [make_sample(i) for i in range(3)]))
    ds[1]
    clone = pickle.loads(pickle.dumps(ds))
    assert clone.keys == ds.keys
    np.testing.assert_array_equal(clone[1]["depth"], ds[1]["depth"])


def test_verify_detects_a_changed_shard(tmp_path, make_sample, make_dataset):
    out = make_dataset(tmp_path, [make_sample(i) for i in range(3)])
    verify(out)
    shard = out / "shard-0-000000.tar"
    data = bytearray(shard.read_bytes())
    data[600] ^= 0xFF
    shard.write_bytes(bytes(data))
    with pytest.raises(DatasetError, match="sha256 differs"):
        verify(out)


def test_not_a_dataset_is_a_clear_error(tmp_path):
    with pytest.raises(DatasetError, match=r"not a datagen dataset: no manifest\.json"):
        load(tmp_path)
    (tmp_path / "manifest.json").write_text('{"samples": 1}')
    with pytest.raises(DatasetError, match="no 'shards' list"):
        load(tmp_path)


def test_recover_cuts_an_unfinished_shard_back_to_its_durable_samples(tmp_path, make_sample):
    sink = ShardWriter(tmp_path, "w", max_count=100)
    for i in range(3):
        sink.write(make_sample(i))
    sink.flush_durable()
    sink.write(make_sample(3))
    sink._open.file.f.flush()  # part of sample 3 reaches the disk, then the process dies
    shard = tmp_path / "shard-w-000000.tar"
    with open(shard, "r+b") as f:
        f.truncate(shard.stat().st_size - 700)
    assert shard.stat().st_size % 10240 != 0

    for _ in range(2):  # and a second recovery changes nothing
        rec = recover(tmp_path, "w")
        assert rec.keys == {"000000000", "000000001", "000000002"}
        assert rec.next_shard == 1
        assert [(s.name, s.samples) for s in rec.shards] == [("shard-w-000000.tar", 3)]
        with tarfile.open(shard) as tar:
            assert len(tar.getmembers()) == 15
    assert shard.stat().st_size % 10240 == 0


def test_recover_drops_a_shard_with_nothing_durable_and_keeps_finished_ones(tmp_path):
    with ShardWriter(tmp_path, "w", max_count=1) as sink:
        sink.write(Sample(0, {"json": b"{}"}))
    (tmp_path / "shard-w-000001.tar").write_bytes(b"\x00" * 100)  # died before its first fsync
    with ShardWriter(tmp_path, "v") as other:
        other.write(Sample(9, {"json": b"{}"}))
    rec = recover(tmp_path, "w")
    assert not (tmp_path / "shard-w-000001.tar").exists()
    assert rec.keys == {"000000000"} and rec.other_keys == {"000000009"}
    assert rec.next_shard == 2


def test_scan_members_matches_tarfile_and_stops_at_a_damaged_header(tmp_path, make_sample):
    with ShardWriter(tmp_path, "w", max_count=10) as sink:
        for i in range(4):
            sink.write(make_sample(i))
    shard = tmp_path / "shard-w-000000.tar"
    with tarfile.open(shard) as tar:
        expected = [(m.name, m.offset, m.offset_data, m.size) for m in tar]
    members = scan_members(shard)
    assert [(m.name, m.offset, m.offset_data, m.size) for m in members] == expected
    assert read_keys(shard) == [f"{i:09d}" for i in range(4)]
    damaged = bytearray(shard.read_bytes())
    damaged[members[5].offset + 3] ^= 0x20  # a bit flip in the 6th header
    shard.write_bytes(bytes(damaged))
    assert read_keys(shard) == ["000000000"]  # the first sample's 5 members only


def test_remove_keys_leaves_the_tar_a_fresh_writer_would_have_made(tmp_path, make_sample):
    samples = [make_sample(i) for i in range(5)]
    with ShardWriter(tmp_path / "a", "w", max_count=10) as sink:
        for s in samples:
            sink.write(s)
    with ShardWriter(tmp_path / "b", "w", max_count=10) as sink:
        for s in samples:
            if s.index not in (1, 3):
                sink.write(s)
    info = remove_keys(tmp_path / "a" / "shard-w-000000.tar", {"000000001", "000000003"})
    rewritten = (tmp_path / "a" / "shard-w-000000.tar").read_bytes()
    assert rewritten == (tmp_path / "b" / "shard-w-000000.tar").read_bytes()
    assert (info.samples, info.bytes) == (3, len(rewritten))
    assert info.sha256 == file_sha256(tmp_path / "a" / "shard-w-000000.tar")
    assert (
        remove_keys(tmp_path / "b" / "shard-w-000000.tar", {f"{i:09d}" for i in range(5)}) is None
    )
    assert not (tmp_path / "b" / "shard-w-000000.tar").exists()


def test_durable_keys_of_a_shard_being_written_stop_at_its_journal(tmp_path, make_sample):
    sink = ShardWriter(tmp_path, "x", max_count=100)
    for i in range(3):
        sink.write(make_sample(i))
    sink.flush_durable()
    sink.write(make_sample(3))
    sink._open.file.f.flush()  # on disk, not yet durable: it may be cut on recovery
    assert read_keys(tmp_path / "shard-x-000000.tar")[-1] == "000000003"
    assert durable_keys(tmp_path, "x") == {"000000000", "000000001", "000000002"}
    assert recover(tmp_path, "y").other_keys == {"000000000", "000000001", "000000002"}
    sink.close()
    assert len(durable_keys(tmp_path, "x")) == 4


def test_a_writer_lock_is_exclusive(tmp_path):
    lock = WriterLock(tmp_path, "A")
    with pytest.raises(WriterLocked, match=r"writer 'A' is already running on .*pid \d+"):
        WriterLock(tmp_path, "A")
    WriterLock(tmp_path, "B").release()
    lock.release(remove=True)
    assert not (tmp_path / ".writer-A.lock").exists()
    WriterLock(tmp_path, "A").release()


def _part(out, writer_id, shards, round_id="r1"):
    write_part(out, writer_id, round_id, shards=[s.to_json() for s in shards], samples=0)


def test_combine_checks_the_directory_against_the_writers_reports(tmp_path):
    def shard(writer_id, indices):
        with ShardWriter(tmp_path, writer_id, max_count=100) as sink:
            for i in indices:
                sink.write(Sample(i, {"json": b"{}"}))
        return sink.shards

    a, b = shard("A", range(0, 4)), shard("B", range(4, 7))
    _part(tmp_path, "A", a)
    with pytest.raises(FinalizeError, match=r"writers not in the finalize list.*shard-B-000000"):
        combine(tmp_path, ["A"], "r1", 4)
    with pytest.raises(FinalizeError, match=r"cannot read writer-B\.json"):
        combine(tmp_path, ["A", "B"], "r1", 7)
    _part(tmp_path, "B", b, round_id="r0")
    with pytest.raises(FinalizeError, match="from another finalize"):
        combine(tmp_path, ["A", "B"], "r1", 7)
    _part(tmp_path, "B", b)
    with pytest.raises(FinalizeError, match="expected 8 samples, have 7") as err:
        combine(tmp_path, ["A", "B"], "r1", 8)
    assert err.value.fields == {"samples": 7, "expected": 8}
    doc = combine(tmp_path, ["B", "A"], "r1", 7)
    assert doc["samples"] == 7 and doc["writers"] == ["A", "B"]
    assert [s["name"] for s in doc["shards"]] == ["shard-A-000000.tar", "shard-B-000000.tar"]

    c = shard("C", [3, 9])  # sample 3 twice: C must drop it, A keeps it
    _part(tmp_path, "C", c)
    with pytest.raises(FinalizeError, match="sample 000000003 is in both"):
        combine(tmp_path, ["A", "B", "C"], "r1", 8)
    kept, removed = drop_copies_held_by_smaller(tmp_path, "C", c)
    assert removed == {"000000003"} and kept[0].samples == 1
    _part(tmp_path, "C", kept)
    assert combine(tmp_path, ["A", "B", "C"], "r1", 8)["keys_sha256"] == keys_sha256(
        f"{i:09d}" for i in [*range(7), 9]
    )
