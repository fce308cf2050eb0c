"""Convex collision parts of users' meshes (CoACD), decomposed once per machine.

A decomposition takes seconds to minutes a mesh (robosuite's can, 956 faces: 19 s on one core),
and every worker and the coordinator need the same parts. Each is therefore computed once and
kept in ``$XDG_CACHE_HOME/datagen/meshes/convex/`` (else ``~/.cache/...``), named by all that
decides it: the normalised mesh CoACD is given (its vertices and faces: a glTF's separate
buffers count too, a file's comments do not) and :func:`recipe` (CoACD's version and
parameters). Every later process and build reads the entry back, the same float64 values the
decomposition returned, so a sample's bytes do not depend on whether its parts were cached.

Processes starting together share the work: each mesh has a lock (``flock`` on
``<entry>.lock``); a process finding it held goes on to the next mesh and comes back for this
one, reading what the holder wrote. A holder that dies releases its lock, and the next process
decomposes the mesh. An entry is written to a temporary file renamed over its name
(:func:`datagen.library.files.write_file`), so a reader sees a whole entry or none.

An entry is one ``.npy`` array, (points, 4) float64: x, y, z in the normalised mesh's frame and
the index of the part the point belongs to. It is read as untrusted input: a regular file of at
most :data:`MAX_ENTRY_BYTES`, its header checked before any value is read (no pickle), then its
values (finite, inside the normalised mesh's bounds, parts numbered in order with at least 4
points each, at most :data:`MAX_PARTS`). An entry that fails is logged, decomposed again and
replaced.
"""

from __future__ import annotations

import fcntl
import functools
import hashlib
import io
import json
import logging
import os
from dataclasses import dataclass
from importlib.metadata import version
from pathlib import Path

import numpy as np
import trimesh

from datagen.library.files import read_file, write_file
from datagen.user_cache import user_cache

log = logging.getLogger(__name__)
MAX_PARTS = 8  # convex parts per object
COACD_PARAMETERS = {  # coacd.run_coacd's keywords: seeded, so a mesh always gives the same parts
    "threshold": 0.08,
    "max_convex_hull": MAX_PARTS,
    "preprocess_mode": "auto",
    "resolution": 1000,
    "mcts_iterations": 50,
    "mcts_max_depth": 2,
    "seed": 0,
}
ENTRY_FORMAT = "convex-parts/1"  # changes when what an entry holds changes
MAX_ENTRY_BYTES = 2**20  # 8 parts of at most 256 points (CoACD's max_ch_vertex): 64 KiB
MAX_COORDINATE = 1.0  # the normalised mesh lies within +-0.5: a part's point beyond is corrupt
Parts = tuple[np.ndarray, ...]  # each (points, 3) float64, in the normalised mesh's frame
_HEADER_READERS = {1: np.lib.format.read_array_header_1_0, 2: np.lib.format.read_array_header_2_0}


@dataclass(frozen=True)
class Decomposition:
    parts: Parts
    computed: bool  # decomposed by this process (else read from the machine's cache)


def cache_dir() -> Path:
    return user_cache("meshes") / "convex"


@functools.cache
def recipe() -> str:
    """What, besides the mesh, decides its parts."""
    settings = {"format": ENTRY_FORMAT, "coacd": version("coacd"), **COACD_PARAMETERS}
    return json.dumps(settings, sort_keys=True)


def decompose(mesh: trimesh.Trimesh) -> Parts:
    """The convex parts of ``mesh``, computed now; ValueError when there is none."""
    import coacd

    coacd.set_log_level("error")
    mesh_in = coacd.Mesh(np.asarray(mesh.vertices), np.asarray(mesh.faces))
    hulls = tuple(
        np.asarray(v, float) for v, _ in coacd.run_coacd(mesh_in, **COACD_PARAMETERS) if len(v) >= 4
    )
    if not hulls:
        raise ValueError("convex decomposition produced no part")
    return hulls


def decompose_all(meshes: dict[str, trimesh.Trimesh]) -> dict[str, Decomposition | Exception]:
    """The convex parts of each mesh (by name, in the given order), read from the machine's
    cache or decomposed here and cached; the exception instead for a mesh that cannot be
    decomposed. Meshes another process is decomposing are taken last, once it is done."""
    found: dict[str, Decomposition | Exception] = {}
    held = []
    for name, mesh in meshes.items():
        outcome = _outcome(mesh, wait=False)
        if outcome is None:
            held.append(name)
        else:
            found[name] = outcome
    for name in held:
        found[name] = _outcome(meshes[name], wait=True)
    return {name: found[name] for name in meshes}


def _outcome(mesh: trimesh.Trimesh, wait: bool) -> Decomposition | Exception | None:
    """None: another process holds the mesh's lock (only when not ``wait``)."""
    try:
        return _cached_or_decomposed(mesh, wait)
    except Exception as exc:  # a mesh CoACD fails on, of any kind, is reported, never fatal
        return exc


