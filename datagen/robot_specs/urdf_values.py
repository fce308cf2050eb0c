"""Every number of a URDF checked before anything uses it, and the tree it describes.

A URDF attribute is read by datagen (:mod:`datagen.robot_specs.urdf`), SAPIEN's loader and
mplib, each in its own way: ``abc`` was a ValueError traceback here, ``nan`` passed everywhere
and a NaN joint origin gave images without the arm past that joint. So each number a link or
joint holds must be a plain decimal (what every URDF reader parses alike; no ``nan``, ``inf``,
hex or ``1_0``), finite and in range, with the right count: origins (xyz within
``MAX_METRES``, rpy within ``MAX_RADIANS``), a moving joint's axis (non-zero; normalised as
URDF readers do), limits (lower <= upper), effort, velocity, damping and friction (>= 0), mimic
and safety numbers, mass (>= 0), inertia (with a positive mass, a positive-definite tensor, as
SAPIEN asserts in every sample; the triangle inequality of its principal moments is not
checked: PhysX needs positive moments only), primitive sizes and mesh scales (> 0), colours
(0..1). A mass of 0 marks a link without mass properties (SAPIEN ignores such an inertial and
derives them from the collision shapes; 7 of the 61 URDFs mani-skill ships have one).

The tree: unique names, joints of URDF's types between links of the file (a mimic naming a
joint of it), one root link, every link below it and none the child of two joints. A problem is
one ConfigError line naming the file, the link or joint, its tags and the value.
"""

from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET
from collections import Counter
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from datagen.errors import ConfigError

MAX_METRES = 1e3  # origins, sizes, prismatic limits (metres) and revolute limits (radians)
MAX_RADIANS = 1e2  # roll-pitch-yaw
MAX_MASS = 1e5  # kg, one link
MAX_INERTIA = 1e5  # kg m^2
MAX_SCALE = 1e3  # a mesh's scale: 1e3 turns millimetres into metres
MAX_DRIVE = 1e9  # effort, velocity, damping, friction, safety gains
INERTIA_KEYS = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed", "floating", "planar")
MOVING = ("revolute", "continuous", "prismatic", "planar")
# a decimal number as every URDF reader parses it: Python's float() alone also takes nan, inf
# and 1_0, numpy's fromstring (SAPIEN) stops at the first word it cannot read
_NUMBER = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?")


@dataclass(frozen=True)
class Rule:
    count: int
    low: float
    high: float
    above_low: bool = False  # low itself excluded
    required: bool = False

    def expected(self) -> str:
        what = "a finite number" if self.count == 1 else f"{self.count} finite numbers"
        bracket = "(" if self.above_low else "["
        return f"{what} in {bracket}{self.low:g}, {self.high:g}]"

    def problem(self, text: str | None) -> str | None:
        if text is None:
            return f"expected {self.expected()}, got none" if self.required else None
        words = text.split()
        numbers = [float(w) for w in words if _NUMBER.fullmatch(w)]
        finite = len(numbers) == len(words) == self.count and all(map(math.isfinite, numbers))
        if finite and all(self.low < v <= self.high for v in numbers):
            return None
        if finite and not self.above_low and all(self.low <= v <= self.high for v in numbers):
            return None
        return f"expected {self.expected()}, got {_shown(text)}"


