"""The picture library under attack (issue 38: critical 2, high 4, medium 9 and 13, low 14).

``$DATAGEN_LIBRARY`` may be a shared folder: whoever can write into it may plant links, damage
``manifest.json`` or swap pictures. ``datagen library install`` must never write through a link
(a file is written to a temporary in its folder and renamed over whatever is there; a source
folder that is a link is refused), and a build must refuse a damaged library at
``build --check`` in one line naming the file and what to run, never a traceback in a worker.

Every test installs a real source with the real ``datagen library install``: a wheel of three
pictures in a local folder, fetched by pip offline (``PIP_NO_INDEX``, ``PIP_FIND_LINKS``) and
registered by a plug-in distribution on ``PYTHONPATH``, as a user's package would register it;
then it plants the attack on disk and runs the real command."""

from __future__ import annotations

import hashlib
import json
import os
import re
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import cv2
import numpy as np
import pytest
import trimesh
import yaml

from adversarial.refusals import refused

pytestmark = [pytest.mark.adversarial]
REPO = Path(__file__).resolve().parents[2]
SOURCE = "attack-pictures"
PRECIOUS = b"precious: not the library's to write\n"
MODULE = f"""\
from datagen.library.sources import Source
from datagen.registries import LibrarySource

PICTURES = Source(registry="pip", package="attack-pictures==1.0", kind="photo",
                  members=("attack_pictures/*.png",), url="https://example.org/attack-pictures",
                  licence="CC0-1.0", copyright="datagen's tests")
RECORD = LibrarySource("{SOURCE}", "3 test pictures", "attack_pictures_source:PICTURES")
"""
CHECKED = {
    "version": 1,
    "scene": "grasp_tabletop",
    "num_samples": 1,
    "photos": {"sources": [SOURCE], "held_out": []},
}


def picture(seed: int, width: int = 96, height: int = 64) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return rng.integers(0, 256, (height, width, 3), dtype=np.uint8)


def wheel(folder: Path) -> Path:
    """A wheel ``attack-pictures 1.0`` holding three PNG pictures (as pip finds one)."""
    folder.mkdir()
    path = folder / "attack_pictures-1.0-py3-none-any.whl"
    info = "attack_pictures-1.0.dist-info"
    with zipfile.ZipFile(path, "w") as archive:
        for i in range(3):
            png = cv2.imencode(".png", picture(i))[1].tobytes()
            archive.writestr(f"attack_pictures/p{i}.png", png)
        archive.writestr(
            f"{info}/METADATA", "Metadata-Version: 2.1\nName: attack-pictures\nVersion: 1.0\n"
        )
        archive.writestr(
            f"{info}/WHEEL", "Wheel-Version: 1.0\nRoot-Is-Purelib: true\nTag: py3-none-any\n"
        )
        archive.writestr(f"{info}/RECORD", "")
    return folder


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    """The plug-in distribution registering the source, and the folder holding its wheel."""
    folder = tmp_path_factory.mktemp("site")
    info = folder / "attack_pictures_source-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text(
        "Metadata-Version: 2.1\nName: attack-pictures-source\nVersion: 0.1\n"
    )
    (info / "entry_points.txt").write_text(
        f"[datagen.library_sources]\n{SOURCE} = attack_pictures_source:RECORD\n"
    )
    (folder / "attack_pictures_source.py").write_text(MODULE)
    wheel(folder / "wheels")
    return folder


def datagen(site: Path, library: Path, *args: object) -> tuple[int, str, str]:
    python_path = os.pathsep.join(filter(None, [str(site), os.environ.get("PYTHONPATH")]))
    env = os.environ | {
        "PYTHONPATH": python_path,
        "DATAGEN_LIBRARY": str(library),
        "PIP_NO_INDEX": "1",
        "PIP_FIND_LINKS": str(site / "wheels"),
    }
    done = subprocess.run(
        [sys.executable, "-m", "datagen.cli", *map(str, args)],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=300,
        env=env,
    )
    return done.returncode, done.stdout, done.stderr


def install(site: Path, library: Path, *more: str) -> tuple[int, str, str]:
    return datagen(site, library, "library", "install", "--sources", SOURCE, *more)


@pytest.fixture(scope="module")
def installed(site, tmp_path_factory) -> Path:
    library = tmp_path_factory.mktemp("installed") / "library"
    code, out, err = install(site, library)
    assert code == 0 and f"{SOURCE}: 3 files (CC0-1.0)" in out, err
    return library


@pytest.fixture
def library(installed, tmp_path) -> Path:
    """A copy of the installed library, for one test to attack."""
    return Path(shutil.copytree(installed, tmp_path / "library", symlinks=True))


def check(site: Path, library: Path, tmp_path: Path) -> tuple[int, str, str]:
    config = tmp_path / "photos.yaml"
    config.write_text(yaml.safe_dump(CHECKED))
    return datagen(site, library, "build", config, "--out", tmp_path / "out", "--check")


def manifest(library: Path) -> dict:
    return json.loads((library / "manifest.json").read_text())


