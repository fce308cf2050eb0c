"""One URDF from an arm's URDF and the Franka hand of ManiSkill's ``panda_v2.urdf`` (its hand,
TCP, fingers, finger pads and their joints, the mimic of finger joint 2 included), fixed to the
arm's flange link; and an SRDF for the motion planner beside it. Plain XML, no simulator: the
files go to a cache folder (``$XDG_CACHE_HOME/datagen/robots``, else ``~/.cache/...``) under a
name holding a digest of their content, written to a temporary file and renamed, so concurrent
processes share them and never read half a file."""

from __future__ import annotations

import hashlib
import itertools
import os
import tempfile
import xml.etree.ElementTree as ET
import zlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from datagen.robot_specs import Vector3, locate
from datagen.robot_specs.urdf_files import mesh_path
from datagen.robot_specs.urdf_xml import parse_urdf_xml
from datagen.user_cache import user_cache

HAND_SOURCE = "mani_skill:robots/panda/panda_v2.urdf"
HAND_LINKS = (
    "panda_hand",
    "panda_hand_tcp",
    "panda_leftfinger",
    "panda_rightfinger",
    "panda_leftfinger_pad",
    "panda_rightfinger_pad",
)
MOUNT_JOINT = "franka_hand_mount"
PAIR_SAMPLES = 2000  # random configurations the SRDF's never-in-collision pairs are judged on


@dataclass(frozen=True)
class Composition:
    name: str  # the robot's name: the composed files are <name>-<digest>.urdf/.srdf
    arm: str  # the arm's URDF, located like RobotSpec.description
    flange: str  # the arm link the hand is fixed to
    mount_xyz: Vector3 = (0.0, 0.0, 0.0)  # metres, the hand's frame in the flange's
    mount_rpy: Vector3 = (0.0, 0.0, 0.0)  # radians, URDF roll-pitch-yaw
    hand: str = HAND_SOURCE


def cache_dir() -> Path:
    return user_cache("robots")


def planner_mesh(mesh_file: Path) -> Path:
    """mplib 0.1.1 plans with ``<collision mesh>.convex.stl``; where none is beside the mesh,
    the mesh and its convex hull are copied into the cache."""
    if Path(f"{mesh_file}.convex.stl").is_file():
        return mesh_file
    data = mesh_file.read_bytes()
    recipe = b"merge_vertices; qhull QbB Pp Qt"  # in the key: a new recipe, a new copy
    copy = cache_dir() / "meshes" / hashlib.sha256(data + recipe).hexdigest()[:16] / mesh_file.name
    hull_file = Path(f"{copy}.convex.stl")
    if not hull_file.is_file():  # made once: the hull is written before the mesh's copy
        import trimesh

        mesh = trimesh.load(mesh_file, force="mesh")
        mesh.merge_vertices()  # thin parts (koch's 2.8 mm chassis) otherwise give an open hull
        hull = trimesh.convex.convex_hull(mesh, qhull_options="QbB Pp Qt")
        write_once(hull_file, hull.export(file_type="stl"))
    return write_once(copy, data)


def _relink_meshes(element: ET.Element, source: Path) -> None:
    """Mesh file names relative to ``source``'s folder made relative to the cache folder, in
    place (mplib 0.1.1 joins even absolute names to the URDF's folder)."""
    for kind in ("visual", "collision"):
        for geometry in element.iter(kind):
            for mesh in geometry.iter("mesh"):
                filename = mesh.get("filename", "")
                path = mesh_path(source, filename)
                if kind == "collision":
                    path = planner_mesh(path)
                mesh.set("filename", os.path.relpath(path, cache_dir()))


def _hand_parts(hand_urdf: Path) -> list[ET.Element]:
    """The hand's links and the joints among them, as in ``hand_urdf``."""
    root = parse_urdf_xml(hand_urdf)
    links = {link.get("name"): link for link in root.findall("link")}
    missing = [name for name in HAND_LINKS if name not in links]
    if missing:
        raise ValueError(f"{hand_urdf}: the Franka hand needs links {missing}")
    joints = [
        joint
        for joint in root.findall("joint")
        if joint.find("child").get("link") in HAND_LINKS
        and joint.find("parent").get("link") in HAND_LINKS
    ]
    parts = [links[name] for name in HAND_LINKS] + joints
    for part in parts:
        _relink_meshes(part, hand_urdf)
    return parts


def _mount_joint(composition: Composition) -> ET.Element:
    joint = ET.Element("joint", name=MOUNT_JOINT, type="fixed")
    ET.SubElement(joint, "parent", link=composition.flange)
    ET.SubElement(joint, "child", link=HAND_LINKS[0])
    xyz, rpy = composition.mount_xyz, composition.mount_rpy
    ET.SubElement(
        joint,
        "origin",
        xyz=" ".join(repr(float(v)) for v in xyz),
        rpy=" ".join(repr(float(v)) for v in rpy),
    )
    return joint


