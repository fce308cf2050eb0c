"""A user's arm (``robot.urdf``) plans with a copy of its URDF in the cache whose collision
meshes have convex hulls, made once and nothing written beside the user's files. The arm is the
docs/robots.md walkthrough's (the Panda's shipped URDF copied into a folder of the user's),
without the shipped ``.convex.stl`` files, with which mplib 0.1.1 could not load it."""

from __future__ import annotations

import shutil
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
import trimesh

from datagen.config import config_from_dict
from datagen.config.robot import robot_spec
from datagen.errors import ConfigError
from datagen.registries import ROBOTS
from datagen.robot_specs.compose import cache_dir
from datagen.robot_specs.planner_copy import planner_copy, planner_urdf

PANDA_URDF = ROBOTS["panda"].load().urdf_path()
TRAY_TCP = np.array([0.08, 0.0, 0.9, 0.0, 1.0, 0.0, 0.0])  # above the tray centre, z down (wxyz)
WORLD_BASE = np.array([-0.62, 0.0, 0.75, 1.0, 0.0, 0.0, 0.0])  # the worlds' robot base pose


@pytest.fixture(autouse=True)
def _cache(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))


def _user_arm(folder: Path, package: bool = False, visual: bool = False) -> Path:
    """The walkthrough's ``my_arm/my_arm.urdf`` without hulls (collision meshes only, and the
    visual ones with ``visual``: a config's check wants every mesh); with ``package``, at
    ``franka_description/urdf/`` naming its meshes ``package://``."""
    for kind in ("collision", "visual") if visual else ("collision",):
        shutil.copytree(
            PANDA_URDF.parent / f"franka_description/meshes/{kind}",
            folder / f"franka_description/meshes/{kind}",
            ignore=shutil.ignore_patterns("*.convex.stl"),
        )
    text = PANDA_URDF.read_text()
    if package:
        urdf = folder / "franka_description/urdf/my_arm.urdf"
        text = text.replace(
            'filename="franka_description/', 'filename="package://franka_description/'
        )
    else:
        urdf = folder / "my_arm.urdf"
    urdf.parent.mkdir(parents=True, exist_ok=True)
    urdf.write_text(text)
    return urdf


def _files(folder: Path) -> dict[str, tuple[int, int]]:
    return {
        str(p.relative_to(folder)): (p.stat().st_size, p.stat().st_mtime_ns)
        for p in folder.rglob("*")
    }


def _collision_meshes(urdf: Path) -> list[Path]:
    root = ET.parse(urdf).getroot()
    return [urdf.parent / m.get("filename") for c in root.iter("collision") for m in c.iter("mesh")]


@pytest.mark.parametrize("package", [False, True], ids=["relative", "package"])
def test_the_copy_is_in_the_cache_with_a_hull_per_collision_mesh(tmp_path, package):
    user = tmp_path / "my_arm"
    urdf = _user_arm(user, package)
    before = _files(user)
    copy = planner_copy(urdf)
    assert copy.parent == cache_dir() and copy.is_relative_to(tmp_path / "cache")
    meshes = _collision_meshes(copy)
    assert len(meshes) == len(_collision_meshes(PANDA_URDF)) == 9
    for mesh in meshes:
        hull = trimesh.load(f"{mesh}.convex.stl", force="mesh")
        assert mesh.resolve().is_relative_to(cache_dir()), mesh
        assert hull.is_watertight and hull.is_convex, mesh
    assert ET.parse(copy).getroot().find("link/visual") is None
    assert _files(user) == before

    written = {p: p.stat().st_mtime_ns for p in cache_dir().rglob("*") if p.is_file()}
    assert planner_copy(urdf) == copy
    assert {p: p.stat().st_mtime_ns for p in cache_dir().rglob("*") if p.is_file()} == written


def test_hulls_the_user_ships_are_used_where_they_are(tmp_path):
    user = tmp_path / "my_arm"
    shutil.copytree(
        PANDA_URDF.parent / "franka_description/meshes/collision",
        user / "franka_description/meshes/collision",
    )
    shutil.copy(PANDA_URDF, user / "my_arm.urdf")
    meshes = _collision_meshes(planner_copy(user / "my_arm.urdf"))
    assert all(m.resolve().parent == user / "franka_description/meshes/collision" for m in meshes)
    assert not (cache_dir() / "meshes").exists()


