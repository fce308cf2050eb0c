"""The end of a shard: the end-of-archive blocks and record padding ``TarFile.close`` writes, and
then, where needed, more zero records so that the shard is never taken for a zip.

Python's ``zipfile.is_zipfile`` looks for a zip's end-of-central-directory signature in the last
64 KiB + 22 bytes of a file. A shard whose last members hold an ``.npz`` (a zip: a grasp
attempt's ``trajectory.npz``, an aerial episode's ``occupancy.npz``) has one there, and a reader
that tries zip before tar (mlcroissant 1.1.1's extraction) unpacks the npz instead of the shard.
Zero records after the end-of-archive are still the end of a tar: tar readers stop at the first
zero block.
"""

from __future__ import annotations

import os
import tarfile
from typing import BinaryIO

ZIP_SNIFF_BYTES = (1 << 16) + 22  # how far from a file's end zipfile looks (zipfile._EndRecData)
_ZIP_END = b"PK\x05\x06"  # a zip's end-of-central-directory signature


def end_of_archive(offset: int) -> bytes:
    """What ``TarFile.close`` writes after the last member ending at ``offset``: two zero
    blocks, then zeros to the next whole record."""
    end = offset + 2 * tarfile.BLOCKSIZE
    return tarfile.NUL * (2 * tarfile.BLOCKSIZE + (-end) % tarfile.RECORDSIZE)


def zip_clear_padding(f: BinaryIO) -> bytes:
    """The whole zero records to append to the ended tar ``f`` (open for reading) so that no
    zip end-of-central-directory signature lies within its last ``ZIP_SNIFF_BYTES``."""
    size = f.seek(0, os.SEEK_END)
    start = max(size - ZIP_SNIFF_BYTES, 0)
    f.seek(start)
    found = f.read().rfind(_ZIP_END)
    if found < 0:
        return b""
    short = start + found + ZIP_SNIFF_BYTES + 1 - size  # bytes the file must grow by
    return tarfile.NUL * (-(-short // tarfile.RECORDSIZE) * tarfile.RECORDSIZE)
