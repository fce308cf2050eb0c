"""Files of the picture library, which may be a shared folder: read and written only inside it,
never through a link.

A path in the library is relative and made of plain names (letters, digits, ``_``, ``.``, ``-``;
no ``..``, never absolute). A read checks every folder below the root with ``lstat`` (a link is
refused) and opens the file itself without following a link, as a regular file of bounded size
(:func:`datagen.images.read_regular_file`). A write walks the folders by file descriptor, each
opened with ``O_NOFOLLOW`` (a folder swapped for a link during the walk is refused too), writes
a temporary beside the file and renames it over the name: a link found there is replaced, never
written through. The root is the user's: a link on its path is refused only when another user
owns it (one planted in a shared folder), as ``sudo`` and ``ssh`` judge such paths.
"""

from __future__ import annotations

import contextlib
import os
import re
import secrets
import stat
from pathlib import Path

from datagen.images import read_regular_file

_NAME = re.compile(r"[A-Za-z0-9_.-]+")
_FOLDER_FLAGS = os.O_RDONLY | os.O_DIRECTORY | os.O_NOFOLLOW | os.O_CLOEXEC
_NEW_FILE_FLAGS = os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW | os.O_CLOEXEC


class UnsafePath(ValueError):
    """A library path that is not plain and relative, or that passes through a link."""


def parts_of(relative: object) -> tuple[str, ...]:
    """The names of a library path, or UnsafePath saying what a path must be."""
    parts = tuple(relative.split("/")) if isinstance(relative, str) else ()
    if not parts or any(not _NAME.fullmatch(p) or p in {".", ".."} for p in parts):
        raise UnsafePath(
            f"path {relative!r}: expected a path inside the library (plain names of letters, "
            "digits, '_', '.', '-' joined by '/'; no '..', not absolute)"
        )
    return parts


def check_root(root: Path) -> None:
    """UnsafePath if a link on the path of ``root`` (itself included) is owned by another user."""
    mine = {0, os.getuid()}
    for path in [Path(os.path.abspath(root)), *Path(os.path.abspath(root)).parents]:
        try:
            info = os.lstat(path)
        except FileNotFoundError:
            continue
        if stat.S_ISLNK(info.st_mode) and info.st_uid not in mine:
            raise UnsafePath(
                f"{path}: a link owned by another user (uid {info.st_uid}) on the library's "
                f"path: name the folder itself in $DATAGEN_LIBRARY ({os.path.realpath(path)}) "
                "if it is the one you mean"
            )


def check_folder(folder: Path) -> None:
    """UnsafePath if ``folder`` exists and is a link or not a folder."""
    try:
        info = os.lstat(folder)
    except FileNotFoundError:
        return
    if stat.S_ISLNK(info.st_mode):
        raise UnsafePath(
            f"{folder}: a link, not a folder (the library is never read or written through a link)"
        )
    if not stat.S_ISDIR(info.st_mode):
        raise UnsafePath(f"{folder}: not a folder")


def read_file(root: Path, relative: str, *, max_bytes: int) -> bytes:
    """The bytes of the regular file ``relative`` inside ``root`` (no link on the way)."""
    parts = parts_of(relative)
    folder = root
    for name in parts[:-1]:
        folder = folder / name
        check_folder(folder)
    return read_regular_file(folder / parts[-1], max_bytes=max_bytes)


def write_file(root: Path, relative: str, data: bytes) -> None:
    """``data`` at ``relative`` inside ``root``, folders made as needed, atomically."""
    parts = parts_of(relative)
    folder = _open_folders(root, parts[:-1])
    temporary = f".{parts[-1]}.{secrets.token_hex(6)}.partial"
    try:
        with open(os.open(temporary, _NEW_FILE_FLAGS, 0o644, dir_fd=folder), "wb") as out:
            out.write(data)
        os.replace(temporary, parts[-1], src_dir_fd=folder, dst_dir_fd=folder)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(temporary, dir_fd=folder)
        raise
    finally:
        os.close(folder)


def _open_folders(root: Path, names: tuple[str, ...]) -> int:
    """A descriptor of ``root/names...``, each folder made if missing, none through a link."""
    folder = os.open(root, os.O_RDONLY | os.O_DIRECTORY | os.O_CLOEXEC)
    path = root
    for name in names:
        path = path / name
        try:
            with contextlib.suppress(FileExistsError):
                os.mkdir(name, 0o755, dir_fd=folder)
            inner = os.open(name, _FOLDER_FLAGS, dir_fd=folder)
        except OSError:
            check_folder(path)  # says why: a link, or not a folder
            raise
        finally:
            os.close(folder)
        folder = inner
    return folder
