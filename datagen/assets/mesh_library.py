"""Users' own object meshes: ``objects.source: folder`` with ``objects.assets_dir: DIR``.

``DIR/<class name>/<mesh file>``: OBJ, STL, PLY, GLB/GLTF (trimesh) or USD (.usd, .usda, .usdc,
usd-core). Each mesh is centred on its bounding box and scaled so its largest extent is 1; a
sample scales it to a size drawn from ``objects.size``. Collision shapes come from a convex
decomposition (CoACD, seeded, so the same file always gives the same parts), computed once per
machine and shared by every process (:mod:`datagen.assets.mesh_decomposition`). A file that
cannot be read, is empty, has non-finite or degenerate geometry, or fails to decompose is
skipped and reported, never fatal; the build fails only if no mesh at all is usable. A mesh with more faces
than ``objects.max_mesh_faces`` is refused before anything starts (config validation,
:func:`oversized_meshes`): its decomposition would take minutes in every worker; so is a mesh with
a non-finite vertex coordinate or one beyond ``MAX_COORDINATE`` (:func:`out_of_range_meshes`):
normalised, it would collapse into a point or a needle.
"""

from __future__ import annotations

import functools
import hashlib
import json
import logging
import struct
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import trimesh

from datagen.assets.image_library import machine_free
from datagen.assets.mesh_decomposition import cache_dir, decompose_all

log = logging.getLogger(__name__)
MESH_SUFFIXES = {".obj", ".stl", ".ply", ".glb", ".gltf", ".usd", ".usda", ".usdc"}
MIN_EXTENT = 1e-6  # metres (before normalisation): smaller is degenerate
MAX_COORDINATE = 1e6  # file units (metres, millimetres, ...): farther is no object's vertex


class AssetError(ValueError):
    """No usable mesh in the folder; the text says what was found and why it was skipped."""


@dataclass(frozen=True)
class Asset:
    class_name: str
    path: str  # relative to the assets folder
    sha256: str
    visual: trimesh.Trimesh  # normalised: centred, largest extent 1
    parts: tuple[np.ndarray, ...]  # convex parts' vertices, normalised like the visual


@dataclass
class AssetLibrary:
    root: Path
    assets: list[Asset] = field(default_factory=list)
    skipped: list[tuple[str, str]] = field(default_factory=list)  # (relative path, reason)
    decomposed: list[str] = field(default_factory=list)  # by this process, not read from the cache

    def find(self, path: str) -> Asset | None:
        return next((a for a in self.assets if a.path == path), None)

    @property
    def classes(self) -> list[str]:
        return sorted({a.class_name for a in self.assets})

    def report(self) -> dict:
        return {
            "classes": self.classes,
            "meshes": [
                {"class": a.class_name, "path": a.path, "sha256": a.sha256} for a in self.assets
            ],
            "skipped": [{"path": p, "reason": r} for p, r in self.skipped],
        }


def _usd_mesh(path: Path) -> trimesh.Trimesh:
    from pxr import Usd, UsdGeom

    stage = Usd.Stage.Open(str(path))
    if stage is None:
        raise ValueError("usd-core could not open it")
    meshes = []
    for prim in stage.Traverse():
        if not prim.IsA(UsdGeom.Mesh):
            continue
        mesh = UsdGeom.Mesh(prim)
        points = np.asarray(mesh.GetPointsAttr().Get() or [], float)
        counts = list(mesh.GetFaceVertexCountsAttr().Get() or [])
        indices = list(mesh.GetFaceVertexIndicesAttr().Get() or [])
        faces, start = [], 0
        for n in counts:  # fan-triangulate polygons
            faces += [
                [indices[start], indices[start + k], indices[start + k + 1]]
                for k in range(1, n - 1)
            ]
            start += n
        to_world = np.asarray(UsdGeom.Xformable(prim).ComputeLocalToWorldTransform(0)).T
        if len(points) and faces:
            meshes.append(trimesh.Trimesh(points, faces, process=False).apply_transform(to_world))
    if not meshes:
        raise ValueError("no UsdGeom.Mesh with faces")
    return trimesh.util.concatenate(meshes)


