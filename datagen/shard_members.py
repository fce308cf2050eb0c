"""A shard's tar members, read from the USTAR headers directly (about 15x faster than
``tarfile`` on 10^5 samples): ``scan_members`` stops quietly at a truncated or damaged tail (a
shard being written, or cut by a crash).

A dataset is untrusted input: ``read_members`` and ``members_in`` (``datagen.shards.read_shard``
and every reader use them) open regular files only (``open_regular``) and accept members that
are sample parts only (``member_problem``, ``_check``); anything else is a ``DatasetError``
naming the shard and the member.
"""

from __future__ import annotations

import logging
import os
import stat
import tarfile
import zlib
from pathlib import Path
from typing import NamedTuple

from datagen.errors import DatasetError
from datagen.sample import KEY_DIGITS, valid_part_name

log = logging.getLogger(__name__)


class Member(NamedTuple):
    """A regular file in a tar: its name, where its header starts, its data, and where the next
    header starts (``end``)."""

    name: str
    offset: int
    offset_data: int
    size: int
    end: int


_ZERO_BLOCK = tarfile.NUL * tarfile.BLOCKSIZE
MAX_MEMBER_BYTES = 2**30  # 4x the largest sample a build sends (transfer.max_sample_mb <= 256)
_TYPES = {
    b"1": "a hard link",
    b"2": "a symbolic link",
    b"3": "a character device",
    b"4": "a block device",
    b"5": "a directory",
    b"6": "a FIFO",
    b"7": "a contiguous file",
    b"S": "a sparse file",
    b"x": "a pax extended header",
    b"g": "a pax global header",
    b"L": "a GNU long name",
    b"K": "a GNU long link name",
}


