"""A user's URDF (``robot.urdf.file``) is hostile input: ``datagen build CONFIG --check`` refuses
a number that is not one, NaN or infinite, out of range or inconsistent (limits, axis, mass,
inertia, geometry sizes), a mesh that is missing or not a regular file or beyond the user-mesh
bounds, XML that is too deep, too large or declares entities: exit 2, one line naming the URDF,
the element and the value, before SAPIEN ever reads the file (issue 38, items 5, 6, 10, 14).
Before, ``ixx="abc"`` was a ValueError traceback, a NaN origin or ``lower="-inf"`` passed and
gave a dataset without the arm past joint 1, and a 50 MB attribute took 50 s to check."""

from __future__ import annotations

import contextlib
import io
import os
import shutil
import struct
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
import trimesh
import yaml

from datagen.cli import main
from datagen.registries import ROBOTS
from datagen.robot_specs.urdf_xml import MAX_URDF_BYTES

pytestmark = [pytest.mark.adversarial]
PANDA = ROBOTS["panda"].load().urdf_path()
JOINT1 = ".//joint[@name='panda_joint1']"
LINK1 = ".//link[@name='panda_link1']"
VISUAL1 = f"{LINK1}/visual/geometry/mesh"


@pytest.fixture(scope="module")
def arm(tmp_path_factory) -> Path:
    """The docs/robots.md walkthrough's folder: the Panda's meshes, URDFs written beside them."""
    folder = tmp_path_factory.mktemp("my_arm")
    shutil.copytree(PANDA.parent / "franka_description", folder / "franka_description")
    return folder


def urdf_with(arm: Path, name: str, path: str, attribute: str, value: str) -> Path:
    """The Panda's URDF with one attribute of the element at ``path`` set to ``value``."""
    tree = ET.parse(PANDA)
    tree.getroot().find(path).set(attribute, value)
    urdf = arm / f"{name}.urdf"
    tree.write(urdf)
    return urdf


def check(tmp_path: Path, urdf: Path) -> tuple[int, str]:
    """``datagen build CONFIG --check`` of the walkthrough's config naming ``urdf``."""
    joints = [f"panda_joint{i}" for i in range(1, 8)]
    robot = {
        "name": "my_arm",
        "urdf": {
            "file": str(urdf),
            "arm_joints": joints,
            "finger_joints": ["panda_finger_joint1", "panda_finger_joint2"],
            "tcp_link": "panda_hand_tcp",
            "ready_pose": [0.0, -0.95, 0.0, -2.75, 0.0, 1.95, 0.785],
        },
    }
    config = tmp_path / "my_arm.yaml"
    config.write_text(yaml.safe_dump({"scene": "grasp_attempts", "robot": robot}))
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        code = main(["build", str(config), "--out", str(tmp_path / "out"), "--check"])
    return code, err.getvalue()


def refused(tmp_path: Path, urdf: Path, *fragments: str) -> str:
    code, err = check(tmp_path, urdf)
    assert code == 2, err
    assert "Traceback" not in err and err.count("\n") == 1, err
    for fragment in (str(urdf), *fragments):
        assert fragment in err, err
    assert not (tmp_path / "out").exists()
    return err


def test_the_walkthrough_urdf_passes(tmp_path, arm):
    shutil.copy(PANDA, arm / "my_arm.urdf")
    code, err = check(tmp_path, arm / "my_arm.urdf")
    assert code == 0, err


