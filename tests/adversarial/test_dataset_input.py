"""A dataset is hostile input (issue 22): shard members named by absolute paths or with ``..``,
links, FIFOs and devices as members, a shard that is a link to /dev/zero or a FIFO, a member
declaring 6 GiB, an export onto a full disk. Each forged dataset is re-signed, so its manifest
agrees with its shards. ``datagen verify`` (exit 1), ``export`` and ``inspect`` (exit 2) and
``datagen.load`` name the shard and the member on one line, never hang, never read a member
whole, and write nothing outside the dataset; a failed export leaves nothing behind."""

from __future__ import annotations

import json
import os
import resource
import subprocess
import sys
import tarfile
from pathlib import Path

import pytest

from adversarial.forged_datasets import (
    copy_dataset,
    renamed,
    resign,
    rewrite_shard,
    small_tmpfs,
    snapshot,
    special,
    tiny_build,
)
from adversarial.grasp_dataset import cli
from datagen.dataset.loader import DatasetError, load

pytestmark = [pytest.mark.adversarial, pytest.mark.sim]
REPO = Path(__file__).resolve().parents[2]
SHARD = "shard-0-000001.tar"  # holds sample 000000001
EXPORTS = ("pointclouds", "coco", "usd", "episodes.h5", "inspect")
EVERY_FORMAT = "pointcloud,coco,usd,hdf5"


def real_cli(*argv, memory: int | None = None) -> tuple[int, str, str]:
    """``datagen ARGV`` as a user runs it; ``memory``: its address-space limit in bytes."""

    def limit() -> None:
        if memory:
            resource.setrlimit(resource.RLIMIT_AS, (memory, memory))

    done = subprocess.run(
        [sys.executable, "-m", "datagen.cli", *map(str, argv)],
        capture_output=True, text=True, cwd=REPO, timeout=60, preexec_fn=limit,
    )  # fmt: skip
    return done.returncode, done.stdout, done.stderr


def failed(result: tuple[int, str, str], status: int, *fragments: str) -> None:
    """The command exited with ``status``, its stderr holding ``fragments`` and no traceback."""
    code, _, err = result
    assert code == status, (code, err)
    assert "Traceback" not in err, err
    for fragment in fragments:
        assert fragment in err, err


@pytest.fixture
def dataset(tmp_path_factory, tmp_path) -> Path:
    return copy_dataset(tiny_build(tmp_path_factory), tmp_path / "ds")


def _absolute(victim: Path):
    return lambda members: [(renamed(i, f"{victim}/{i.name}"), d) for i, d in members]


def _replace_part(part: str, make):
    return lambda members: [
        (make(i.name), b"") if i.name.endswith(f".{part}") else (i, d) for i, d in members
    ]


def _pax_path(victim: Path):
    """A pax header naming the json member by an absolute path; its USTAR name looks harmless."""

    def change(members):
        for info, _ in members:
            if info.name.endswith(".json"):
                info.pax_headers = {"path": f"{victim}/{info.name}"}
        return members

    return change


# attack -> (shard rewrite given the victim folder, tar format, what the error must say)
ATTACKS = {
    "absolute": (_absolute, tarfile.USTAR_FORMAT, "/victim/000000001.rgb.png' is an absolute path"),
    "dotdot": (lambda v: lambda ms: [(renamed(i, f"../{i.name}"), d) for i, d in ms], tarfile.USTAR_FORMAT, "'../000000001.rgb.png' is a path with '..'"),
    "symlink": (lambda v: _replace_part("rgb.png", lambda n: special(n, tarfile.SYMTYPE, "/etc/passwd")), tarfile.USTAR_FORMAT, "'000000001.rgb.png' is a symbolic link"),
    "hardlink": (lambda v: _replace_part("depth.png", lambda n: special(n, tarfile.LNKTYPE, "000000001.rgb.png")), tarfile.USTAR_FORMAT, "'000000001.depth.png' is a hard link"),
    "fifo": (lambda v: _replace_part("seg.png", lambda n: special(n, tarfile.FIFOTYPE)), tarfile.USTAR_FORMAT, "'000000001.seg.png' is a FIFO"),
    "device": (lambda v: _replace_part("json", lambda n: special(n, tarfile.CHRTYPE)), tarfile.USTAR_FORMAT, "'000000001.json' is a character device"),
    "pax_absolute": (_pax_path, tarfile.PAX_FORMAT, "is a pax extended header"),
}  # fmt: skip


@pytest.mark.parametrize("attack", list(ATTACKS))
def test_a_member_that_is_not_a_sample_file_is_named_and_nothing_is_written_outside(
    dataset, tmp_path, attack
):
    change, fmt, says = ATTACKS[attack]
    victim = tmp_path / "victim"  # where the exports of key <victim>/000000001 would write
    victim.mkdir()
    for suffix in (".ply", ".png", ".usda"):
        (victim / f"000000001{suffix}").write_bytes(b"precious")
    before = snapshot(victim)
    rewrite_shard(dataset / SHARD, change(victim), fmt)
    resign(dataset)

    failed(cli("verify", dataset), 1, SHARD, says)
    failed(cli("export", dataset, "--to", EVERY_FORMAT), 2, SHARD, says)
    failed(cli("inspect", dataset), 2, SHARD, says)
    with pytest.raises(DatasetError, match=f"{SHARD}.*{says}"):
        load(dataset)
    assert snapshot(victim) == before
    assert not [name for name in EXPORTS if (dataset / name).exists()]
    assert not list(dataset.glob(".*.partial"))


