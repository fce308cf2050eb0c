"""Whether the checkout's code makes a kept grasp campaign again: the campaign is rebuilt from
the config its manifest keeps, in a temporary folder, and every attempt record is compared.

    .venv/bin/python benchmarks/grasp_rebuild.py CAMPAIGN [--attempts N] [--workers 2]

A change meant to make campaigns faster and leave what they do alone (a collision test, an
execution step) is checked this way: the attempts of the same (seed, index) must come out the
same, byte for byte once serialised. Printed: how many attempt records are identical, and, for
each that is not, its index and the keys that differ. Exits with 1 when any differs.
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
import tempfile
from pathlib import Path

from dr_transfer.building import build


def arguments() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("campaign", type=Path, help="a grasp campaign's folder")
    parser.add_argument("--attempts", type=int, help="the first N attempts only (all)")
    parser.add_argument("--workers", type=int, default=2, help="campaign workers (2)")
    return parser.parse_args()


def attempt_records(root: Path, count: int | None = None) -> list[dict]:
    from datagen.dataset.loader import load

    dataset = load(root)
    try:
        n = len(dataset) if count is None else min(count, len(dataset))
        return [dataset.metadata(i)["attempt"] for i in range(n)]
    finally:
        dataset.close()


def differences(kept: list[dict], made: list[dict]) -> list[tuple[int, list[str]]]:
    """(index, keys whose values differ) of each attempt record that is not the same."""
    out = []
    for i, (old, new) in enumerate(zip(kept, made, strict=True)):
        keys = sorted(
            key
            for key in old.keys() | new.keys()
            if json.dumps(old.get(key), sort_keys=True) != json.dumps(new.get(key), sort_keys=True)
        )
        if keys:
            out.append((i, keys))
    return out


def rebuild(campaign: Path, attempts: int | None, workers: int) -> tuple[int, list]:
    """(attempts compared, differences) of ``campaign`` against its rebuild."""
    from datagen.dataset.manifest import read_manifest

    data = read_manifest(campaign)["config"]
    if attempts is not None:
        data = data | {"num_samples": min(attempts, data["num_samples"])}
    out = Path(tempfile.mkdtemp(prefix="datagen-grasp-rebuild-"))
    try:
        build(f"{campaign}: manifest config", data, out / "campaign", workers)
        made = attempt_records(out / "campaign")
    finally:
        shutil.rmtree(out, ignore_errors=True)
    return len(made), differences(attempt_records(campaign, len(made)), made)


def main() -> int:
    args = arguments()
    count, differ = rebuild(args.campaign, args.attempts, args.workers)
    print(f"{args.campaign.name}: {count - len(differ)} of {count} attempt records identical")
    for index, keys in differ:
        print(f"  attempt {index}: {', '.join(keys)} differ")
    return 1 if differ else 0


if __name__ == "__main__":
    sys.exit(main())