INERTIA, MASS = f"{LINK1}/inertial/inertia", f"{LINK1}/inertial/mass"
NUMBERS = [  # (element, attribute, value, what the line names besides the value)
    (INERTIA, "ixx", "abc", "link 'panda_link1' <inertial> <inertia> ixx"),
    (INERTIA, "ixx", "0x10", "link 'panda_link1' <inertial> <inertia> ixx"),
    (f"{JOINT1}/origin", "xyz", "nan 0 0.333", "joint 'panda_joint1' <origin> xyz"),
    (f"{JOINT1}/origin", "xyz", "0 0", "joint 'panda_joint1' <origin> xyz"),
    (f"{JOINT1}/origin", "xyz", "1e300 0 0.333", "joint 'panda_joint1' <origin> xyz"),
    (f"{JOINT1}/origin", "xyz", "1_0 0 0.333", "joint 'panda_joint1' <origin> xyz"),
    (f"{JOINT1}/origin", "rpy", "0 inf 0", "joint 'panda_joint1' <origin> rpy"),
    (f"{JOINT1}/origin", "rpy", "0 1e999 0", "joint 'panda_joint1' <origin> rpy"),
    (f"{JOINT1}/axis", "xyz", "0 0 0", "joint 'panda_joint1' <axis> xyz"),
    (f"{JOINT1}/axis", "xyz", "0 NaN 1", "joint 'panda_joint1' <axis> xyz"),
    (f"{JOINT1}/limit", "lower", "-inf", "joint 'panda_joint1' <limit> lower"),
    (f"{JOINT1}/limit", "lower", "3", "joint 'panda_joint1' <limit> lower"),
    (f"{JOINT1}/limit", "upper", "", "joint 'panda_joint1' <limit> upper"),
    (f"{JOINT1}/limit", "effort", "-1", "joint 'panda_joint1' <limit> effort"),
    (f"{JOINT1}/limit", "velocity", "nan", "joint 'panda_joint1' <limit> velocity"),
    (f"{JOINT1}/dynamics", "damping", "nan", "joint 'panda_joint1' <dynamics> damping"),
    (f"{JOINT1}/safety_controller", "k_position", "inf", "joint 'panda_joint1' <safety_contr"),
    (".//joint[@name='panda_finger_joint2']/mimic", "multiplier", "nan", "<mimic> multiplier"),
    (".//joint[@name='panda_finger_joint2']/mimic", "joint", "nowhere", "<mimic> joint"),
    (MASS, "value", "-1", "link 'panda_link1' <inertial> <mass> value"),
    (MASS, "value", "-inf", "link 'panda_link1' <inertial> <mass> value"),
    (MASS, "value", "1e6", "link 'panda_link1' <inertial> <mass> value"),
    (INERTIA, "ixx", "nan", "link 'panda_link1' <inertial> <inertia> ixx"),
    (INERTIA, "ixx", "-0.7", "link 'panda_link1' <inertial> <inertia> ixx"),
    (INERTIA, "ixx", "0", "link 'panda_link1' <inertial> <inertia>: expected a positive-def"),
    (INERTIA, "ixy", "5", "link 'panda_link1' <inertial> <inertia>: expected a positive-def"),
    (f"{LINK1}/inertial/origin", "xyz", "0 0 -inf", "link 'panda_link1' <inertial> <origin> xyz"),
    (VISUAL1, "scale", "0 1 1", "link 'panda_link1' <visual> <mesh> scale"),
    (VISUAL1, "scale", "1 nan 1", "link 'panda_link1' <visual> <mesh> scale"),
    (JOINT1, "type", "hinge", "joint 'panda_joint1' type"),
    (f"{JOINT1}/parent", "link", "nowhere", "joint 'panda_joint1' <parent> link"),
    (".//joint[@name='panda_joint2']/child", "link", "panda_link1", "link 'panda_link1': the ch"),
]


@pytest.mark.parametrize(("element", "attribute", "value", "names"), NUMBERS)
def test_a_number_that_is_not_finite_or_in_range_is_refused(
    tmp_path, arm, element, attribute, value, names
):
    urdf = urdf_with(arm, tmp_path.name, element, attribute, value)
    refused(tmp_path, urdf, names, value)


@pytest.mark.parametrize(
    ("shape", "names"),
    [
        ('<box size="0.1 -0.1 0.1"/>', "<box> size"),
        ('<box size="0.1 0.1"/>', "<box> size"),
        ('<cylinder radius="nan" length="0.1"/>', "<cylinder> radius"),
        ('<cylinder radius="0.1" length="0"/>', "<cylinder> length"),
        ('<sphere radius="inf"/>', "<sphere> radius"),
        ("<sphere/>", "<sphere> radius"),
    ],
)
def test_a_primitive_of_no_size_is_refused(tmp_path, arm, shape, names):
    tree = ET.parse(PANDA)
    geometry = tree.getroot().find(f"{LINK1}/collision/geometry")
    geometry.remove(geometry[0])
    geometry.append(ET.fromstring(shape))
    urdf = arm / f"{tmp_path.name}.urdf"
    tree.write(urdf)
    refused(tmp_path, urdf, f"link 'panda_link1' <collision> {names}")


def _fifo(where: Path) -> Path:
    os.mkfifo(where / "link1.glb")
    return where / "link1.glb"


def _device(where: Path) -> Path:
    (where / "link1.glb").symlink_to("/dev/zero")
    return where / "link1.glb"


def _directory(where: Path) -> Path:
    (where / "link1.glb").mkdir()
    return where / "link1.glb"


def _huge(where: Path) -> Path:
    with open(where / "link1.glb", "wb") as f:
        f.truncate(2**31)  # sparse: 2 GiB that take no disk
    return where / "link1.glb"


def _nan_vertex(where: Path) -> Path:
    mesh = trimesh.creation.box(extents=[0.05, 0.04, 0.03])
    mesh.vertices[0] = [float("nan"), 0.0, 0.0]
    mesh.export(where / "link1.stl")
    return where / "link1.stl"


def _not_a_mesh(where: Path) -> Path:
    (where / "link1.stl").write_bytes(b"solid nothing\n")
    return where / "link1.stl"


