"""Real datasets made hostile: real grasp samples (rendered once per test session) written as a
build writes them, shards rewritten with crafted tar members, and the manifest re-signed from
the shards as they now are, the way an attacker makes a forged dataset self-consistent (so that
only the crafted content is wrong). Re-signing reads the tars with ``tarfile`` (regular members
only), not with datagen's reader."""

from __future__ import annotations

import contextlib
import copy
import gc
import hashlib
import io
import json
import os
import shutil
import subprocess
import tarfile
from collections.abc import Callable
from pathlib import Path

from conftest import write_dataset  # tests/conftest.py: shards and a manifest, no MQTT

from adversarial.grasp_dataset import grasp_samples, write_grasp_dataset
from datagen.shards import keys_sha256, sample_sha256

_BUILT: dict[str, Path] = {}

Members = list[tuple[tarfile.TarInfo, bytes]]


def tiny_build(tmp_path_factory) -> Path:
    """The real grasp samples of ``grasp_dataset`` (rendered once per session) as a finalized
    dataset, one sample per shard (``shard-0-000000.tar``: 000000000, ``shard-0-000001.tar``:
    000000001), with the scene, classes and config in its manifest; copy it before changing it."""
    if "ds" not in _BUILT:
        out = tmp_path_factory.mktemp("tiny-build") / "ds"
        one_per_shard = lambda out, samples, shard_size: write_dataset(out, samples, 1)  # noqa: E731
        _BUILT["ds"] = write_grasp_dataset(out, list(grasp_samples()), one_per_shard)
    return _BUILT["ds"]


def copy_dataset(source: Path, dest: Path) -> Path:
    return Path(shutil.copytree(source, dest))


def members_of(shard: Path) -> Members:
    with tarfile.open(shard) as tar:
        return [(m, tar.extractfile(m).read()) for m in tar]


def rewrite_shard(
    shard: Path, change: Callable[[Members], Members], fmt: int = tarfile.USTAR_FORMAT
) -> None:
    """The shard written again with the members ``change`` returns (data ignored where the
    member's type holds none)."""
    members = change(members_of(shard))
    with tarfile.open(shard, "w", format=fmt) as tar:
        for info, data in members:
            tar.addfile(info, io.BytesIO(data) if info.isreg() else None)


def renamed(info: tarfile.TarInfo, name: str) -> tarfile.TarInfo:
    changed = copy.copy(info)
    changed.name = name
    return changed


def special(name: str, kind: bytes, linkname: str = "") -> tarfile.TarInfo:
    """A member of tar type ``kind`` (tarfile.SYMTYPE, LNKTYPE, FIFOTYPE, CHRTYPE, ...)."""
    info = tarfile.TarInfo(name)
    info.type = kind
    info.linkname = linkname
    info.mode = 0o644
    if kind == tarfile.CHRTYPE:
        info.devmajor, info.devminor = 1, 5  # /dev/zero
    return info


def resign(root: Path) -> None:
    """Every shard record (sha256, bytes, samples, sample_sha256), ``samples`` and
    ``keys_sha256`` recomputed from the shards on disk (regular members; key = the name up to
    its first dot)."""
    manifest_path = root / "manifest.json"
    manifest = json.loads(manifest_path.read_text())
    keys: list[str] = []
    for record in manifest["shards"]:
        path = root / record["name"]
        digests = _sample_digests(path)
        record.update(
            sha256=hashlib.sha256(path.read_bytes()).hexdigest(),
            bytes=path.stat().st_size,
            samples=len(digests),
            sample_sha256=digests,
        )
        keys += digests
    manifest.update(samples=len(keys), keys_sha256=keys_sha256(keys))
    manifest_path.write_text(json.dumps(manifest, indent=2, sort_keys=True))


def _sample_digests(shard: Path) -> dict[str, str]:
    samples: dict[str, list[tuple[str, bytes]]] = {}
    with tarfile.open(shard) as tar:
        for m in tar:
            if m.isfile():
                key, _, part = m.name.partition(".")
                samples.setdefault(key, []).append((part, tar.extractfile(m).read()))
    return {key: sample_sha256(parts) for key, parts in samples.items()}


def snapshot(root: Path) -> dict[str, str]:
    """Every path under ``root`` (links not followed) with its content's digest."""
    found = {}
    for p in sorted(root.rglob("*")):
        if p.is_symlink() or not p.is_file():
            found[str(p)] = "link" if p.is_symlink() else ""
        else:
            found[str(p)] = hashlib.sha256(p.read_bytes()).hexdigest()
    return found


@contextlib.contextmanager
def small_tmpfs(mount_point: Path, size: str = "1m"):
    """A tmpfs of ``size`` mounted at ``mount_point`` (root only; the caller skips otherwise)."""
    mount_point.mkdir(parents=True, exist_ok=True)
    mount = ["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(mount_point)]
    if os.geteuid() != 0 or subprocess.run(mount, capture_output=True).returncode != 0:
        raise PermissionError(f"cannot mount a tmpfs at {mount_point}")
    try:
        yield mount_point
    finally:
        gc.collect()  # a dataset object still open in this process holds its shards
        subprocess.run(["umount", "--lazy", str(mount_point)], check=True)