def composed_text(composition: Composition) -> str:
    """The composed URDF (mesh paths relative to :func:`cache_dir`, where it is written)."""
    arm_urdf, hand_urdf = locate(composition.arm), locate(composition.hand)
    root = parse_urdf_xml(arm_urdf)
    names = {link.get("name") for link in root.findall("link")}
    if composition.flange not in names:
        raise ValueError(f"{arm_urdf}: no link {composition.flange!r} to mount the hand on")
    clash = names.intersection(HAND_LINKS)
    if clash:
        raise ValueError(f"{arm_urdf}: links {sorted(clash)} clash with the Franka hand's")
    _relink_meshes(root, arm_urdf)
    root.set("name", composition.name)
    root.append(_mount_joint(composition))
    root.extend(_hand_parts(hand_urdf))
    ET.indent(root, space="  ")
    note = (
        f"<!-- composed by datagen.robot_specs.compose: {composition.arm} + the Franka hand of"
        f" {composition.hand} on {composition.flange} -->\n"
    )
    return '<?xml version="1.0"?>\n' + note + ET.tostring(root, encoding="unicode") + "\n"


def write_once(path: Path, content: str | bytes) -> Path:
    """``content`` at ``path``, unless already there; atomic (temporary file, then rename)."""
    if path.is_file():
        return path
    path.parent.mkdir(parents=True, exist_ok=True)
    data = content.encode("utf-8") if isinstance(content, str) else content
    with tempfile.NamedTemporaryFile(
        dir=path.parent, prefix=f".{path.name}.", delete=False
    ) as temporary:
        temporary.write(data)
    os.replace(temporary.name, path)
    return path


def compose_urdf(composition: Composition) -> Path:
    """The composed URDF's path, written on first use."""
    text = composed_text(composition)
    digest = hashlib.sha256(text.encode("utf-8")).hexdigest()[:16]
    return write_once(cache_dir() / f"{composition.name}-{digest}.urdf", text)


def _adjacent_pairs(root: ET.Element) -> set[tuple[str, str]]:
    """Links joined by a joint, fixed chains of links without collision shapes skipped."""
    parent_of = {
        j.find("child").get("link"): j.find("parent").get("link") for j in root.iter("joint")
    }
    solid = {link.get("name") for link in root.iter("link") if link.find("collision") is not None}

    def solid_ancestor(link: str) -> str | None:
        while link in parent_of:
            link = parent_of[link]
            if link in solid:
                return link
        return None

    pairs = set()
    for child in solid:
        ancestor = solid_ancestor(child)
        if ancestor is not None:
            pairs.add(tuple(sorted((child, ancestor))))
    return pairs


def collision_pairs(
    urdf: Path, seed: int, samples: int = PAIR_SAMPLES
) -> dict[tuple[str, str], str]:
    """Link pairs the planner need not check, with MoveIt's reasons: ``Adjacent``, ``Default``
    (in collision in every sampled configuration), ``Never`` (in none). The configurations are
    uniform in the joint limits, drawn from ``seed``."""
    from mplib.pymp import ArticulatedModel, PlanningWorld

    model = ArticulatedModel(str(urdf), "", [0, 0, -9.81], [], [], convex=True, verbose=False)
    world = PlanningWorld([model], ["robot"], [], [])
    pinocchio = model.get_pinocchio_model()
    limits = np.concatenate(pinocchio.get_joint_limits())  # (dof, 2)
    low, high = np.clip(limits[:, 0], -np.pi, np.pi), np.clip(limits[:, 1], -np.pi, np.pi)
    entropy = (seed, zlib.crc32(b"collision_pairs"))
    rng = np.random.default_rng(np.random.SeedSequence(entropy=entropy))
    counts: dict[tuple[str, str], int] = {}
    for _ in range(samples):
        model.set_qpos(rng.uniform(low, high), True)
        touching = {tuple(sorted((c.link_name1, c.link_name2))) for c in world.collide_full()}
        for pair in touching:
            counts[pair] = counts.get(pair, 0) + 1
    root = parse_urdf_xml(urdf)
    solid = sorted(
        link.get("name") for link in root.iter("link") if link.find("collision") is not None
    )
    adjacent = _adjacent_pairs(root)
    reasons = {}
    for pair in itertools.combinations(solid, 2):
        if pair in adjacent:
            reasons[pair] = "Adjacent"
        elif counts.get(pair, 0) == samples:
            reasons[pair] = "Default"
        elif counts.get(pair, 0) == 0:
            reasons[pair] = "Never"
    return reasons


