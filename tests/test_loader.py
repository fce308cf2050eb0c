"""Shards (datagen.sinks.webdataset) and reading them back (datagen.loader)."""

from __future__ import annotations

import json
import pickle
import tarfile

import numpy as np
import pytest

from datagen.loader import DatasetError, load, verify
from datagen.sample import Sample
from datagen.sinks.webdataset import ShardWriter, journal_path, recover


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
    journal_path(tmp_path, "w").unlink()  # as after finalize
    (tmp_path / "shard-w-000001.tar").write_bytes(b"\x00" * 100)  # died before its first fsync
    with ShardWriter(tmp_path, "v") as other:
        other.write(Sample(9, {"json": b"{}"}))
    rec = recover(tmp_path, "w")
    assert not (tmp_path / "shard-w-000001.tar").exists()
    assert rec.keys == {"000000000"} and rec.other_keys == {"000000009"}
    assert rec.next_shard == 2