def test_a_built_in_arm_plans_with_its_own_urdf():
    assert planner_urdf(ROBOTS["panda"].load()) == PANDA_URDF
    assert not cache_dir().exists()


@pytest.mark.parametrize(
    ("damage", "message"),
    [
        (
            lambda mesh: mesh.unlink(),
            r"collision mesh 'franka_description/meshes/collision/link3.stl': no file",
        ),
        (
            lambda mesh: mesh.write_bytes(b"solid nothing\n"),
            r"collision mesh '.*/link3.stl': not a readable 3-D mesh",
        ),
    ],
    ids=["missing", "unreadable"],
)
def test_a_missing_or_unreadable_mesh_is_one_line_naming_urdf_and_mesh(tmp_path, damage, message):
    urdf = _user_arm(tmp_path / "my_arm")
    damage(tmp_path / "my_arm/franka_description/meshes/collision/link3.stl")
    with pytest.raises(ConfigError, match=rf"my_arm\.urdf: {message}") as error:
        planner_copy(urdf)
    assert "\n" not in str(error.value)


def test_an_unknown_package_is_named(tmp_path):
    urdf = _user_arm(tmp_path / "my_arm")
    urdf.write_text(
        urdf.read_text().replace('filename="franka_description/', 'filename="package://nope/')
    )
    with pytest.raises(
        ConfigError, match=r"my_arm\.urdf: collision mesh 'package://nope/.*no folder"
    ):
        planner_copy(urdf)


def _walkthrough_spec(urdf: Path):
    walkthrough = {
        "file": str(urdf),
        "arm_joints": [f"panda_joint{i}" for i in range(1, 8)],
        "finger_joints": ["panda_finger_joint1", "panda_finger_joint2"],
        "tcp_link": "panda_hand_tcp",
        "ready_pose": [0.0, -0.95, 0.0, -2.75, 0.0, 1.95, 0.785],
    }
    return robot_spec(config_from_dict({"robot": {"name": "my_arm", "urdf": walkthrough}}).robot)


def test_the_walkthrough_arm_plans_with_the_copy(tmp_path):
    import mplib

    spec = _walkthrough_spec(_user_arm(tmp_path / "my_arm", visual=True))
    srdf = str(PANDA_URDF.with_suffix(".srdf"))
    with pytest.raises(ValueError, match=r"Could not load resource .*link0\.stl\.convex\.stl"):
        mplib.Planner(urdf=str(spec.urdf_path()), srdf=srdf, move_group=spec.gripper.tcp_link)
    copy = planner_urdf(spec)
    assert copy.parent == cache_dir()
    planner = mplib.Planner(urdf=str(copy), srdf=srdf, move_group=spec.gripper.tcp_link)
    planner.set_base_pose(WORLD_BASE)
    start = np.array([*spec.ready_pose, 0.04, 0.04])
    assert not planner.check_for_self_collision(qpos=start)
    status, solutions = planner.IK(
        planner.transform_goal_to_wrt_base(TRAY_TCP), start, n_init_qpos=40
    )
    assert status == "Success", status
    assert not planner.check_for_self_collision(qpos=np.asarray(solutions[0]))


@pytest.mark.sim
def test_make_planner_plans_a_user_arm_with_the_copy(tmp_path):
    import sapien

    from datagen.families.grasp_attempts.planner import make_planner, solve_ik

    user = tmp_path / "my_arm"  # the walkthrough's folder whole: SAPIEN loads the visual meshes
    shutil.copytree(
        PANDA_URDF.parent / "franka_description",
        user / "franka_description",
        ignore=shutil.ignore_patterns("*.convex.stl"),
    )
    shutil.copy(PANDA_URDF, user / "my_arm.urdf")
    spec = _walkthrough_spec(user / "my_arm.urdf")
    before = _files(user)
    scene = sapien.Scene()
    robot = scene.create_urdf_loader().load(str(spec.urdf_path()))
    robot.set_root_pose(sapien.Pose(WORLD_BASE[:3]))
    planner = make_planner(scene, robot, [], spec)
    assert Path(planner.urdf).parent == cache_dir()
    qpos = np.array([*spec.ready_pose, 0.04, 0.04])
    assert solve_ik(planner, sapien.Pose(TRAY_TCP[:3], TRAY_TCP[3:]), qpos)
    assert _files(user) == before
