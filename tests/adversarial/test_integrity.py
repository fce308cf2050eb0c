"""A dataset altered after it was written is caught, sample by sample: ``datagen verify`` (the
real CLI) names the altered, missing, duplicated and extra keys, ``load(verify=True)`` raises,
and a manifest of a future format is refused. Samples the build did not sign under its
``sample`` key (the raw secret of the old scheme, another build's key) never reach a shard."""

from __future__ import annotations

import hashlib
import hmac
import io
import json
import shutil
import subprocess
import sys
import tarfile
import zlib
from pathlib import Path

import pytest

import datagen
from datagen.config import config_from_dict
from datagen.dataset.frame_dataset import load_frames
from datagen.dataset.loader import DatasetError, load, verify
from datagen.pipeline.run import run_build
from datagen.sample import Sample
from datagen.shard_members import scan_members
from datagen.transport.collector import AckCollector
from datagen.transport.connection import MqttConnection
from datagen.transport.envelope import derive_key
from datagen.transport.publisher import SamplePublisher
from datagen.transport.run_binding import RunBinding
from datagen.transport.topics import topics
from datagen.transport.wire import SECRET_ENV, encode_sample

pytestmark = [pytest.mark.adversarial]
REPO = Path(__file__).resolve().parents[2]
SAMPLES = 6


def cli(*args) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "datagen.cli", *map(str, args)],
        capture_output=True,
        text=True,
        cwd=REPO,
        timeout=120,
    )


@pytest.fixture(scope="module")
def built(tmp_path_factory) -> Path:
    """A real build: 6 samples at 64x48 in shards of 3."""
    out = tmp_path_factory.mktemp("integrity") / "ds"
    config = config_from_dict({
        "num_samples": SAMPLES, "seed": 3,
        "render": {"width": 64, "height": 48, "wrist_camera": False},
        "objects": {"count": [1, 1]}, "physics": {"settle_time": 0.1},
        "output": {"shard_size": 3, "formats": ["webdataset"]},
    })  # fmt: skip
    run_build(config, out, workers=1)
    return out


@pytest.fixture
def copy(built, tmp_path) -> Path:
    return Path(shutil.copytree(built, tmp_path / "ds"))


def shard_of(root: Path, key: str) -> Path:
    manifest = json.loads((root / "manifest.json").read_text())
    name = next(s["name"] for s in manifest["shards"] if key in s["sample_sha256"])
    return root / name


def problems(result: subprocess.CompletedProcess) -> str:
    assert result.returncode == 1, (result.returncode, result.stdout, result.stderr)
    assert "Traceback" not in result.stderr
    return result.stderr


@pytest.mark.sim
@pytest.mark.mqtt
@pytest.mark.slow
def test_a_sample_altered_in_place_is_named(copy):
    intact = cli("verify", copy)
    assert intact.returncode == 0, intact.stderr
    assert f"{SAMPLES} samples in 2 shards verified (each sample's sha256)" in intact.stdout
    shard = shard_of(copy, "000000004")
    size = shard.stat().st_size
    member = next(m for m in scan_members(shard) if m.name == "000000004.json")
    with open(shard, "r+b") as f:  # same size, same tar headers: only the content differs
        f.seek(member.offset_data)
        meta = f.read(member.size)
        f.seek(member.offset_data)
        f.write(meta.replace(b'"seed"', b'"SEED"', 1))
    assert shard.stat().st_size == size and b'"seed"' in meta

    stderr = problems(cli("verify", copy))
    assert f"altered 1: 000000004 ({shard.name})" in stderr
    assert f"{shard.name}: sha256 differs from the manifest" in stderr
    assert "missing" not in stderr and "bytes, manifest says" not in stderr
    for open_verified in (
        load,
        load_frames,
        lambda root, verify: datagen.stream(root, verify=verify),
    ):
        with pytest.raises(DatasetError, match=r"altered 1: 000000004"):
            open_verified(copy, verify=True)
    assert len(load(copy)) == SAMPLES  # without verify=True: opened as before


def _rewrite(shard: Path, drop: frozenset[str] = frozenset(), append: tuple = ()) -> None:
    """The shard as a new tar without the members of keys in ``drop``, with ``append`` added."""
    with tarfile.open(shard) as tar:
        kept = [(m, tar.extractfile(m).read()) for m in tar if m.name.split(".")[0] not in drop]
    with tarfile.open(shard, "w", format=tarfile.USTAR_FORMAT) as tar:
        for member, data in kept:
            tar.addfile(member, io.BytesIO(data))
        for name, data in append:
            info = tarfile.TarInfo(name)
            info.size = len(data)
            tar.addfile(info, io.BytesIO(data))