@pytest.mark.parametrize(
    ("make", "reason"),
    [
        (lambda where: where / "missing.glb", "no such file"),
        (_fifo, "not a regular file"),
        (_device, "not a regular file"),
        (_directory, "not a regular file"),
        (_huge, "larger than 268435456 bytes"),
        (_nan_vertex, "non-finite"),
        (_not_a_mesh, "not a readable 3-D mesh"),
    ],
    ids=["missing", "fifo", "dev-zero-link", "directory", "2-GiB", "nan-vertex", "not-a-mesh"],
)
@pytest.mark.parametrize("kind", ["visual", "collision"])
def test_a_mesh_that_is_missing_special_or_unreadable_is_refused(tmp_path, arm, make, reason, kind):
    mesh = make(tmp_path)
    element = f"{LINK1}/{kind}/geometry/mesh"
    urdf = urdf_with(arm, tmp_path.name, element, "filename", str(mesh))
    started = time.monotonic()
    refused(tmp_path, urdf, f"link 'panda_link1' <{kind}> <mesh>", str(mesh), reason)
    assert time.monotonic() - started < 20


def _panda_with(before: str, inserted: str) -> str:
    """The Panda's URDF, ``inserted`` before the first ``before``."""
    return PANDA.read_text().replace(before, inserted + before, 1)


DEEP = "<gazebo>" + "<plugin>" * 200_000 + "</plugin>" * 200_000 + "</gazebo>"
LAUGHS = "".join(f'<!ENTITY {chr(98 + i)} "{("&" + chr(97 + i) + ";") * 10}">' for i in range(8))
LONG_NAME = '<material name="' + "m" * 300_000 + '"/>'


@pytest.mark.parametrize(
    ("text", "reason"),
    [
        (_panda_with("</robot>", DEEP), "elements nested deeper than 32"),
        (_panda_with("<robot", '<!DOCTYPE robot [<!ENTITY z "0.333">]>\n'), "a DOCTYPE"),
        (
            _panda_with("<robot", f'<!DOCTYPE robot [<!ENTITY a "aaaaaaaaaa">{LAUGHS}]>\n'),
            "DOCTYPE",
        ),
        (_panda_with("</robot>", LONG_NAME), "<material> name: an attribute longer than 4096"),
        (PANDA.read_text()[:5000], "not a readable URDF"),
    ],
    ids=["200k-deep", "entity", "billion-laughs", "long-attribute", "truncated"],
)
def test_xml_that_is_too_deep_declares_entities_or_is_broken_is_refused(
    tmp_path, arm, text, reason
):
    urdf = arm / f"{tmp_path.name}.urdf"
    urdf.write_text(text)
    started = time.monotonic()
    refused(tmp_path, urdf, reason)
    assert time.monotonic() - started < 10


def test_a_50_mb_attribute_is_refused_by_the_size_bound_at_once(tmp_path, arm):
    urdf = arm / f"{tmp_path.name}.urdf"
    text = PANDA.read_text().replace('name="panda"', 'name="' + "p" * 50 * 2**20 + '"', 1)
    urdf.write_text(text)
    started = time.monotonic()
    refused(tmp_path, urdf, f"more than the {MAX_URDF_BYTES} allowed")
    assert time.monotonic() - started < 5  # 20 to 50 s before


def _jpeg_claiming(width: int, height: int) -> bytes:
    """A JPEG's start and frame header, nothing else: 22 bytes declaring ``width`` x ``height``."""
    return b"\xff\xd8\xff\xc0\x00\x11\x08" + struct.pack(">HH", height, width) + b"\x03" + bytes(9)


def _bomb(where: Path) -> Path:
    (where / "bomb.jpg").write_bytes(_jpeg_claiming(32000, 32000))
    return where / "bomb.jpg"


@pytest.mark.parametrize(
    ("make", "reason"),
    [
        (lambda where: where / "missing.png", "no such file"),
        (_fifo, "not a regular file"),
        (_bomb, "32000x32000 pixels"),
    ],
    ids=["missing", "fifo", "32000x32000-jpeg"],
)
def test_a_texture_that_is_missing_special_or_a_bomb_is_refused(tmp_path, arm, make, reason):
    texture = make(tmp_path)
    tree = ET.parse(PANDA)
    visual = tree.getroot().find(f"{LINK1}/visual")
    material = ET.SubElement(visual, "material", name="skin")
    ET.SubElement(material, "texture", filename=str(texture))
    urdf = arm / f"{tmp_path.name}.urdf"
    tree.write(urdf)
    refused(tmp_path, urdf, "link 'panda_link1' <visual> <material> <texture>", reason)


@pytest.mark.timeout(180)  # a scan of the joints per link took minutes; linear: a few seconds
def test_a_urdf_of_20000_links_is_checked_in_linear_time(tmp_path, arm):
    chain = "".join(
        f'<link name="extra{i}"/><joint name="extra{i}" type="fixed">'
        f'<parent link="{f"extra{i - 1}" if i else "panda_link0"}"/><child link="extra{i}"/>'
        '<origin xyz="0 0 0.001"/></joint>'
        for i in range(20_000)
    )
    urdf = arm / f"{tmp_path.name}.urdf"
    urdf.write_text(_panda_with("</robot>", chain))
    assert urdf.stat().st_size < MAX_URDF_BYTES
    code, err = check(tmp_path, urdf)
    assert code == 0, err
