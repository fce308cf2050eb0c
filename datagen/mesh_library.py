"""Users' own object meshes: ``objects.source: folder`` with ``objects.assets_dir: DIR``.

``DIR/<class name>/<mesh file>``: OBJ, STL, PLY, GLB/GLTF (trimesh) or USD (.usd, .usda, .usdc,
usd-core). Each mesh is centred on its bounding box and scaled so its largest extent is 1; a
sample scales it to a size drawn from ``objects.size``. Collision shapes come from a convex
decomposition (CoACD, seeded, so the same file always gives the same parts). A file that cannot
be read, is empty, has non-finite or degenerate geometry, or fails to decompose is skipped and
reported, never fatal; the build fails only if no mesh at all is usable.
"""

from __future__ import annotations

import functools
import hashlib
import logging
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import trimesh

log = logging.getLogger(__name__)
MESH_SUFFIXES = {".obj", ".stl", ".ply", ".glb", ".gltf", ".usd", ".usda", ".usdc"}
MAX_PARTS = 8  # convex parts per object
MIN_EXTENT = 1e-6  # metres (before normalisation): smaller is degenerate


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
            faces += [[indices[start], indices[start + k], indices[start + k + 1]] for k in range(1, n - 1)]  # fmt: skip
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


def convex_parts(mesh: trimesh.Trimesh) -> tuple[np.ndarray, ...]:
    import coacd

    coacd.set_log_level("error")
    parts = coacd.run_coacd(
        coacd.Mesh(np.asarray(mesh.vertices), np.asarray(mesh.faces)),
        threshold=0.08, max_convex_hull=MAX_PARTS, preprocess_mode="auto", resolution=1000,
        mcts_iterations=50, mcts_max_depth=2, seed=0,
    )  # fmt: skip
    hulls = tuple(np.asarray(v, float) for v, _ in parts if len(v) >= 4)
    if not hulls:
        raise ValueError("convex decomposition produced no part")
    return hulls


@functools.lru_cache(maxsize=4)
def load_library(root: str) -> AssetLibrary:
    """Scans ``root`` once per process (sorted, so every worker sees the same library)."""
    base = Path(root)
    library = AssetLibrary(base)
    for path in sorted(p for p in base.rglob("*") if p.is_file()):
        relative = path.relative_to(base).as_posix()
        if path.suffix.lower() not in MESH_SUFFIXES:
            if path.suffix.lower() not in {".mtl", ".png", ".jpg", ".bin", ".txt", ".md"}:
                library.skipped.append((relative, f"not a mesh file ({path.suffix or 'no suffix'})"))  # fmt: skip
            continue
        if len(path.relative_to(base).parts) < 2:
            library.skipped.append((relative, "not in a class folder (DIR/<class>/<file>)"))
            continue
        try:
            mesh = _normalised(load_mesh(path))
            parts = convex_parts(mesh)
        except Exception as exc:  # a broken file of any kind is reported, never fatal
            library.skipped.append((relative, f"{type(exc).__name__}: {exc}"[:300]))
            continue
        digest = hashlib.sha256(path.read_bytes()).hexdigest()
        library.assets.append(Asset(path.relative_to(base).parts[0], relative, digest, mesh, parts))
    for relative, reason in library.skipped:
        log.warning("asset %s skipped: %s", relative, reason)
    if not library.assets:
        found = "; ".join(f"{p}: {r}" for p, r in library.skipped[:10]) or "no files"
        raise AssetError(f"{base}: no usable mesh in DIR/<class>/<file> ({found})")
    return library