def _padded(size: int) -> int:
    return -(-size // tarfile.BLOCKSIZE) * tarfile.BLOCKSIZE


class _NotPlainUstar(Exception):
    pass


def _parse_header(block: bytes) -> tuple[str, int, bytes]:
    """(name, size, type flag) of a USTAR header; ValueError if damaged, _NotPlainUstar if its
    size is base-256 (8 GiB or more)."""
    stored = int(block[148:156].split(b"\0", 1)[0].strip() or b"-1", 8)
    # The header checksum is the byte sum with its own field read as spaces. Adler-32's low half
    # is (1 + byte sum) mod 65521, computed in C: comparing modulo 65521 is 5x faster than sum().
    byte_sum = stored + sum(block[148:156]) - 8 * 32
    if (1 + byte_sum) % 65521 != zlib.adler32(block) & 0xFFFF:
        raise ValueError("bad header checksum")
    name = block[:100].split(b"\0", 1)[0].decode("utf-8")
    prefix = block[345:500].split(b"\0", 1)[0].decode("utf-8")
    if block[124] & 0x80:
        raise _NotPlainUstar(f"{prefix}/{name}" if prefix else name)
    size = int(block[124:136].split(b"\0", 1)[0].strip() or b"0", 8)
    kind = b"0" if block[156:157] == b"\0" else block[156:157]
    return (f"{prefix}/{name}" if prefix else name), size, kind


def member_problem(name: str) -> str | None:
    """Why a tar member's name is not that of a sample's part, ``KEY.PART`` (KEY: the
    ``KEY_DIGITS`` digits of ``sample_key``; PART: ``valid_part_name``), or None."""
    if name.startswith("/"):
        return "is an absolute path"
    if ".." in name.split("/"):
        return "is a path with '..'"
    key, _, part = name.partition(".")
    if len(key) != KEY_DIGITS or not (key.isascii() and key.isdigit()) or not valid_part_name(part):
        return f"is not KEY.PART (KEY: {KEY_DIGITS} digits, PART: a part name such as rgb.png)"
    return None


def _check(path: Path, name: str, size: int, kind: bytes, max_bytes: int) -> None:
    """DatasetError naming the shard and the member unless it is a sample's part: a regular file
    in a plain USTAR header (datagen writes no pax or GNU headers) of at most ``max_bytes``."""
    shown = repr(name[:200])
    if kind != b"0":
        what = _TYPES.get(kind, f"of tar type {kind!r}")
        raise DatasetError(f"{path}: member {shown} is {what}; a shard holds regular files only")
    if problem := member_problem(name):
        raise DatasetError(f"{path}: member {shown} {problem}")
    if size > max_bytes:
        raise DatasetError(f"{path}: member {shown} declares {size} bytes, more than {max_bytes}")


def scan_members(path: str | Path) -> list[Member]:
    """Regular-file members of a tar, in order, their names unchecked; stops quietly at a
    truncated or damaged tail (a shard being written, or cut by a crash)."""
    path = Path(path)
    try:
        with open(path, "rb", buffering=0) as f:
            return members_in(path, f.fileno(), None)
    except _NotPlainUstar:
        return _scan_with_tarfile(path)


def read_members(path: str | Path, max_member_bytes: int = MAX_MEMBER_BYTES) -> list[Member]:
    """The members of a dataset's shard, each checked to be a sample's part (``member_problem``)
    and a regular file of at most ``max_member_bytes``: DatasetError naming the shard and the
    member otherwise, or if the shard is not a regular file (``open_regular``)."""
    path = Path(path)
    fd = open_regular(path)
    try:
        return members_in(path, fd, max_member_bytes)
    finally:
        os.close(fd)


def members_in(path: Path, fd: int, max_bytes: int | None) -> list[Member]:
    """The members of the open shard ``fd``, from the USTAR headers, ``tarfile`` never involved;
    with ``max_bytes`` every member is checked (``_check``), else _NotPlainUstar where
    ``tarfile`` must read on."""
    members: list[Member] = []
    length, offset = os.fstat(fd).st_size, 0
    while offset + tarfile.BLOCKSIZE <= length:
        block = os.pread(fd, tarfile.BLOCKSIZE, offset)
        if block == _ZERO_BLOCK:
            break
        try:
            name, size, kind = _parse_header(block)
        except (ValueError, UnicodeDecodeError) as exc:
            log.warning("%s: stopped reading at a damaged header (%s)", path.name, exc)
            break
        except _NotPlainUstar as exc:  # a base-256 size
            if max_bytes is None:
                raise
            shown = repr(str(exc)[:200])
            raise DatasetError(f"{path}: member {shown} declares 8 GiB or more") from None
        if max_bytes is not None:
            _check(path, name, size, kind, max_bytes)
        elif kind != b"0":
            raise _NotPlainUstar
        end = offset + tarfile.BLOCKSIZE + _padded(size)
        if end > length:
            break
        members.append(Member(name, offset, offset + tarfile.BLOCKSIZE, size, end))
        offset = end
    return members


def _scan_with_tarfile(path: Path) -> list[Member]:
    members: list[Member] = []
    try:
        with tarfile.open(path, "r:") as tar:
            for m in tar:
                if m.isfile():
                    end = m.offset_data + _padded(m.size)
                    members.append(Member(m.name, m.offset, m.offset_data, m.size, end))
    except (tarfile.TarError, OSError) as exc:
        log.warning("%s: stopped reading at a damaged tail (%s)", path.name, exc)
    return members


_KINDS = {
    stat.S_IFDIR: "a directory",
    stat.S_IFIFO: "a FIFO",
    stat.S_IFCHR: "a character device",
    stat.S_IFBLK: "a block device",
    stat.S_IFSOCK: "a socket",
}


def open_regular(path: Path) -> int:
    """A read-only descriptor of ``path`` if it is a regular file (a link to one is followed);
    DatasetError naming it otherwise. A FIFO or a device is never opened (that could block or
    never end), and the file is checked again once open. FileNotFoundError if there is none."""
    mode = os.stat(path).st_mode
    if stat.S_ISREG(mode):
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_NOCTTY)
        mode = os.fstat(fd).st_mode
        if stat.S_ISREG(mode):
            return fd
        os.close(fd)
    what = _KINDS.get(stat.S_IFMT(mode), "not a file")
    link = f" (a link to {os.readlink(path)!r})" if os.path.islink(path) else ""
    raise DatasetError(f"{path}: {what}{link}, not a regular file")
