"""The copy of a user's URDF that the motion planner loads. mplib 0.1.1 (``convex=True``) loads
each collision mesh from ``<mesh>.convex.stl`` beside it and fails without one ("Could not load
resource"), or with a hull that is not watertight; it writes ``*_package_keyword_replaced.urdf``
beside a URDF naming ``package://`` meshes. The copy, in the cache beside the composed arms
(:func:`datagen.robot_specs.compose.cache_dir`), names every collision mesh by a path relative
to the cache, with its hull (a ``.convex.stl`` of the user's beside the mesh, else one made in
the cache), and has no visual meshes. It is named by a digest of its text, which holds the
digests of the copied meshes: written once, reused until the URDF or a mesh changes, and
nothing is written beside the user's files. SAPIEN still loads the user's URDF."""

from __future__ import annotations

import hashlib
import os
import xml.etree.ElementTree as ET
from pathlib import Path

from datagen.errors import ConfigError
from datagen.robot_specs import RobotSpec
from datagen.robot_specs.compose import cache_dir, planner_mesh, write_once
from datagen.robot_specs.urdf_files import mesh_path
from datagen.robot_specs.urdf_xml import parse_urdf_xml

SHIPPED = ("mani_skill", "datagen", "composed")  # description schemes whose meshes have hulls


def planner_urdf(spec: RobotSpec) -> Path:
    """The URDF mplib plans ``spec`` with: a user's file (a plain path) through
    :func:`planner_copy`, a shipped or composed description as it is."""
    if spec.description.partition(":")[0] in SHIPPED:
        return spec.urdf_path()
    return planner_copy(spec.urdf_path())


def planner_copy(urdf: Path) -> Path:
    """The planner's copy of ``urdf`` (module docstring), written on first use; a ConfigError
    naming the URDF and the mesh when a collision mesh is missing or not readable."""
    urdf = Path(urdf).resolve()
    try:
        root = parse_urdf_xml(urdf)
    except ValueError as error:
        raise ConfigError(str(error)) from None
    for link in root.iter("link"):
        for visual in link.findall("visual"):
            link.remove(visual)
        for mesh in (m for c in link.iter("collision") for m in c.iter("mesh")):
            mesh.set("filename", _relinked(urdf, mesh.get("filename", "")))
    for limit in root.iter("limit"):  # urdfdom (mplib) rejects a limit without them
        limit.set("effort", limit.get("effort", "0"))
        limit.set("velocity", limit.get("velocity", "0"))
    ET.indent(root, space="  ")
    note = f"<!-- the planner's copy of {urdf.name}, by datagen.robot_specs.planner_copy -->\n"
    text = '<?xml version="1.0"?>\n' + note + ET.tostring(root, encoding="unicode") + "\n"
    digest = hashlib.sha256(text.encode("utf-8")).hexdigest()[:16]
    return write_once(cache_dir() / f"{urdf.stem}.planner-{digest}.urdf", text)


def _relinked(urdf: Path, filename: str) -> str:
    """A collision mesh's file name in the copy: its planner mesh relative to the cache."""
    try:
        mesh = mesh_path(urdf, filename)
    except ValueError:
        raise ConfigError(
            f"{urdf}: collision mesh {filename!r}: no folder named after its package above the URDF"
        ) from None
    if not mesh.is_file():
        raise ConfigError(f"{urdf}: collision mesh {filename!r}: no file {mesh}")
    try:
        copied = planner_mesh(mesh)
    except (OSError, ValueError, RuntimeError) as error:  # trimesh's and qhull's errors
        reason = str(error).splitlines()[0] if str(error) else type(error).__name__
        raise ConfigError(
            f"{urdf}: collision mesh {filename!r}: not a readable 3-D mesh ({reason})"
        ) from None
    return os.path.relpath(copied, cache_dir())