def compose_srdf(composition: Composition, seed: int = 0) -> Path:
    """The SRDF beside the composed URDF: its collision pairs to skip (:func:`collision_pairs`).
    Named ``<urdf stem>.pairs.srdf``, not ``<urdf stem>.srdf``, which mplib's Planner overwrites
    when it is given no SRDF."""
    urdf = compose_urdf(composition)
    return _pairs_srdf(
        urdf.with_name(f"{urdf.stem}.pairs-{seed}.srdf"), composition.name, urdf, seed
    )


def generated_srdf(urdf: Path, seed: int = 0) -> Path:
    """An SRDF of :func:`collision_pairs` for a URDF that comes without one (a user's arm), in
    the cache, named by the URDF's digest."""
    urdf = Path(urdf)
    digest = hashlib.sha256(urdf.read_bytes()).hexdigest()[:16]
    path = cache_dir() / f"{urdf.stem}-{digest}.pairs-{seed}.srdf"
    return _pairs_srdf(path, urdf.stem, urdf, seed)


def _pairs_srdf(path: Path, name: str, urdf: Path, seed: int) -> Path:
    """``path``, holding :func:`collision_pairs` of ``urdf`` as SRDF, written once."""
    if path.is_file():
        return path
    root = ET.Element("robot", name=name)
    for (first, second), reason in sorted(collision_pairs(urdf, seed).items()):
        ET.SubElement(root, "disable_collisions", link1=first, link2=second, reason=reason)
    ET.indent(root, space="  ")
    return write_once(
        path, '<?xml version="1.0"?>\n' + ET.tostring(root, encoding="unicode") + "\n"
    )


@dataclass(frozen=True)
class Frame:
    """A link without geometry, fixed to ``parent`` (a TCP or a finger pad)."""

    name: str
    parent: str
    xyz: Vector3  # metres, in the parent's frame
    rpy: Vector3 = (0.0, 0.0, 0.0)  # radians, URDF roll-pitch-yaw


@dataclass(frozen=True)
class FrameComposition:
    """A shipped URDF with frames added; written like :func:`compose_urdf`."""

    name: str
    source: str  # located like RobotSpec.description
    frames: tuple[Frame, ...]
    # radians about z: a new root link ``<name>_mount`` holds the shipped root turned by it,
    # so that an arm built facing -y faces +x like the others
    base_yaw: float = 0.0


def framed_text(composition: FrameComposition) -> str:
    source = locate(composition.source)
    root = parse_urdf_xml(source)
    names = {link.get("name") for link in root.findall("link")}
    for frame in composition.frames:
        if frame.parent not in names or frame.name in names:
            raise ValueError(
                f"{source}: frame {frame.name!r} on {frame.parent!r}: no such parent or a clash"
            )
        names.add(frame.name)
    _relink_meshes(root, source)
    for limit in root.iter("limit"):  # urdfdom (mplib) rejects a limit without them
        limit.set("effort", limit.get("effort", "0"))
        limit.set("velocity", limit.get("velocity", "0"))
    root.set("name", composition.name)
    frames = composition.frames
    if composition.base_yaw:
        children = {joint.find("child").get("link") for joint in root.findall("joint")}
        (shipped_root,) = (
            n for n in (link.get("name") for link in root.findall("link")) if n not in children
        )
        mount = f"{composition.name}_mount"
        ET.SubElement(root, "link", name=mount)
        frames = (
            Frame(shipped_root, mount, (0.0, 0.0, 0.0), (0.0, 0.0, composition.base_yaw)),
            *frames,
        )
    shipped = {link.get("name") for link in root.findall("link")}
    for frame in frames:
        if frame.name not in shipped:
            ET.SubElement(root, "link", name=frame.name)
        joint = ET.SubElement(root, "joint", name=f"{frame.name}_joint", type="fixed")
        ET.SubElement(joint, "parent", link=frame.parent)
        ET.SubElement(joint, "child", link=frame.name)
        xyz, rpy = (" ".join(repr(float(v)) for v in values) for values in (frame.xyz, frame.rpy))
        ET.SubElement(joint, "origin", xyz=xyz, rpy=rpy)
    ET.indent(root, space="  ")
    note = f"<!-- composed by datagen.robot_specs.compose: {composition.source} with frames -->\n"
    return '<?xml version="1.0"?>\n' + note + ET.tostring(root, encoding="unicode") + "\n"


def compose_framed_urdf(composition: FrameComposition) -> Path:
    """The URDF with its frames added, written on first use."""
    text = framed_text(composition)
    digest = hashlib.sha256(text.encode("utf-8")).hexdigest()[:16]
    return write_once(cache_dir() / f"{composition.name}-{digest}.urdf", text)
