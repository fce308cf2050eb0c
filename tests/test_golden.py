"""Samples of fixed seed keep their bytes (tests/data/golden_parts.json: sha256 of every part).
Images, depth and label maps are byte-for-byte those of commit c1ba73d, before the scene families
became plug-ins; the JSON metadata was re-recorded once, deliberately, when issue 14 corrected
``visible_fraction`` and ``obb_corners_px``. Every part of the grasp samples was re-recorded for
issue 15: settling stops once the objects rest and holds the robot asleep meanwhile
(datagen/worlds/settle.py), which moves objects and the arm; navigation kept its bytes. Issue 16
turned the appearance randomisers on by default (textures, rooms, distractors, household shapes,
camera effects, sensor depth), so every part of the default grasp, campaign and navigation
samples was re-recorded; ``configs/grasp_flat.yaml`` (all of them off) was added with images,
depth and label maps byte-for-byte those of the defaults before issue 16 (only its JSON differs:
the class list gained the new families, ``distractor`` and ``wall`` at its end). Issue 24 moved
the default workspace camera behind the robot and labelled the arm and the gripper as instances
(class ``gripper`` appended): every part of the default grasp and campaign samples was
re-recorded; ``configs/grasp_flat.yaml`` keeps the close-up camera, so only its JSON changed
(``gripper`` in the classes, ``robot_parts`` per view); navigation kept its bytes. The grasp
samplers' gripper boxes now come from the hand's URDF collision shapes (four per finger instead
of two hand-typed ones), which changes the campaign sample's chosen approach; the campaign sample
gained ``trajectory.npz`` (the recorded attempt), with every other part unchanged by recording.
Issue 26 added photographs of the picture library, flying distractors, class-free colours and the
wider lighting to the defaults (every part of the default grasp and campaign samples but the
campaign's trajectory re-recorded; ``grasp_flat`` turns them off, so only its JSON changed: the
lights' ``temperature_k`` and ``shadow_edge``), and turned texture coordinates so that a picture
is never drawn mirrored or upside down, which changes the textured walls of the navigation
frames (their ``rgb.png`` only). Issue 27 draws the robot with at most ``render.robot_triangles``
(20,000) triangles and filters shadows with 9 taps instead of 25, and counts the robot's and a
mesh's silhouette from the triangles the renderer draws (front faces): every image part of the
default grasp and campaign samples, their JSON and the campaign's trajectory (its frames) were
re-recorded; ``grasp_flat`` (the robot out of view) its ``rgb.png`` and sample 0's JSON (robot
fractions); navigation its ``rgb.png`` frames (shadow edges). Issue 28 made a navigation episode's
``shortest_path_m`` a true lower bound, gave it a TartanAir-style ``poses.head.txt`` and named the
commands of its robot (its JSON re-recorded, the pose file added), and added an aerial episode
(``configs/aerial_corridor.yaml``, two drones). Issue 39 re-recorded, on the AVX-512 class only
(the AVX2 digests of those parts are null until recorded there): the aerial sample (a
conservative voxel grid changes the flights; IMU streams, NED pose files, Habitat's SPL), the
``nav_maze`` sample's JSON, pose file and frames after the first (Fetch's step an exact arc,
trajectories to 6 digits, each frame's action) and the campaign sample's JSON, trajectory and
post-grasp frames (attempts run in a rebuilt scene with SAT contacts; executed grasp poses).
Issue 39 then turned the wrist camera on by default and held it over the tray (``robot.pose:
look``): every part of the default grasp and campaign samples was re-recorded on the AVX-512
class and their ``wrist.*`` parts added; ``grasp_flat`` (arm folded back, no wrist camera) kept
its bytes. Issue 41 gave the antipodal sampler grasp depths and a tighter approach sweep of
the Franka finger's slanted block: the campaign sample's JSON (its grasp, ``info.depth``),
trajectory and post-grasp frames were re-recorded on the AVX-512 class. The
digests were recorded with Mesa's lavapipe (llvmpipe) on x86-64, as on CI; another renderer draws
other pixels, so the test runs only there. The same commit draws other bytes on a CPU with
AVX-512 than on one with AVX2 only, so each class has its digests (:func:`cpu_class`):
``golden_parts.json`` (AVX2, recorded as above) and ``golden_parts.avx512.json`` (every part
recorded from commit c0aa1f4's code on an AVX-512 machine; an Emerald Rapids, whose model
numpy's OpenBLAS does not know, draws them too since ``import datagen`` pins its kernel to
Skylake-X's: ``datagen/blas_kernel.py``). Each sample is drawn in a child process
without ``OPENBLAS_CORETYPE``, so with that kernel even where the host sets another.
``--record`` re-records the class of
the machine it runs on; re-record both when a part's meaning changes.

Re-record deliberately, naming the parts whose meaning changed; any other part that changed is
an error and nothing is written::

    .venv/bin/python tests/test_golden.py --record json
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
import sapien

from datagen.config import load_config
from datagen.registries import FAMILIES

REPO = Path(__file__).resolve().parents[1]


def cpu_class() -> str:
    """``avx512`` where the CPU has AVX-512F, else ``avx2``. The same commit drew other bytes on
    the AVX-512 machine of 2026-11-29 than on the AVX2 ones the digests were recorded on (at
    c0aa1f4 five of the seven samples below: their JSON, a campaign's trajectory and post-grasp
    images, one tabletop rgb); LP_NATIVE_VECTOR_WIDTH=256, OPENBLAS_CORETYPE,
    NPY_DISABLE_CPU_FEATURES, OPENCV_CPU_DISABLE and other trimesh, scipy and coacd releases did
    not bring them back, so each class has its own digests."""
    try:
        flags = Path("/proc/cpuinfo").read_text()
    except OSError:
        return "avx2"
    return "avx512" if " avx512f" in flags else "avx2"


GOLDEN_FILES = {
    "avx2": REPO / "tests" / "data" / "golden_parts.json",
    "avx512": REPO / "tests" / "data" / "golden_parts.avx512.json",
}
GOLDEN_FILE = GOLDEN_FILES[cpu_class()]
GOLDEN = json.loads(GOLDEN_FILE.read_text())
SCENE = {"configs/grasp_campaign.yaml": "grasp_attempts"}

pytestmark = [pytest.mark.sim, pytest.mark.slow]


def sample_digests(config: str, key: str) -> dict[str, str]:
    """sha256 of every part of the sample, drawn in this process."""
    cfg = load_config(REPO / config)
    cfg = cfg.replace(scene=SCENE.get(config, cfg.scene))
    sample = FAMILIES[cfg.scene].produce_sample(cfg, cfg.seed, int(key))
    return {name: hashlib.sha256(data).hexdigest() for name, data in sample.parts.items()}


def part_digests(config: str, key: str) -> dict[str, str]:
    """:func:`sample_digests` drawn in a child process without ``OPENBLAS_CORETYPE``, so with
    datagen's own kernel (datagen/blas_kernel.py), which the digests were recorded with: a host
    may set another kernel for every process (one had ``Haswell`` on an AVX-512 CPU), and that
    draws other bytes by design, not because the code changed."""
    environment = {k: v for k, v in os.environ.items() if k != "OPENBLAS_CORETYPE"}
    done = subprocess.run(
        [sys.executable, __file__, "--digests", config, key],
        env=environment,
        cwd=REPO,
        capture_output=True,
        text=True,
        check=False,
    )
    assert done.returncode == 0, f"{config} {key}: {done.stderr[-3000:]}"
    return json.loads(done.stdout.splitlines()[-1])


@pytest.fixture(scope="module", autouse=True)
def lavapipe():
    device = sapien.render.get_device_summary()
    if "llvmpipe" not in device:
        pytest.skip(f"golden digests are lavapipe's; this machine renders with: {device[:80]}")


@pytest.mark.parametrize(
    ("config", "key"), [(c, k) for c, keys in sorted(GOLDEN.items()) for k in sorted(keys)]
)
def test_sample_bytes_are_unchanged(config, key):
    """Every part is there, and has its digest; a part recorded as ``null`` for this CPU class
    was re-recorded on the other class and waits for a recording on this one."""
    expected = GOLDEN[config][key]
    digests = part_digests(config, key)
    assert sorted(digests) == sorted(expected)
    assert {n: d for n, d in digests.items() if expected[n] is not None} == {
        n: d for n, d in expected.items() if d is not None
    }


def record(parts: set[str]) -> int:
    """Re-records the digests of ``parts`` for this machine's CPU class; returns 1, writing
    nothing, if any other changed. The other class's digests of the parts that changed become
    ``null`` (unchecked there until it records them)."""
    recorded, unexpected, changes = {}, [], {}
    for config, keys in sorted(GOLDEN.items()):
        for key, old in sorted(keys.items()):
            new = part_digests(config, key)
            unexpected += [
                f"{config} {key} {name}"
                for name in sorted(set(old) | set(new))
                if name not in parts
                and old.get(name) is not None
                and old.get(name) != new.get(name)
            ]
            changed = sorted(name for name in parts if old.get(name) != new.get(name))
            print(f"{config} {key}: re-recorded {changed or 'nothing'}")
            names = [n for n in sorted(set(old) | set(new)) if n in (new if n in parts else old)]
            recorded.setdefault(config, {})[key] = {
                name: (new if name in parts else old)[name] for name in names
            }
            changes[(config, key)] = (changed, names)
    if unexpected:
        print("not recorded: parts not named changed too:\n  " + "\n  ".join(unexpected))
        return 1
    GOLDEN_FILE.write_text(json.dumps(recorded, indent=1, sort_keys=True))
    for other in {f for c, f in GOLDEN_FILES.items() if c != cpu_class()}:
        golden = json.loads(other.read_text())
        for (config, key), (changed, names) in changes.items():
            digests = golden.setdefault(config, {}).setdefault(key, {})
            golden[config][key] = {n: None if n in changed else digests.get(n) for n in names}
        other.write_text(json.dumps(golden, indent=1, sort_keys=True))
        print(f"{other.name}: the parts that changed are null until recorded on that CPU class")
    return 0


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    chosen = parser.add_mutually_exclusive_group(required=True)
    chosen.add_argument("--record", nargs="+", metavar="PART")
    chosen.add_argument("--digests", nargs=2, metavar=("CONFIG", "KEY"), help=argparse.SUPPRESS)
    arguments = parser.parse_args()
    if arguments.digests:
        print(json.dumps(sample_digests(*arguments.digests)))
        sys.exit(0)
    sys.exit(record(set(arguments.record)))
