"""A robot drawn with at most ``render.robot_triangles`` triangles: its mesh-file visuals
simplified once per machine.

Shipped descriptions draw arms with CAD meshes (the Panda: 135,548 triangles, about one per pixel
it covers at 640x480). A CPU renderer pays for every triangle in the camera pass and again in each
shadow pass, and the robot's amodal silhouettes (``sensing/robot_labels.py``) project every
one: together half of a default frame. Each mesh file of a link is read by SAPIEN itself (so its
materials are what SAPIEN would show), each of its parts simplified to its share of the budget
(:mod:`datagen.assets.mesh_simplify`) and written as a GLB file into
``$XDG_CACHE_HOME/datagen/robots/simplified/`` (else ``~/.cache/...``), named by the source file's
bytes and the recipe, so every process and every later build reads the same file. The link's
visual record is replaced by one record per part, the part's material kept. Collision shapes are
untouched: physics is the same. A file with a textured part is kept as it is (a simplified mesh
has no texture coordinates).
"""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import cast

import sapien
import trimesh
from sapien.wrapper.actor_builder import VisualShapeRecord, preprocess_mesh_file
from sapien.wrapper.articulation_builder import ArticulationBuilder

from datagen.assets.mesh_simplify import (
    CREASE_DEG,
    SIMPLIFIER,
    face_budgets,
    simplified_with_normals,
)
from datagen.exports.files import replace_file
from datagen.user_cache import user_cache

KEEP_BELOW = 1000  # triangles: smaller parts (fingers, logos) are kept whole, for close-ups
_TEXTURES = ("base_color_texture", "normal_texture", "roughness_texture", "metallic_texture")


def cache_dir() -> Path:
    return user_cache("robots") / "simplified"


def _textured(part: sapien.render.RenderShapeTriangleMeshPart) -> bool:
    return any(getattr(part.material, name) is not None for name in _TEXTURES)


def _part_file(source: str, index: int, part, max_faces: int) -> Path:
    """Part ``index`` of the mesh file ``source`` simplified to about ``max_faces`` triangles,
    as a GLB file in the cache (written once, atomically: concurrent workers write the same
    bytes, since the simplification is deterministic)."""
    recipe = f"{SIMPLIFIER}|{CREASE_DEG}|{index}|{max_faces}|{trimesh.__version__}".encode()
    digest = hashlib.sha256(Path(source).read_bytes() + recipe).hexdigest()[:20]
    path = cache_dir() / f"{Path(source).stem}-{index}-{max_faces}-{digest}.glb"
    if not path.is_file():
        vertices, faces, normals = simplified_with_normals(part.vertices, part.triangles, max_faces)
        mesh = trimesh.Trimesh(vertices, faces, vertex_normals=normals, process=False)
        data = cast(bytes, mesh.export(file_type="glb", include_normals=True))  # a GLB: bytes
        path.parent.mkdir(parents=True, exist_ok=True)
        replace_file(path, lambda tmp: tmp.write_bytes(data))
    return path


def drawn_triangles(builder: ArticulationBuilder) -> int:
    """Triangles of ``builder``'s mesh-file visuals (primitives are not counted)."""
    return sum(
        len(part.triangles)
        for link in builder.link_builders
        for record in link.visual_records
        if record.type == "file"
        for part in _loaded(record.filename).parts
    )


def _loaded(filename: str) -> sapien.render.RenderShapeTriangleMesh:
    return sapien.render.RenderShapeTriangleMesh(preprocess_mesh_file(filename))


def simplify_visuals(builder: ArticulationBuilder, max_triangles: int) -> None:
    """Replaces, in place, the mesh-file visuals of ``builder``'s links by simplified ones when
    they have more than ``max_triangles`` triangles in all (0: never)."""
    files = [
        (link, record, _loaded(record.filename))
        for link in builder.link_builders
        for record in link.visual_records
        if record.type == "file"
    ]
    total = sum(len(part.triangles) for _, _, shape in files for part in shape.parts)
    if max_triangles <= 0 or total <= max_triangles:
        return
    textured = [any(map(_textured, shape.parts)) for _, _, shape in files]
    simplified = [f for f, kept in zip(files, textured, strict=True) if not kept]
    fixed = sum(
        len(part.triangles)
        for (_, _, shape), kept in zip(files, textured, strict=True)
        if kept
        for part in shape.parts
    )
    counts = [len(part.triangles) for _, _, shape in simplified for part in shape.parts]
    budgets = iter(face_budgets(counts, max(max_triangles - fixed, 0), KEEP_BELOW))
    for link, record, shape in simplified:
        source = preprocess_mesh_file(record.filename)
        parts = [
            VisualShapeRecord(
                type="file",
                filename=str(_part_file(source, i, part, next(budgets))),
                scale=record.scale,
                material=part.material,
                pose=record.pose,
                name=record.name,
            )
            for i, part in enumerate(shape.parts)
        ]
        at = link.visual_records.index(record)
        link.visual_records[at : at + 1] = parts