def listed(library: Path, changes: dict, index: int = 0) -> None:
    """Rewrites the manifest with ``changes`` to its ``index``-th file entry (what someone who
    can write into a shared library can do)."""
    data = manifest(library)
    data["files"][index].update(changes)
    data["files"][index] = {k: v for k, v in data["files"][index].items() if v is not None}
    (library / "manifest.json").write_text(json.dumps(data))


def victim(folder: Path, name: str = "precious.jpg") -> Path:
    folder.mkdir(exist_ok=True)
    (folder / name).write_bytes(PRECIOUS)
    return folder / name


# --- critical 2: install never writes through a link ---------------------------------------------


def test_install_replaces_a_picture_that_is_a_link_and_leaves_its_target_alone(
    site, library, tmp_path
):
    sentinel = victim(tmp_path / "outside")
    first = library / manifest(library)["files"][0]["path"]
    first.unlink()
    first.symlink_to(sentinel)
    code, out, err = install(site, library)
    assert code == 0 and "fetching" in out, err
    assert sentinel.read_bytes() == PRECIOUS
    assert not first.is_symlink() and first.is_file()


def test_install_refuses_a_source_folder_that_is_a_link(site, library, tmp_path):
    outside = tmp_path / "outside"
    sentinel = victim(outside)
    shutil.rmtree(library / SOURCE)
    (library / SOURCE).symlink_to(outside)
    refused(install(site, library), f"{library / SOURCE}", "link")
    assert sorted(outside.iterdir()) == [sentinel] and sentinel.read_bytes() == PRECIOUS


def test_install_does_not_write_through_a_link_at_the_manifest_or_its_temporary(
    site, library, tmp_path
):
    sentinel = victim(tmp_path / "outside")
    (library / "manifest.json.tmp").symlink_to(sentinel)
    code, _, err = install(site, library, "--force")
    assert code == 0, err
    assert sentinel.read_bytes() == PRECIOUS
    (library / "manifest.json").unlink()
    (library / "manifest.json").symlink_to(sentinel)
    code, _, err = install(site, library)
    assert code == 0, err
    assert sentinel.read_bytes() == PRECIOUS and not (library / "manifest.json").is_symlink()
    assert manifest(library)["sources"][SOURCE]["files"] == 3


@pytest.mark.skipif(os.geteuid() != 0, reason="a link owned by another user needs root to make")
def test_install_refuses_a_library_root_that_is_a_link_planted_by_another_user(
    site, library, tmp_path
):
    outside = tmp_path / "outside"
    sentinel = victim(outside)
    planted = tmp_path / "shared"
    planted.symlink_to(outside)
    os.lchown(planted, 4242, 4242)
    refused(install(site, planted), str(planted), "link")
    assert sorted(outside.iterdir()) == [sentinel]


# --- high 4: a damaged manifest.json is one line at build --check, and install mends it ----------

DAMAGES = {
    "truncated": lambda path: path.write_text(path.read_text()[:800]),
    "100k-deep": lambda path: path.write_text("[" * 100_000 + "]" * 100_000),
    "entry without kind": lambda path: listed(path.parent, {"kind": None}),
    "width not a number": lambda path: listed(path.parent, {"width": "96"}),
}


@pytest.mark.parametrize("damage", DAMAGES)
def test_a_damaged_manifest_is_one_line_naming_it_and_install_mends_it(
    site, library, tmp_path, damage
):
    path = library / "manifest.json"
    DAMAGES[damage](path)
    refused(check(site, library, tmp_path), str(path), "datagen library install")
    code, _, err = install(site, library)
    assert code == 0, err
    code, out, err = check(site, library, tmp_path)
    assert code == 0 and "check passed" in out, err


# --- medium 9, low 14: library files are regular files, bounded, pictures ------------------------


def bomb() -> bytes:
    """A JPEG of a few hundred bytes whose frame header declares 32000x32000 pixels."""
    data = bytearray(cv2.imencode(".jpg", picture(7, 8, 8), [cv2.IMWRITE_JPEG_QUALITY, 5])[1])
    at = data.index(b"\xff\xc0")
    data[at + 5 : at + 9] = (32000).to_bytes(2, "big") * 2
    return bytes(data)


def swapped(library: Path, data: bytes) -> dict:
    """The first picture replaced by ``data``, and the manifest updated to its digest."""
    entry = manifest(library)["files"][0]
    (library / entry["path"]).write_bytes(data)
    listed(library, {"sha256": hashlib.sha256(data).hexdigest()})
    return entry


def test_a_picture_linked_to_dev_zero_is_refused_at_check(site, library, tmp_path):
    entry = manifest(library)["files"][0]
    (library / entry["path"]).unlink()
    (library / entry["path"]).symlink_to("/dev/zero")
    refused(check(site, library, tmp_path), entry["path"], "link", "datagen library install")


