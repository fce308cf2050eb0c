"""The files a user's URDF names, checked before any process loads them: each visual and
collision mesh and each texture must be a regular file within bounds, and a mesh of a format
trimesh reads is read with the bounds of a user's object mesh (:mod:`datagen.assets.mesh_library`:
faces counted from the header first, then finite vertices within ``MAX_COORDINATE``). Before,
a missing mesh, a FIFO, a link to ``/dev/zero`` or a directory passed the check and failed or
hung every sample in SAPIEN's loader or the planner.

A name is resolved as the planner's copy resolves it (:func:`mesh_path`: relative to the URDF,
or ``package://<pkg>/...`` under the nearest folder named ``<pkg>`` above it) and links are
followed wherever they lead: a URDF commonly names ``../meshes`` or a shared package, and a link
reaches no further than a path the URDF could name itself. What is refused is what would block,
never end or exceed the bounds: anything but a regular file, more than ``MAX_MESH_BYTES``, more
than ``MAX_MESH_FACES``. Meshes of other formats (COLLADA ``.dae``, which SAPIEN's assimp reads
and trimesh cannot) are checked as files only; textures must be PNG or JPEG within
:data:`datagen.images.MAX_IMAGE_PIXELS`.
"""

from __future__ import annotations

import functools
import os
import stat
import xml.etree.ElementTree as ET
from pathlib import Path

from datagen.errors import ConfigError
from datagen.images import (
    MAX_IMAGE_FILE_BYTES,
    MAX_IMAGE_PIXELS,
    ImageInputError,
    header_size,
    read_regular_file,
)
from datagen.robot_specs.urdf_values import owner_name, parts, walk
from datagen.robot_specs.urdf_xml import parse_urdf_xml

MAX_MESH_BYTES = 256 * 2**20  # a binary STL of MAX_MESH_FACES is 50 MB, an OBJ about 100 MB
MAX_MESH_FACES = 1_000_000  # the default of objects.max_mesh_faces, a user's object mesh
TRIMESH_SUFFIXES = (".obj", ".stl", ".ply", ".glb", ".gltf")
_KINDS = {
    stat.S_IFDIR: "a directory",
    stat.S_IFIFO: "a FIFO",
    stat.S_IFCHR: "a device",
    stat.S_IFBLK: "a device",
    stat.S_IFSOCK: "a socket",
}


def mesh_path(source: Path, filename: str) -> Path:
    """A file name of ``source`` resolved: relative to its folder, or ``package://<pkg>/...``
    under the nearest folder of ``source`` named ``<pkg>``; ValueError for an unknown package."""
    if not filename.startswith("package://"):
        return (source.parent / filename.removeprefix("file://")).resolve()
    package, _, rest = filename.removeprefix("package://").partition("/")
    for folder in source.parents:
        if folder.name == package:
            return (folder / rest).resolve()
    raise ValueError(f"{source}: mesh {filename!r}: no folder {package!r} above the URDF")


def file_problem(path: Path, max_bytes: int) -> str | None:
    """Why ``path`` is not a regular file of at most ``max_bytes`` (links followed), else None."""
    try:
        info = os.stat(path)
    except FileNotFoundError:
        return "no such file"
    except OSError as error:
        return f"cannot read it ({error.strerror})"
    if not stat.S_ISREG(info.st_mode):
        return f"not a regular file ({_KINDS.get(stat.S_IFMT(info.st_mode), 'a special file')})"
    if info.st_size > max_bytes:
        return f"larger than {max_bytes} bytes ({info.st_size})"
    return None


def mesh_problem(path: Path) -> str | None:
    """Why the mesh file ``path`` is unusable (module docstring), else None."""
    problem = file_problem(path, MAX_MESH_BYTES)
    if problem or path.suffix.lower() not in TRIMESH_SUFFIXES:
        return problem
    from datagen.assets.mesh_library import coordinate_problem, face_count  # trimesh: 0.5 s

    try:
        faces = face_count(path)
        if faces > MAX_MESH_FACES:
            return f"{faces} faces, more than {MAX_MESH_FACES}"
        if faces == 0:
            return "not a readable 3-D mesh (no faces)"
        problem = coordinate_problem(path)
    except Exception as error:  # trimesh's errors of any kind: the file is no mesh
        reason = str(error).splitlines()[0] if str(error) else type(error).__name__
        return f"not a readable 3-D mesh ({reason[:200]})"
    return problem


def texture_problem(path: Path) -> str | None:
    """Why the texture ``path`` is unusable: not a regular PNG or JPEG file within the bounds of
    every picture datagen reads."""
    problem = file_problem(path, MAX_IMAGE_FILE_BYTES)
    if problem:
        return problem
    try:
        data = read_regular_file(path, max_bytes=MAX_IMAGE_FILE_BYTES)
    except ImageInputError as error:  # replaced since it was looked at
        return str(error).removeprefix(f"{path}: ")
    size = header_size(data)
    if size is None:
        return "not a PNG or JPEG picture"
    if size[0] * size[1] > MAX_IMAGE_PIXELS:
        return f"{size[0]}x{size[1]} pixels, more than {MAX_IMAGE_PIXELS}"
    return None


def named_files(root: ET.Element) -> list[tuple[str, ET.Element]]:
    """(what names it, the element) of every mesh and texture of the links and materials."""
    return [
        (f"{owner_name(part)} {tags}", element)
        for part in parts(root)
        for tags, element in walk(part)
        if element.tag in ("mesh", "texture")
    ]


def _problem(element: ET.Element, target: Path) -> str | None:
    if element.tag == "texture":
        return texture_problem(target)
    problem = mesh_problem(target)
    hull = Path(f"{target}.convex.stl")  # the planner loads a user's hull instead of the mesh
    if problem is None and element.tag == "mesh" and os.path.lexists(hull):
        problem = mesh_problem(hull)
        return None if problem is None else f"its hull {hull.name}: {problem}"
    return problem


@functools.lru_cache(maxsize=16)
def check_files(path: Path) -> None:
    """Each mesh and texture the URDF at ``path`` names (module docstring); a ConfigError naming
    the URDF, the link and tags, the file name and the problem. Once per process and file, like
    :func:`datagen.robot_specs.urdf.read_urdf`: the scenes ask for the robot in every sample."""
    checked: dict[Path, str | None] = {}
    for where, element in named_files(parse_urdf_xml(path)):
        filename = element.get("filename", "")
        try:
            target = mesh_path(path, filename)
        except ValueError:
            raise ConfigError(
                f"{path}: {where} filename {filename!r}: no folder named after its package "
                "above the URDF"
            ) from None
        if target not in checked:
            checked[target] = _problem(element, target) if filename else "expected a file name"
        if checked[target]:
            shown = repr(filename) + ("" if Path(filename) == target else f" ({target})")
            raise ConfigError(f"{path}: {where} filename {shown}: {checked[target]}")