def load_mesh(path: Path) -> trimesh.Trimesh:
    """One triangle mesh from a file (all its meshes merged); raises ValueError if unusable."""
    if path.suffix.lower() in {".usd", ".usda", ".usdc"}:
        mesh = _usd_mesh(path)
    else:
        mesh = trimesh.load(str(path), force="mesh")
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        raise ValueError("no triangles")
    if not np.isfinite(mesh.vertices).all():
        raise ValueError("non-finite vertex coordinates")
    if mesh.extents.max() < MIN_EXTENT:
        raise ValueError(f"degenerate: largest extent {mesh.extents.max():.3g}")
    return mesh


def _normalised(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    mesh = mesh.copy()
    mesh.apply_translation(-mesh.bounds.mean(axis=0))
    mesh.apply_scale(1.0 / mesh.extents.max())
    return mesh


def face_count(path: Path) -> int:
    """The faces a mesh file holds, read cheaply: from the header (binary STL, PLY, GLB/GLTF
    accessors) or by counting face records (OBJ, ASCII STL) without parsing the geometry; USD
    stages are opened and their face counts summed. Raises ValueError if it cannot tell."""
    suffix = path.suffix.lower()
    if suffix == ".stl":
        size = path.stat().st_size
        with path.open("rb") as f:
            head = f.read(84)
        if len(head) == 84 and size == 84 + 50 * struct.unpack_from("<I", head, 80)[0]:
            return struct.unpack_from("<I", head, 80)[0]  # binary STL: 50 bytes a triangle
        return _count_in_file(path, b"endfacet")
    if suffix == ".obj":
        return _count_in_file(path, b"\nf ", first=b"\n")
    if suffix == ".ply":
        return _ply_faces(path)
    if suffix in (".glb", ".gltf"):
        return _gltf_faces(path)
    from pxr import Usd, UsdGeom

    stage = Usd.Stage.Open(str(path))
    if stage is None:
        raise ValueError("usd-core could not open it")
    prims = [p for p in stage.Traverse() if p.IsA(UsdGeom.Mesh)]
    return sum(len(UsdGeom.Mesh(p).GetFaceVertexCountsAttr().Get() or []) for p in prims)


def _count_in_file(path: Path, token: bytes, first: bytes = b"") -> int:
    count, tail = 0, first
    with path.open("rb") as f:
        while chunk := f.read(16 * 2**20):
            data = tail + chunk
            count += data.count(token)
            tail = data[-(len(token) - 1) :]  # too short to hold a whole token: none counted twice
    return count


def _ply_faces(path: Path) -> int:
    with path.open("rb") as f:
        for _ in range(1000):  # header lines
            words = f.readline(4096).split()
            if words[:2] == [b"element", b"face"] and len(words) == 3:
                return int(words[2])
            if not words or words[0] == b"end_header":
                break
    raise ValueError("no 'element face' line in the PLY header")


def _gltf_faces(path: Path) -> int:
    with path.open("rb") as f:
        head = f.read(20)
        if head[:4] == b"glTF":  # GLB: 12-byte header, then the JSON chunk (length, type, data)
            doc = json.loads(f.read(struct.unpack_from("<I", head, 12)[0]))
        else:
            doc = json.loads(head + f.read())
    accessors = doc.get("accessors", [])
    faces = 0
    for mesh in doc.get("meshes", []):
        for primitive in mesh.get("primitives", []):
            key = primitive.get("indices", primitive.get("attributes", {}).get("POSITION"))
            faces += int(accessors[key]["count"]) // 3 if key is not None else 0
    return faces


def _mesh_files(base: Path) -> list[Path]:
    return sorted(p for p in base.rglob("*") if p.suffix.lower() in MESH_SUFFIXES)


def coordinate_problem(path: Path) -> str | None:
    """Why the vertices of the mesh file ``path`` are unusable (a non-finite coordinate, or one
    beyond ``MAX_COORDINATE``), else None. Reads the file as stored (``process=False``: trimesh
    would otherwise drop non-finite vertices and the faces using them without a word)."""
    if path.suffix.lower() in {".usd", ".usda", ".usdc"}:
        vertices = _usd_mesh(path).vertices
    else:
        vertices = trimesh.load(str(path), force="mesh", process=False).vertices
    vertices = np.asarray(vertices, float)
    if not np.isfinite(vertices).all():
        return "non-finite vertex coordinates (NaN or infinity)"
    largest = float(np.abs(vertices).max(initial=0.0))
    if largest > MAX_COORDINATE:
        return f"a vertex coordinate of {largest:.3g}"
    return None


def out_of_range_meshes(root: str) -> list[tuple[str, str]]:
    """(path relative to ``root``, why) of every mesh file in ``root`` whose vertices are
    unusable (:func:`coordinate_problem`); a file that cannot be read is left to
    :func:`load_library`. Call it after :func:`oversized_meshes`: it parses every file."""
    base, found = Path(root), []
    for path in _mesh_files(base):
        try:
            problem = coordinate_problem(path) if path.is_file() else None
        except Exception as exc:  # an unreadable file of any kind: load_library reports it
            log.debug("vertices of %s unread: %s", path, exc)
            continue
        if problem:
            found.append((path.relative_to(base).as_posix(), problem))
    return found


def oversized_meshes(root: str, max_faces: int) -> list[tuple[str, int]]:
    """(path relative to ``root``, faces) of every mesh file in ``root`` with more than
    ``max_faces`` faces; a file whose count cannot be read is left to :func:`load_library`."""
    base, found = Path(root), []
    for path in _mesh_files(base):
        try:
            faces = face_count(path) if path.is_file() else 0
        except Exception as exc:  # an unreadable file of any kind: load_library reports it
            log.debug("face count of %s unknown: %s", path, exc)
            continue
        if faces > max_faces:
            found.append((path.relative_to(base).as_posix(), faces))
    return found


def _scanned(base: Path) -> dict[str, trimesh.Trimesh | str]:
    """Every file under ``base`` (relative path, in sorted order): its normalised mesh, or the
    reason it is skipped."""
    found: dict[str, trimesh.Trimesh | str] = {}
    for path in sorted(p for p in base.rglob("*") if p.is_file()):
        relative = path.relative_to(base).as_posix()
        if path.suffix.lower() not in MESH_SUFFIXES:
            if path.suffix.lower() not in {".mtl", ".png", ".jpg", ".bin", ".txt", ".md"}:
                found[relative] = f"not a mesh file ({path.suffix or 'no suffix'})"
        elif len(path.relative_to(base).parts) < 2:
            found[relative] = "not in a class folder (DIR/<class>/<file>)"
        else:
            try:
                found[relative] = _normalised(load_mesh(path))
            except Exception as exc:  # a broken file of any kind is reported, never fatal
                found[relative] = machine_free(f"{type(exc).__name__}: {exc}", base)
    return found


@functools.lru_cache(maxsize=4)
def load_library(root: str) -> AssetLibrary:
    """Scans ``root`` once per process (sorted, so every worker sees the same library); the
    convex parts come from the machine's cache where they are in it."""
    base = Path(root)
    library = AssetLibrary(base)
    scanned = _scanned(base)
    decompositions = decompose_all({p: m for p, m in scanned.items() if not isinstance(m, str)})
    for relative, outcome in (scanned | decompositions).items():
        if isinstance(outcome, str):
            library.skipped.append((relative, outcome))
        elif isinstance(outcome, Exception):
            reason = f"{type(outcome).__name__}: {outcome}"
            library.skipped.append((relative, machine_free(reason, base)))
        else:
            digest = hashlib.sha256((base / relative).read_bytes()).hexdigest()
            mesh = scanned[relative]
            class_name = relative.split("/")[0]
            library.assets.append(Asset(class_name, relative, digest, mesh, outcome.parts))
            if outcome.computed:
                library.decomposed.append(relative)
    for relative, reason in library.skipped:
        log.warning("asset %s skipped: %s", relative, reason)
    if not library.assets:
        found = "; ".join(f"{p}: {r}" for p, r in library.skipped[:10]) or "no files"
        raise AssetError(f"{base}: no usable mesh in DIR/<class>/<file> ({found})")
    computed = len(library.decomposed)
    log.info(
        "%s: %d meshes, %d decomposed here, %d read from %s",
        base,
        len(library.assets),
        computed,
        len(library.assets) - computed,
        cache_dir(),
    )
    return library