@pytest.mark.timeout(120)
@pytest.mark.parametrize("kind", ["link to /dev/zero", "FIFO"])
def test_a_shard_that_is_a_device_or_a_fifo_is_refused_without_hanging(dataset, kind):
    shard = dataset / SHARD
    shard.unlink()
    if kind == "FIFO":
        os.mkfifo(shard)
        says = f"{SHARD}: a FIFO, not a regular file"
    else:
        shard.symlink_to("/dev/zero")
        says = f"{SHARD}: a character device (a link to '/dev/zero'), not a regular file"

    failed(real_cli("verify", dataset), 1, says)  # hung reading before
    failed(cli("export", dataset, "--to", "hdf5"), 2, says)
    with pytest.raises(DatasetError, match=says.replace("(", r"\(").replace(")", r"\)")):
        load(dataset)


def test_a_member_declaring_6_gib_is_refused_unread(dataset):
    """A sparse shard: its last member's header declares 6 GiB, and the file is that long
    (holes on disk, no bytes written); the manifest lists the shard's real length."""
    shard = dataset / SHARD
    declared = 6 * 2**30
    with tarfile.open(shard) as tar:
        last = tar.getmembers()[-1]
    with open(shard, "r+b") as f:
        f.seek(last.offset_data + -(-last.size // tarfile.BLOCKSIZE) * tarfile.BLOCKSIZE)
        header = tarfile.TarInfo("000000001.blob.bin")  # over the end-of-archive blocks
        header.size = declared
        f.write(header.tobuf(tarfile.USTAR_FORMAT))
        f.truncate(f.tell() + declared + 2 * tarfile.BLOCKSIZE)
    manifest = json.loads((dataset / "manifest.json").read_text())
    record = next(r for r in manifest["shards"] if r["name"] == SHARD)
    record["bytes"] = shard.stat().st_size
    (dataset / "manifest.json").write_text(json.dumps(manifest))
    assert shard.stat().st_blocks * 512 < 2**20  # nothing of it is on disk

    says = f"member '000000001.blob.bin' declares {declared} bytes"
    failed(real_cli("verify", dataset, memory=3 * 2**30), 1, SHARD, says)  # MemoryError before
    failed(cli("export", dataset, "--to", "hdf5"), 2, SHARD, says)
    with pytest.raises(DatasetError, match=says):
        load(dataset)


def test_a_key_in_a_samples_metadata_cannot_lead_the_usd_textures_outside(dataset, tmp_path):
    """The USD export names texture tiles ``textures/<metadata key>/<look>.png``."""
    victim = tmp_path / "victim"
    victim.mkdir()

    def change(members):
        for info, data in members:
            if info.name.endswith(".json"):
                data = json.dumps(json.loads(data) | {"key": "../../../victim/k"}).encode()
                info.size = len(data)
            yield info, data

    rewrite_shard(dataset / SHARD, lambda members: list(change(members)))
    resign(dataset)
    failed(cli("export", dataset, "--to", "usd"), 2, "outside this folder")
    assert not list(victim.rglob("*"))  # tiles were written there before
    assert not [p for p in dataset.iterdir() if "usd" in p.name]


def test_links_planted_at_the_names_an_export_writes_are_not_written_through(dataset, tmp_path):
    """The manifest's temporary name, the export's temporary name and the export itself are links
    to the user's files: the export replaces the links, never the files they point to."""
    victims = {name: tmp_path / f"victim-{name}" for name in ("manifest.json.tmp", ".coco.partial", "episodes.h5")}  # fmt: skip
    for name, victim in victims.items():
        victim.write_bytes(b"precious")
        (dataset / name).symlink_to(victim)

    code, _, err = cli("export", dataset, "--to", "coco,hdf5")
    assert code == 0, err
    assert all(victim.read_bytes() == b"precious" for victim in victims.values())
    assert not (dataset / "manifest.json").is_symlink()  # was moved into place before
    assert not (dataset / "episodes.h5").is_symlink() and (dataset / "coco").is_dir()
    assert set(json.loads((dataset / "manifest.json").read_text())["exports"]) == {"coco", "hdf5"}


FORMATS = {"pointcloud": "pointclouds", "coco": "coco", "usd": "usd", "hdf5": "episodes.h5"}


@pytest.mark.parametrize("fmt", list(FORMATS))
def test_an_export_onto_a_full_disk_says_so_and_keeps_nothing(tmp_path_factory, tmp_path, fmt):
    try:
        with small_tmpfs(tmp_path / "disk") as disk:
            root = copy_dataset(tiny_build(tmp_path_factory), disk / "ds")
            stat = os.statvfs(disk)
            (disk / "filler").write_bytes(b"\0" * (stat.f_bavail * stat.f_frsize - 8192))
            before = snapshot(root)

            failed(cli("export", root, "--to", fmt), 1, "disk full", str(root))
            assert snapshot(root) == before  # no output, no partial folder, manifest as it was
    except PermissionError as exc:
        pytest.skip(str(exc))