_LENGTH, _SIZE = Rule(1, -MAX_METRES, MAX_METRES), Rule(1, 0.0, MAX_METRES, True, True)
_DRIVE, _MOMENT = Rule(1, 0.0, MAX_DRIVE), Rule(1, -MAX_INERTIA, MAX_INERTIA)
RULES = {
    ("origin", "xyz"): Rule(3, -MAX_METRES, MAX_METRES),
    ("origin", "rpy"): Rule(3, -MAX_RADIANS, MAX_RADIANS),
    ("axis", "xyz"): Rule(3, -MAX_METRES, MAX_METRES),
    ("limit", "lower"): _LENGTH,
    ("limit", "upper"): _LENGTH,
    ("limit", "effort"): _DRIVE,
    ("limit", "velocity"): _DRIVE,
    ("dynamics", "damping"): _DRIVE,
    ("dynamics", "friction"): _DRIVE,
    ("mimic", "multiplier"): _LENGTH,
    ("mimic", "offset"): _LENGTH,
    ("safety_controller", "soft_lower_limit"): _LENGTH,
    ("safety_controller", "soft_upper_limit"): _LENGTH,
    ("safety_controller", "k_position"): _DRIVE,
    ("safety_controller", "k_velocity"): _DRIVE,
    ("calibration", "rising"): _LENGTH,
    ("calibration", "falling"): _LENGTH,
    ("mass", "value"): Rule(1, 0.0, MAX_MASS, required=True),
    **{("inertia", k): _MOMENT for k in ("ixy", "ixz", "iyz")},
    **{("inertia", k): Rule(1, 0.0, MAX_INERTIA, required=True) for k in ("ixx", "iyy", "izz")},
    ("box", "size"): Rule(3, 0.0, MAX_METRES, above_low=True, required=True),
    ("cylinder", "radius"): _SIZE,
    ("cylinder", "length"): _SIZE,
    ("capsule", "radius"): _SIZE,
    ("capsule", "length"): _SIZE,
    ("sphere", "radius"): _SIZE,
    ("mesh", "scale"): Rule(3, 0.0, MAX_SCALE, above_low=True),
    ("color", "rgba"): Rule(4, 0.0, 1.0, required=True),
}
_KEYS = {tag: [k for t, k in RULES if t == tag] for tag, _ in RULES}  # the keys of each tag


def _shown(text: str, limit: int = 60) -> str:
    return repr(text if len(text) <= limit else text[:limit] + "...")


def owner_name(element: ET.Element) -> str:
    """``link 'name'``, ``joint 'name'``: how a message names a URDF's part."""
    return f"{element.tag} {_shown(element.get('name', ''))}"


def walk(owner: ET.Element) -> Iterator[tuple[str, ET.Element]]:
    """Every element below ``owner`` with the tags down to it (``<visual> <mesh>``; the
    ``<geometry>`` between left out)."""
    stack = [(child, "") for child in reversed(owner)]
    while stack:
        element, above = stack.pop()
        tags = above if element.tag == "geometry" else f"{above} <{element.tag}>".strip()
        if element.tag != "geometry":
            yield tags, element
        stack.extend((child, tags) for child in reversed(element))


def parts(root: ET.Element) -> list[ET.Element]:
    """The links, joints and named materials of a URDF, where its numbers are."""
    return [e for e in root if e.tag in ("link", "joint", "material")]


def check_numbers(root: ET.Element, path: Path) -> None:
    """Each number of each link, joint and material (module docstring)."""
    for part in parts(root):
        for tags, element in walk(part):
            for key in _KEYS.get(element.tag, ()):
                problem = RULES[(element.tag, key)].problem(element.get(key))
                if problem:
                    raise ConfigError(f"{path}: {owner_name(part)} {tags} {key}: {problem}")


def _vector(element: ET.Element | None, key: str, default: tuple[float, ...]) -> np.ndarray:
    text = None if element is None else element.get(key)
    return np.asarray(default if text is None else [float(v) for v in text.split()], float)


def _check_joint(joint: ET.Element, joint_names: set[str], path: Path) -> None:
    name, kind, mimic = owner_name(joint), joint.get("type"), joint.find("mimic")
    if mimic is not None and mimic.get("joint") not in joint_names:
        raise ConfigError(
            f"{path}: {name} <mimic> joint: expected a joint of the file, got {mimic.get('joint')!r}"
        )
    if kind not in JOINT_TYPES:
        raise ConfigError(f"{path}: {name} type: expected one of {list(JOINT_TYPES)}, got {kind!r}")
    axis = _vector(joint.find("axis"), "xyz", (1.0, 0.0, 0.0))
    if kind in MOVING and np.linalg.norm(axis) < 1e-6:
        shown = joint.find("axis").get("xyz")  # type: ignore[union-attr]
        raise ConfigError(
            f"{path}: {name} <axis> xyz: expected a non-zero direction, got {shown!r}"
        )
    limit = joint.find("limit")
    if kind in ("revolute", "prismatic") and limit is not None:
        lower, upper = (float(limit.get(k, 0.0)) for k in ("lower", "upper"))
        if lower > upper:
            raise ConfigError(
                f"{path}: {name} <limit> lower: expected at most upper ({upper:g}), "
                f"got {limit.get('lower')!r}"
            )