@pytest.mark.parametrize(
    ("data", "why"), [(bomb(), "32000x32000"), (b"not a picture\n", "not a PNG or JPEG")]
)
def test_a_bomb_or_a_file_that_is_no_picture_is_refused_at_check(
    site, library, tmp_path, data, why
):
    entry = swapped(library, data)
    refused(check(site, library, tmp_path), entry["path"], why, "datagen library install")


WORKER = """\
import resource, sys
resource.setrlimit(resource.RLIMIT_AS, (2 << 30, 2 << 30))
from datagen.library.catalogue import LibraryMissing, load_picture
try:
    load_picture(sys.argv[1], sys.argv[2])
except LibraryMissing as exc:
    sys.exit(f"refused: {exc}")
"""


@pytest.mark.parametrize(
    ("data", "why"), [(bomb(), "32000x32000"), (b"not a picture\n", "not a PNG or JPEG")]
)
def test_a_worker_never_decodes_a_bomb_or_a_file_that_is_no_picture(library, data, why):
    """What a worker (or replay, or the USD export) does with a picture its sample names, under
    a 2 GiB address-space limit: a one-line refusal, never a 3 GB allocation or an assertion."""
    entry = swapped(library, data)
    env = os.environ | {"DATAGEN_LIBRARY": str(library)}
    done = subprocess.run(
        [sys.executable, "-c", WORKER, entry["path"], hashlib.sha256(data).hexdigest()],
        capture_output=True,
        text=True,
        timeout=120,
        env=env,
        cwd=REPO,
    )
    assert done.returncode == 1 and "Traceback" not in done.stderr, done.stderr
    assert done.stderr.startswith("refused: ") and why in done.stderr, done.stderr


# --- medium 13: manifest paths stay inside the library -------------------------------------------


@pytest.mark.parametrize("where", ["dotdot", "absolute", "link to a folder outside"])
def test_a_manifest_path_leading_outside_the_library_is_refused(site, library, tmp_path, where):
    outside = tmp_path / "outside"
    outside.mkdir()
    data = (library / manifest(library)["files"][0]["path"]).read_bytes()
    (outside / "p.jpg").write_bytes(data)
    path = {
        "dotdot": f"{SOURCE}/../../outside/p.jpg",
        "absolute": str(outside / "p.jpg"),
        "link to a folder outside": f"{SOURCE}/sub/p.jpg",
    }[where]
    (library / SOURCE / "sub").symlink_to(outside)
    listed(library, {"path": path})
    refused(check(site, library, tmp_path), path, "datagen library install")


# --- low 14: what a dataset records holds no machine path ----------------------------------------

MACHINE_PATH = r"(?:^|[\s'\"(@=])/[\w.-]+/"  # an absolute path's start inside a text


@pytest.mark.sim
@pytest.mark.mqtt
def test_a_build_records_library_and_skipped_files_relative_to_their_folders(
    site, library, tmp_path
):
    """A tiny real build drawing the library's pictures, with a user mesh folder holding a USD
    file that does not parse (its error names the file by its full path and USD's own source
    files) and a picture folder holding a file that is no picture and a link to /dev/zero
    (skipped, never read)."""
    assets, pictures = tmp_path / "assets", tmp_path / "pictures"
    (assets / "mug").mkdir(parents=True)
    trimesh.creation.icosphere(subdivisions=1, radius=0.04).export(assets / "mug" / "good.obj")
    (assets / "mug" / "bad.usda").write_text("#usda 1.0\n(\n garbage")
    pictures.mkdir()
    cv2.imwrite(str(pictures / "good.png"), picture(3))
    (pictures / "broken.png").write_bytes(b"not a picture\n")
    (pictures / "zero.png").symlink_to("/dev/zero")
    config = {
        **CHECKED,
        "render": {"width": 64, "height": 48},
        "seed": 5,
        "objects": {"source": "folder", "assets_dir": str(assets)},
        "materials": {"textures_dir": str(pictures)},
        "photos": {**CHECKED["photos"], "surface_probability": 1.0},
    }
    (tmp_path / "tiny.yaml").write_text(yaml.safe_dump(config))
    out = tmp_path / "out"
    build = ("build", tmp_path / "tiny.yaml", "--out", out, "--workers", "1", "--no-preview")
    code, _, err = datagen(site, library, *build)
    assert code == 0, err
    made = json.loads((out / "manifest.json").read_text())
    skipped = made["assets"]["skipped"] + made["pictures"]["materials.textures_dir"]["skipped"]
    assert {s["path"] for s in skipped} == {"mug/bad.usda", "broken.png", "zero.png"}, skipped
    for reason in (s["reason"] for s in skipped):
        assert not re.search(MACHINE_PATH, reason) and "\n" not in reason, reason
    files = made["pictures"]["photos"]["files"]
    assert len(files) == 3 and all(f["path"].startswith(f"{SOURCE}/p") for f in files), files
    assert str(library) not in (out / "manifest.json").read_text()
    shards = b"".join(p.read_bytes() for p in out.rglob("*.tar"))
    assert f"{SOURCE}/p".encode() in shards and str(library).encode() not in shards
