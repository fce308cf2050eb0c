"""Rewriting a closed shard without some of its samples, atomically: ``remove_keys``. Used by
crash recovery (samples not the bytes journalled, ``datagen.writer.journal``) and by finalize
(copies a smaller writer id also holds, ``datagen.writer.finalize``)."""

from __future__ import annotations

import os
from pathlib import Path

from datagen.shard_members import scan_members
from datagen.shards import ShardInfo, fsync_dir, member_key, read_shard
from datagen.writer.tar_end import end_of_archive, zip_clear_padding


def remove_keys(path: Path, keys: set[str]) -> ShardInfo | None:
    """Rewrites the closed shard ``path`` without the samples in ``keys`` (new tar next to it,
    fsync, rename over it, fsync the dir); deletes it when nothing is left (returns None)."""
    members = scan_members(path)
    kept = [m for m in members if member_key(m.name) not in keys]
    out = path.parent
    if not kept:
        path.unlink()
        fsync_dir(out)
        return None
    tmp = out / f".{path.name}.rewrite"
    with open(path, "rb") as src, open(tmp, "w+b") as dst:
        for m in kept:
            src.seek(m.offset)
            left = m.end - m.offset
            while left:
                chunk = src.read(min(left, 1 << 20))
                if not chunk:
                    raise OSError(f"{path.name}: shorter than its headers say")
                dst.write(chunk)
                left -= len(chunk)
        dst.write(end_of_archive(dst.tell()))
        dst.write(zip_clear_padding(dst))  # leaves the position at the end
        dst.flush()
        os.fsync(dst.fileno())
    info = read_shard(tmp).info(path.name)  # read back: the digests are of what is on disk
    os.replace(tmp, path)
    fsync_dir(out)
    return info