def _check_inertial(link: ET.Element, path: Path) -> None:
    inertial = link.find("inertial")
    if inertial is None:
        return
    mass, inertia = inertial.find("mass"), inertial.find("inertia")
    if mass is None or inertia is None:
        raise ConfigError(f"{path}: {owner_name(link)} <inertial>: expected <mass> and <inertia>")
    if float(mass.get("value", 0.0)) == 0:  # SAPIEN then ignores it (module docstring)
        return
    xx, xy, xz, yy, yz, zz = (float(inertia.get(k, 0.0)) for k in INERTIA_KEYS)
    smallest = np.linalg.eigvalsh(np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]]))[0]
    if smallest <= 0:
        shown = " ".join(f"{k}={inertia.get(k, '0')}" for k in INERTIA_KEYS)
        raise ConfigError(
            f"{path}: {owner_name(link)} <inertial> <inertia>: expected a positive-definite "
            f"tensor, got {shown} (smallest principal moment {smallest:.3g})"
        )


def _unique(names: list[str], what: str, path: Path) -> None:
    twice = sorted(name for name, count in Counter(names).items() if count > 1)
    if twice:
        raise ConfigError(f"{path}: two {what}s named {twice[0]!r}; expected unique names")


def check_tree(root: ET.Element, path: Path) -> str:
    """The root link's name, when the joints join the links into one tree (module docstring)."""
    links = [e.get("name", "") for e in root.findall("link")]
    joints = root.findall("joint")
    _unique(links, "link", path)
    _unique([j.get("name", "") for j in joints], "joint", path)
    children = _children(joints, set(links), path)
    below = {child for names in children.values() for child in names}
    roots = [name for name in links if name not in below]
    if len(roots) != 1:
        raise ConfigError(f"{path}: expected one root link, got {roots[:10]}")
    reached, stack = set(), [roots[0]]
    while stack:
        reached.add(stack[-1])
        stack.extend(children.get(stack.pop(), []))
    if len(reached) != len(links):
        cut_off = sorted(set(links) - reached)[:10]
        raise ConfigError(f"{path}: links {cut_off} are not below the root link {roots[0]!r}")
    return roots[0]


def _children(joints: list[ET.Element], links: set[str], path: Path) -> dict[str, list[str]]:
    """The child links of each link, each joint checked; a link may have one parent only."""
    names = {j.get("name", "") for j in joints}
    parent_joint: dict[str, str] = {}
    children: dict[str, list[str]] = {}
    for joint in joints:
        _check_joint(joint, names, path)
        parent, child = (_end(joint, role, links, path) for role in ("parent", "child"))
        if child in parent_joint:
            raise ConfigError(
                f"{path}: link {_shown(child)}: the child of two joints "
                f"({_shown(parent_joint[child])} and {_shown(joint.get('name', ''))}); "
                "expected a tree"
            )
        parent_joint[child] = joint.get("name", "")
        children.setdefault(parent, []).append(child)
    return children


def _end(joint: ET.Element, role: str, links: set[str], path: Path) -> str:
    element = joint.find(role)
    link = None if element is None else element.get("link")
    if link is None or link not in links:
        raise ConfigError(
            f"{path}: {owner_name(joint)} <{role}> link: expected a link of the file, got {link!r}"
        )
    return link


def check_values(root: ET.Element, path: Path) -> str:
    """Every number and the tree of a parsed URDF (module docstring); its root link's name."""
    check_numbers(root, path)
    for link in root.findall("link"):
        _check_inertial(link, path)
    return check_tree(root, path)