@pytest.mark.sim
@pytest.mark.mqtt
@pytest.mark.slow
def test_removed_duplicated_and_extra_samples_are_named(copy):
    first, second = shard_of(copy, "000000001"), shard_of(copy, "000000004")
    assert first != second
    with tarfile.open(first) as tar:
        sample_2 = [(m.name, tar.extractfile(m).read()) for m in tar if m.name[:9] == "000000002"]
    _rewrite(first, drop=frozenset({"000000001"}))
    _rewrite(second, append=(*sample_2, ("000000099.json", b"{}")))

    stderr = problems(cli("verify", copy))
    for line in (
        "missing 1: 000000001",
        "extra 1: 000000099",
        "duplicated 1: 000000002",
        f"{first.name}: sha256 differs from the manifest",
        f"{second.name}: sha256 differs from the manifest",
    ):
        assert line in stderr, stderr
    assert "altered" not in stderr  # the second copy of 000000002 is byte-identical
    with pytest.raises(DatasetError, match=r"missing 1: 000000001.*extra 1: 000000099"):
        load(copy, verify=True)
    with pytest.raises(DatasetError, match=r"duplicated 1: 000000002"):
        verify(copy)


@pytest.mark.sim
@pytest.mark.mqtt
@pytest.mark.slow
def test_a_manifest_of_a_future_format_is_refused(copy):
    manifest = json.loads((copy / "manifest.json").read_text())
    assert manifest["dataset_format"] == "datagen.dataset/1"
    manifest["dataset_format"] = "datagen.dataset/9"
    (copy / "manifest.json").write_text(json.dumps(manifest))
    said = (
        f"{copy / 'manifest.json'}: dataset_format 'datagen.dataset/9' is newer than this "
        "datagen, which reads datagen.dataset/1 and older; upgrade datagen to read it"
    )
    for command in ("verify", "inspect"):
        result = cli(command, copy)
        assert result.returncode == 2 and "Traceback" not in result.stderr
        assert result.stderr.strip() == f"datagen {command}: error: {said}"
    with pytest.raises(DatasetError) as err:
        load(copy)
    assert str(err.value) == said


def _signed_with(key: bytes, build_id: str, sample: Sample, run: RunBinding) -> bytes:
    """A sample of ``run`` whose MAC is HMAC-SHA256 under ``key`` itself: the raw secret (as
    datagen signed before the HKDF keys), or a key of another purpose."""
    body = bytearray(encode_sample(build_id, sample, run=run)[:-4])
    body[6] = 1  # flags: signed
    body += hmac.new(key, bytes(body), hashlib.sha256).digest()
    return bytes(body) + zlib.crc32(body).to_bytes(4, "little")


@pytest.mark.mqtt
def test_samples_not_signed_under_the_builds_sample_key_are_rejected_and_counted(
    broker, build_id, start_writer, tmp_path, monkeypatch
):
    secret, foreign_secret = bytes(range(32)), bytes(range(1, 33))
    monkeypatch.setenv(SECRET_ENV, secret.hex())
    with AckCollector(broker.url, build_id, secret=secret) as collector:
        mark = len(collector.statuses)
        writer = start_writer(out=tmp_path / "ds", writer_id="0", shard_size=4)
        collector.wait_status("ready", writer="0", after=mark, timeout_s=60)
        run = collector.run  # the writer is bound to it once "ready"
        forged = [
            _signed_with(secret, build_id, Sample(0, {"json": b'{"forged":0}'}), run),
            _signed_with(
                derive_key(secret, "ack", run.run), build_id, Sample(1, {"json": b'{"f":1}'}), run
            ),
            encode_sample(build_id, Sample(2, {"json": b'{"forged":2}'}), foreign_secret, run),
            # a genuine sample of another build, moved onto this build's topic
            encode_sample("other-build", Sample(3, {"json": b'{"forged":3}'}), secret, run),
        ]
        raw = MqttConnection(broker.url, f"forger-{build_id}")
        for payload in forged:
            raw.client.publish(topics(build_id).samples, payload, qos=1).wait_for_publish(10)
        raw.close()
        genuine = [Sample(i, {"json": json.dumps({"genuine": i}).encode()}) for i in range(4)]
        with SamplePublisher(
            broker.url, build_id, f"pub-{build_id}", secret=secret, run=run
        ) as pub:
            for sample in genuine:
                pub.publish(sample)
        assert collector.wait_acked(set(range(4)), timeout_s=60), writer.log()
        status = collector.finalize(4, {})
    assert status["state"] == "finalized", writer.log()
    assert writer.wait() == 0
    manifest = verify(tmp_path / "ds")
    assert manifest["rejected_messages"] == len(forged)
    assert writer.log().count("signature does not verify") == 3
    dataset = load(tmp_path / "ds", verify=True)
    assert [dataset.metadata(i) for i in range(4)] == [{"genuine": i} for i in range(4)]
