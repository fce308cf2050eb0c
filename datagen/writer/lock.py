"""The writer lock: keeps two processes with the same writer id off one directory.

Several writers may share one directory (distinct writer ids).
"""

from __future__ import annotations

import errno
import fcntl
import os
from pathlib import Path


class WriterLocked(RuntimeError):
    """Another process already runs this writer id on this directory."""


class WriterLock:
    """``flock`` on ``.writer-{id}.lock`` in the out dir, held while the writer runs (also works
    across machines on NFSv4, where Linux maps ``flock`` to NFS byte-range locks)."""

    def __init__(self, out_dir: str | Path, writer_id: str):
        self.path = Path(out_dir) / f".writer-{writer_id}.lock"
        fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as exc:
            holder = os.pread(fd, 200, 0).decode(errors="replace").strip() or "?"
            os.close(fd)
            if exc.errno not in (errno.EAGAIN, errno.EACCES):
                raise
            raise WriterLocked(
                f"writer {writer_id!r} is already running on {Path(out_dir)} ({holder} holds "
                f"{self.path.name}); give each writer its own --writer-id"
            ) from None
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"pid {os.getpid()} on {os.uname().nodename}\n".encode(), 0)
        self._fd: int | None = fd

    def __enter__(self) -> WriterLock:
        return self

    def __exit__(self, *exc) -> None:
        self.release()

    def release(self, remove: bool = False) -> None:
        """Unlocks; ``remove`` also deletes the file (after a finished build)."""
        if self._fd is None:
            return
        if remove:
            self.path.unlink(missing_ok=True)
        os.close(self._fd)
        self._fd = None
