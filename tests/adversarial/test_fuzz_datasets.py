"""Property-based fuzz of a dataset as input (issue 22): manifests, sample JSON and shard tars of
a real build, mutated by Hypothesis, go through the readers a user runs (``datagen verify``,
``datagen export`` in this process, ``datagen.load`` and its items). Whatever the mutation: no
exception escapes but ``DatasetError`` from the library, the commands exit 0, 1 or 2 naming the
dataset, and nothing is written outside the dataset's folder."""

from __future__ import annotations

import contextlib
import io
import json
import shutil
import tarfile
import tempfile
import zlib
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from adversarial.forged_datasets import (
    members_of,
    resign,
    rewrite_shard,
    snapshot,
    tiny_build,
)
from datagen.cli import main
from datagen.dataset.loader import DatasetError, load

pytestmark = [pytest.mark.adversarial, pytest.mark.sim]
SHARD = "shard-0-000001.tar"
FUZZ = settings(
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)

json_values = st.recursive(
    st.none() | st.booleans() | st.integers(-(2**70), 2**70) | st.floats()
    | st.text(max_size=12) | st.just("/tmp/outside/x") | st.just("../../x"),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=8), inner, max_size=3),
    max_leaves=8,
)  # fmt: skip


@pytest.fixture(scope="module")
def source(tmp_path_factory) -> Path:
    return tiny_build(tmp_path_factory)


def cli(*argv) -> tuple[int, str]:
    err = io.StringIO()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
        try:
            code = main([str(a) for a in argv])
        except SystemExit as exc:
            code = exc.code
    return code, err.getvalue()


def paths(value, prefix=()) -> list[tuple]:
    """Every path into a JSON value, as tuples of keys and indices."""
    found = [prefix]
    if isinstance(value, dict):
        for key, item in value.items():
            found += paths(item, (*prefix, key))
    elif isinstance(value, list):
        for i, item in enumerate(value):
            found += paths(item, (*prefix, i))
    return found


def mutate(doc, path: tuple, new, delete: bool):
    """``doc`` with the value at ``path`` replaced by ``new`` (or deleted)."""
    if not path:
        return new
    parent = doc
    for step in path[:-1]:
        parent = parent[step]
    if delete:
        del parent[path[-1]]
    else:
        parent[path[-1]] = new
    return doc


def read_everything(work: Path, formats: str) -> None:
    """What a user runs on ``work/ds``; checks the properties."""
    root = work / "ds"
    outside = {k: v for k, v in snapshot(work).items() if not k.startswith(str(root))}
    for argv in (("verify", root), ("export", root, "--to", formats, "--force")):
        code, err = cli(*argv)
        assert code in (0, 1, 2), (argv, code, err)
        assert "Traceback" not in err, err
        assert code == 0 or str(root) in err or "shard-" in err, err  # named
    try:
        dataset = load(root)
        for i in range(len(dataset)):
            dataset[i]
            dataset.metadata(i)
    except DatasetError:
        pass
    after = {k: v for k, v in snapshot(work).items() if not k.startswith(str(root))}
    assert after == outside


@contextlib.contextmanager
def copy_of(source: Path):
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        shutil.copytree(source, work / "ds")
        (work / "outside").mkdir()
        (work / "outside" / "x.ply").write_bytes(b"precious")
        yield work


@settings(FUZZ, max_examples=40)
@given(data=st.data())
def test_mutated_manifests(source, data):
    manifest = json.loads((source / "manifest.json").read_text())
    how = data.draw(st.sampled_from(["value", "delete", "bytes"]))
    with copy_of(source) as work:
        if how == "bytes":
            text = json.dumps(manifest).encode()
            cut = data.draw(st.integers(0, len(text)))
            text = text[:cut] + data.draw(st.binary(max_size=16)) + text[cut + 1 :]
        else:
            path = data.draw(st.sampled_from(paths(manifest)[1:]))
            new = data.draw(json_values)
            text = json.dumps(mutate(manifest, path, new, how == "delete")).encode()
        (work / "ds" / "manifest.json").write_bytes(text)
        read_everything(work, "coco,hdf5")


@settings(FUZZ, max_examples=25)
@given(data=st.data())
def test_mutated_sample_json(source, data):
    """The mutated metadata is re-signed into the manifest, so that every export reads it."""
    [meta_bytes] = [d for i, d in members_of(source / SHARD) if i.name.endswith(".json")]
    meta = json.loads(meta_bytes)
    if data.draw(st.booleans()):
        path = data.draw(st.sampled_from(paths(meta)))
        new = json.dumps(mutate(meta, path, data.draw(json_values), data.draw(st.booleans())))
        new_bytes = new.encode()
    else:
        new_bytes = data.draw(st.binary(max_size=64))
    with copy_of(source) as work:

        def change(members):
            for info, payload in members:
                if info.name.endswith(".json"):
                    info.size = len(new_bytes)
                    yield info, new_bytes
                else:
                    yield info, payload

        rewrite_shard(work / "ds" / SHARD, lambda ms: list(change(ms)))
        resign(work / "ds")
        read_everything(work, "coco,hdf5,pointcloud,usd")


def _with_checksum(header: bytearray) -> bytes:
    header[148:156] = b" " * 8
    header[148:155] = f"{sum(header):06o}\0".encode()
    return bytes(header)


@settings(FUZZ, max_examples=60)
@given(data=st.data())
def test_mutated_shard_tars(source, data):
    """Bytes overwritten anywhere, or a header field given other bytes with a valid checksum
    (so that the reader parses it), or the tar cut short; re-signed or not."""
    shard = bytearray((source / SHARD).read_bytes())
    headers = [m.offset for m, _ in members_of(source / SHARD)]
    how = data.draw(st.sampled_from(["bytes", "field", "cut"]))
    if how == "bytes":
        at = data.draw(st.integers(0, len(shard) - 1))
        patch = data.draw(st.binary(min_size=1, max_size=8))
        shard[at : at + len(patch)] = patch
    elif how == "field":
        start = data.draw(st.sampled_from(headers))
        field = data.draw(st.sampled_from([(0, 100), (124, 12), (156, 1), (157, 100), (345, 155)]))
        value = data.draw(
            st.binary(max_size=field[1])
            | st.sampled_from([b"/tmp/outside/x.ply", b"../x.json", b"2", b"6", b"77777777777"])
        )
        header = bytearray(shard[start : start + 512])
        header[field[0] : field[0] + field[1]] = value.ljust(field[1], b"\0")[: field[1]]
        shard[start : start + 512] = _with_checksum(header)
    else:
        del shard[data.draw(st.integers(0, len(shard) - 1)) :]
    with copy_of(source) as work:
        (work / "ds" / SHARD).write_bytes(bytes(shard))
        if data.draw(st.booleans()):
            with contextlib.suppress(tarfile.TarError, zlib.error, EOFError, OSError, ValueError):
                resign(work / "ds")
        read_everything(work, "coco,hdf5,pointcloud")
