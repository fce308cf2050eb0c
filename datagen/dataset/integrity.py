"""Checking a dataset against its manifest, sample by sample: ``verify_dataset``.

Every listed shard is read once, front to back (``read_shard``: a megabyte in memory at a
time), for its size, its sha256 and each sample's ``sample_sha256``. The result names what is
wrong: shards missing, resized or changed; samples missing (listed, in no shard), extra (in a
shard, not listed), duplicated, or altered (a digest that differs from the manifest's). A
build's own check also requires the keys of its samples 0..N-1. Manifests written before
per-sample digests existed are checked by shard sha256 and keys.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from datagen.dataset.manifest import DatasetError, read_manifest
from datagen.records import Manifest, ShardRecord
from datagen.sample import sample_key
from datagen.shard_members import MAX_MEMBER_BYTES
from datagen.shards import keys_sha256, read_shard, shards_by_writer

SHOWN = 10  # keys named per kind of problem; the count says how many there are
MAX_KEYS_WITHOUT_DIGESTS = 10**7  # samples 0..N-1 checked by key when the manifest has no digests


@dataclass
class Verification:
    """What ``verify_dataset`` found; ``problems`` is empty when the dataset is intact."""

    root: Path
    manifest: Manifest
    per_sample: bool  # the manifest lists a digest per sample
    samples: int = 0  # samples found once, intact
    shards: int = 0
    bytes: int = 0
    seconds: float = 0.0
    problems: list[str] = field(default_factory=list)

    def summary(self) -> str:
        checked = "each sample's sha256" if self.per_sample else "shard sha256 and keys only"
        note = "" if self.per_sample else ": this manifest predates per-sample digests"
        return (
            f"{self.root}: {self.samples} samples in {self.shards} "
            f"shard{'' if self.shards == 1 else 's'} verified "
            f"({checked}{note}), {self.bytes / 2**20:.1f} MiB in {self.seconds:.1f} s"
        )


def verify_dataset(
    root: str | Path,
    expected: int | None = None,
    build_id: str | None = None,
    manifest: Manifest | None = None,
    on_sample: Callable[[], None] | None = None,
) -> Verification:
    """Checks ``root`` against its manifest (``manifest``: already read): each sample it lists,
    once, intact; with ``expected``, exactly the samples 0..expected-1; with ``build_id``, the
    manifest must be that build's. Raises DatasetError only when the manifest cannot be read;
    ``on_sample()`` is called after each sample read."""
    start = time.monotonic()
    root = Path(root)
    manifest = read_manifest(root) if manifest is None else manifest
    records = manifest["shards"]
    report = Verification(root, manifest, all("sample_sha256" in r for r in records))
    count = manifest.get("samples")
    if expected is not None and count != expected:
        report.problems.append(f"the manifest says {count} samples, expected {expected}")
    if build_id is not None and manifest.get("build_id") != build_id:
        report.problems.append(
            f"the manifest is of build {manifest.get('build_id')!r}, not {build_id!r}"
        )
    listed = _listed_digests(records, report) if report.per_sample else {}
    wanted = _wanted(report, listed, expected)
    found: dict[str, list[tuple[str, str]]] = {}  # key -> [(shard, digest)] of every copy
    for record in records:
        for key, digest in _read(root, record, report, on_sample):
            found.setdefault(key, []).append((record["name"], digest))
    _compare(report, wanted, listed, found)
    report.seconds = time.monotonic() - start
    return report


def _wanted(report: Verification, listed: dict[str, str], expected: int | None) -> set[str] | None:
    """The keys the dataset must hold: samples 0..expected-1 when the caller knows how many (a
    build), else those the manifest lists; None if it lists none and its ``keys_sha256`` is not
    that of samples 0..N-1 (then only that digest of the keys found is checked)."""
    if expected is not None:
        return {sample_key(i) for i in range(expected)}
    count, digest = report.manifest.get("samples"), report.manifest.get("keys_sha256")
    if report.per_sample:
        if count is not None and count != len(listed):
            report.problems.append(
                f"the manifest says {count} samples but lists the digests of {len(listed)}"
            )
        return set(listed)
    if (count or 0) > MAX_KEYS_WITHOUT_DIGESTS:  # a forged count: no set of 10^9 keys
        return None
    keys = {sample_key(i) for i in range(count or 0)}
    return keys if digest is None or digest == keys_sha256(keys) else None


def _listed_digests(records: list[ShardRecord], report: Verification) -> dict[str, str]:
    listed: dict[str, str] = {}
    twice: list[str] = []
    for record in records:
        digests = record["sample_sha256"]
        if len(digests) != record.get("samples", len(digests)):
            report.problems.append(
                f"the manifest lists {len(digests)} sample digests for {record['name']}, "
                f"which it says holds {record.get('samples')} samples"
            )
        twice += [key for key in digests if key in listed]
        listed.update(digests)
    if twice:
        report.problems.append(f"listed twice in the manifest {_keys(twice)}")
    return listed


def _keys(keys: list[str]) -> str:
    """``3: 000000001, 000000002, 000000007``, at most SHOWN of them named."""
    more = f" ... ({len(keys) - SHOWN} more)" if len(keys) > SHOWN else ""
    return f"{len(keys)}: {', '.join(keys[:SHOWN])}{more}"


def _read(
    root: Path, record: ShardRecord, report: Verification, on_sample: Callable[[], None] | None
) -> list[tuple[str, str]]:
    """The (key, digest) of each sample in one listed shard; its shard-level problems. A member
    that is no sample's part, or larger than the whole shard as listed, is one (its samples are
    then missing)."""
    name = record["name"]
    path = root / name
    try:
        contents = read_shard(
            path, on_sample, min(MAX_MEMBER_BYTES, record.get("bytes", MAX_MEMBER_BYTES))
        )
    except FileNotFoundError:
        report.problems.append(f"{name}: missing")
        return []
    except OSError as exc:
        report.problems.append(f"{name}: cannot read it: {exc.strerror or exc}")
        return []
    except DatasetError as exc:
        report.problems.append(str(exc))
        return []
    report.shards += 1
    report.bytes += contents.bytes
    if "bytes" in record and contents.bytes != record["bytes"]:
        report.problems.append(f"{name}: {contents.bytes} bytes, manifest says {record['bytes']}")
    if contents.sha256 != record.get("sha256"):
        report.problems.append(f"{name}: sha256 differs from the manifest")
    return contents.samples


def _compare(
    report: Verification,
    wanted: set[str] | None,
    listed: dict[str, str],
    found: dict[str, list[tuple[str, str]]],
) -> None:
    if report.per_sample and wanted is not None and listed.keys() != wanted:
        report.problems.append(
            f"the manifest's sample digests are not those of samples 0..{len(wanted) - 1}: "
            f"{len(wanted - listed.keys())} absent, {len(listed.keys() - wanted)} of other keys"
        )
    count = report.manifest.get("samples")
    if wanted is None and count is not None and count != len(found):
        report.problems.append(f"the manifest says {count} samples, its shards hold {len(found)}")
    wanted = set(found) if wanted is None else wanted
    missing = sorted(wanted - found.keys())
    extra = sorted(found.keys() - wanted)
    duplicated = sorted(k for k, copies in found.items() if len(copies) > 1)
    altered = sorted(
        (key, shard)
        for key, copies in found.items()
        if key in listed
        for shard, digest in copies
        if digest != listed[key]
    )
    for label, keys in (
        ("missing", missing),
        ("extra", extra),
        ("duplicated", duplicated),
        ("altered", [f"{key} ({shard})" for key, shard in altered]),
    ):
        if keys:
            report.problems.append(f"{label} {_keys(keys)}")
    intact = (found.keys() & wanted) - set(duplicated) - {key for key, _ in altered}
    report.samples = len(intact)
    expected_digest = report.manifest.get("keys_sha256")
    if (
        expected_digest is not None
        and not (missing or extra)
        and keys_sha256(found) != expected_digest
    ):
        report.problems.append("keys_sha256 differs from the keys in the shards")
    names = {r["name"] for r in report.manifest["shards"]}
    stray = [p.name for paths in shards_by_writer(report.root).values() for p in paths]
    if stray := sorted(set(stray) - names):
        report.problems.append(f"shards not in the manifest: {', '.join(stray[:SHOWN])}")
