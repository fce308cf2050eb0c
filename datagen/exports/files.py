"""Where an export writes, and making sure what it wrote is there.

Every file an export writes is named by :func:`inside` (its folder plus names that may come from
the dataset: a key, a camera, a look), which refuses a path that resolves outside that folder.
A library that reports a failed write by returning False is checked with :func:`written`, and
:func:`disk_full` tells an ENOSPC (or a full disk behind a library's False) from other errors,
so that the runner can say "disk full" and keep nothing.

The tools write their default outputs inside the dataset the same way: :func:`tool_folder` is a
tool's folder there (``inspect/``), refused when it is a link or resolves outside the dataset, and
:func:`replace_file` writes a file under a new temporary name beside it and renames that into
place, so that a link planted at the name is replaced, never written through.
"""

from __future__ import annotations

import errno
import io
import os
import secrets
from collections.abc import Callable
from pathlib import Path

from datagen.dataset.manifest import DatasetError

LOW_SPACE_BYTES = 2**20  # free space below which a failed write is put down to a full disk


def inside(folder: Path, *names: str) -> Path:
    """``folder/names...``; DatasetError unless its folder resolves to ``folder`` or a folder in
    it (an absolute name, a ``..`` or a link leading elsewhere is refused). Its last name is not
    followed: whatever is there is replaced (an export writes into a folder it made)."""
    path = folder.joinpath(*names)
    base, parent = folder.resolve(), path.parent.resolve()
    if path.name in ("", ".", "..") or not parent.is_relative_to(base):
        raise DatasetError(f"{folder}: refusing to write {str(path)[:300]!r}, outside this folder")
    return path


def tool_folder(dataset: Path, name: str) -> Path:
    """``dataset/name``, a tool's default output folder inside the dataset, made if missing;
    DatasetError if it is a symbolic link or not a folder, or resolves outside ``dataset`` (a
    link planted in a dataset must not carry the tool's files elsewhere)."""
    path = inside(dataset, name)
    if path.is_symlink():
        raise DatasetError(
            f"{path}: refusing to write into it: it is a symbolic link (to "
            f"{os.readlink(path)[:200]!r}), not a folder of this dataset; remove it"
        )
    if not path.exists():
        path.mkdir()
    if (
        path.is_symlink()
        or not path.is_dir()
        or not path.resolve().is_relative_to(dataset.resolve())
    ):
        raise DatasetError(f"{path}: refusing to write into it: not a folder of this dataset")
    return path


def replace_file(path: Path, write: Callable[[Path], object]) -> Path:
    """``path`` written by ``write(tmp)`` into a new file beside it (``.NAME.*.partial.SUFFIX``:
    a library picks the format by the suffix), then renamed onto ``path``: whatever is at
    ``path`` (a link planted there included) is replaced, never followed or written through. A
    failed write leaves nothing and ``path`` as it was."""
    tmp = path.with_name(f".{path.name}.{secrets.token_hex(4)}.partial{path.suffix}")
    os.close(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o666))
    try:
        write(tmp)
        try:
            os.replace(tmp, path)
        except OSError as exc:  # a folder at the name, say: the error names it, not tmp
            raise OSError(exc.errno, exc.strerror, str(path)) from None
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return path


def written(ok: bool, path: Path, writer: str) -> None:
    """Raises OSError (ENOSPC on a full disk) when ``writer`` returned False for ``path``."""
    if not ok:
        code = errno.ENOSPC if _low_space(path) else errno.EIO
        raise OSError(code, f"{writer} could not write it ({os.strerror(code)})", str(path))


def disk_full(exc: BaseException, path: Path) -> bool:
    """Whether ``exc``, raised while writing under ``path``, comes from a full disk or quota."""
    code = getattr(exc, "errno", None)
    return code in (errno.ENOSPC, errno.EDQUOT) or (
        isinstance(exc, OSError | RuntimeError) and _low_space(path)
    )


def _low_space(path: Path) -> bool:
    for folder in (path, *path.parents):
        try:
            stat = os.statvfs(folder)
        except OSError:
            continue
        return stat.f_bavail * stat.f_frsize < LOW_SPACE_BYTES
    return False


def fsync_tree(path: Path) -> None:
    """Every file and folder under ``path`` (or the file) flushed to disk: an ENOSPC that the
    file system deferred (delayed allocation) is raised here, before anything is renamed."""
    paths = [path, *path.rglob("*")] if path.is_dir() else [path]
    for item in paths:
        if item.is_symlink():
            continue
        fd = os.open(item, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


class FailureRecordingFile(io.RawIOBase):
    """A file for a library that must never see a failed write (HDF5 crashes when it closes a
    file whose writes failed): the first OSError is kept in ``error`` and every write reports
    success; the caller raises ``error`` once the library has closed the file."""

    def __init__(self, path: Path):
        self.file = open(path, "w+b", buffering=0)  # noqa: SIM115 - closed by close()
        self.error: OSError | None = None

    def readable(self) -> bool:
        return True

    def writable(self) -> bool:
        return True

    def seekable(self) -> bool:
        return True

    def seek(self, offset: int, whence: int = io.SEEK_SET) -> int:
        return self.file.seek(offset, whence)

    def tell(self) -> int:
        return self.file.tell()

    def readinto(self, buffer) -> int:
        return self.file.readinto(buffer)

    def write(self, data) -> int:
        size = memoryview(data).nbytes
        if self.error is None:
            try:
                return self.file.write(data)
            except OSError as exc:
                self.error = exc
        self.file.seek(size, io.SEEK_CUR)
        return size

    def truncate(self, size: int | None = None) -> int:
        try:
            return self.file.truncate(size)
        except OSError as exc:
            self.error = self.error or exc
            return self.tell() if size is None else size

    def flush(self) -> None:
        if self.file.closed:
            return
        try:
            os.fsync(self.file.fileno())
        except OSError as exc:
            self.error = self.error or exc

    def close(self) -> None:
        if not self.file.closed:
            self.flush()
            self.file.close()
        super().close()