def _cached_or_decomposed(mesh: trimesh.Trimesh, wait: bool) -> Decomposition | None:
    name = f"{entry_key(mesh)}.npy"
    if (parts := _read_entry(name, quiet=False)) is not None:
        return Decomposition(parts, computed=False)
    try:
        lock = _lock(cache_dir() / f"{name}.lock", wait)
    except OSError as exc:  # no cache on this machine (a read-only home, ...): decomposed here
        log.warning("convex parts not cached (%s): each process decomposes its meshes", exc)
        return Decomposition(decompose(mesh), computed=True)
    if lock is None:
        return None
    try:
        if (parts := _read_entry(name, quiet=True)) is not None:  # written while we waited
            return Decomposition(parts, computed=False)
        parts = decompose(mesh)
        try:
            write_file(cache_dir(), name, entry_bytes(parts))
        except (OSError, ValueError) as exc:  # a full disk: the parts are right, only not kept
            log.warning("convex parts not cached in %s: %s", cache_dir(), exc)
        return Decomposition(parts, computed=True)
    finally:
        os.close(lock)


def entry_key(mesh: trimesh.Trimesh) -> str:
    """The name of the mesh's entry: a digest of the mesh CoACD is given and the recipe."""
    digest = hashlib.sha256(recipe().encode())
    for array in (np.asarray(mesh.vertices, "<f8"), np.asarray(mesh.faces, "<i8")):
        digest.update(repr(array.shape).encode())
        digest.update(np.ascontiguousarray(array).tobytes())
    return digest.hexdigest()[:32]


def _lock(path: Path, wait: bool) -> int | None:
    """A descriptor holding ``flock`` on ``path`` (closing it unlocks), or None when another
    process holds it and ``wait`` is false."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW | os.O_CLOEXEC, 0o644)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX if wait else fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        os.close(fd)
        return None
    except BaseException:
        os.close(fd)
        raise
    return fd


def _read_entry(name: str, quiet: bool) -> Parts | None:
    """The parts of the cache entry ``name``; None when there is none or it is unusable (logged
    unless ``quiet``)."""
    if not os.path.lexists(cache_dir() / name):
        return None
    try:
        data = read_file(cache_dir(), name, max_bytes=MAX_ENTRY_BYTES)
    except (OSError, ValueError) as exc:  # a link, a folder, too big, unreadable
        if not quiet:
            log.warning("convex parts entry %s unusable (%s): decomposing again", name, exc)
        return None
    try:
        return parts_of_entry(data)
    except ValueError as exc:
        if not quiet:
            log.warning("convex parts entry %s unusable (%s): decomposing again", name, exc)
        return None


def entry_bytes(parts: Parts) -> bytes:
    """``parts`` as an entry: one (points, 4) float64 ``.npy`` array, x, y, z and part index."""
    table = np.concatenate(
        [np.column_stack([p, np.full(len(p), float(i))]) for i, p in enumerate(parts)]
    )
    buffer = io.BytesIO()
    np.save(buffer, np.ascontiguousarray(table, "<f8"), allow_pickle=False)
    return buffer.getvalue()


def parts_of_entry(data: bytes) -> Parts:
    """The parts an entry holds; ValueError saying what is wrong with it."""
    stream = io.BytesIO(data)
    try:
        major, _ = np.lib.format.read_magic(stream)
        shape, fortran, dtype = _HEADER_READERS[major](stream)
    except (ValueError, KeyError, EOFError) as exc:
        raise ValueError(f"not a .npy array ({exc!r:.100})") from None
    if dtype != np.dtype("<f8") or fortran or len(shape) != 2 or shape[1] != 4:
        raise ValueError(f"expected a (points, 4) float64 array, got {shape} {dtype}")
    if stream.tell() + 32 * shape[0] != len(data):
        raise ValueError(f"{len(data)} bytes, not those of {shape[0]} points")
    if shape[0] < 4:
        raise ValueError(f"{shape[0]} points, fewer than a part has")
    table = np.frombuffer(data, "<f8", offset=stream.tell()).reshape(shape)
    points, labels = table[:, :3], table[:, 3]
    if not np.isfinite(table).all() or np.abs(points).max() > MAX_COORDINATE:
        raise ValueError(f"points not finite or beyond +-{MAX_COORDINATE}")
    steps = np.diff(labels)
    if labels[0] != 0 or not np.isin(steps, (0.0, 1.0)).all() or labels[-1] >= MAX_PARTS:
        raise ValueError(f"part indices not 0, 1, ... in order, below {MAX_PARTS}")
    parts = tuple(np.array(p) for p in np.split(points, np.flatnonzero(steps) + 1))
    if min(len(p) for p in parts) < 4:
        raise ValueError("a part of fewer than 4 points")
    return parts
