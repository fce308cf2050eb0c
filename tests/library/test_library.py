"""The library of real appearance (datagen/library/): the installer fetches a source from its
registry idempotently, every installed file carries its source and a licence that allows
redistributing renders, licences that do not are refused, and a build without the library, or
with a held-out source drawn, stops with one line saying what to do."""

from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from datagen.config import config_from_dict
from datagen.errors import ConfigError
from datagen.library import install as installer
from datagen.library.catalogue import library_root, read_manifest
from datagen.library.sources import REDISTRIBUTABLE, SKIMAGE_DATA
from datagen.registries import LIBRARY_SOURCES

REPO = Path(__file__).resolve().parents[2]
DATAGEN = [str(Path(sys.executable).parent / "datagen")]


def _cli(*args: str, library: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "DATAGEN_LIBRARY": str(library)}
    return subprocess.run([*DATAGEN, *args], capture_output=True, text=True, env=env, cwd=REPO)


@pytest.mark.slow  # fetches scikit-image's wheel from PyPI (pip's cache after the first time)
def test_the_installer_fetches_a_source_once_and_mends_a_missing_file(tmp_path):
    first = _cli("library", "install", "--sources", "skimage-data", library=tmp_path)
    assert first.returncode == 0, first.stderr
    assert "skimage-data: 10 files (CC0-1.0, public-domain)" in first.stdout
    manifest = json.loads((tmp_path / "manifest.json").read_text())
    stamps = {e["path"]: (tmp_path / e["path"]).stat().st_mtime_ns for e in manifest["files"]}

    again = _cli("library", "install", "--sources", "skimage-data", library=tmp_path)
    assert (
        again.returncode == 0 and "skimage-data: installed (scikit-image==0.25.2)" in again.stdout
    )
    assert {p: (tmp_path / p).stat().st_mtime_ns for p in stamps} == stamps, "nothing rewritten"
    assert json.loads((tmp_path / "manifest.json").read_text()) == manifest

    (tmp_path / manifest["files"][0]["path"]).unlink()
    mended = _cli("library", "install", "--sources", "skimage-data", library=tmp_path)
    assert "fetching" in mended.stdout and json.loads((tmp_path / "manifest.json").read_text()) == manifest  # fmt: skip


@pytest.mark.slow
def test_a_licence_that_does_not_allow_redistribution_is_refused(tmp_path):
    member = SKIMAGE_DATA.members[0]
    source = installer.Source(**{**SKIMAGE_DATA.__dict__, "per_file": {member: ("CC-BY-NC-4.0", "x")}})  # fmt: skip
    with pytest.raises(installer.InstallError, match=r"licence 'CC-BY-NC-4.0' is not one that allows"):  # fmt: skip
        installer._install_source("skimage-data", source, tmp_path)


def test_every_installed_file_names_its_source_licence_and_copyright():
    manifest = read_manifest()
    assert set(manifest["sources"]) == set(LIBRARY_SOURCES), "scripts/install.sh installs all"
    for entry in manifest["files"]:
        assert entry["source"] in LIBRARY_SOURCES and entry["licence"] in REDISTRIBUTABLE, entry
        assert entry["copyright"] and entry["url"].startswith("https://") and entry["package"]
        data = (library_root() / entry["path"]).read_bytes()
        assert hashlib.sha256(data).hexdigest() == entry["sha256"]
    by_member = {e["member"]: e for e in manifest["files"]}
    aqua = by_member[
        "usr/share/backgrounds/mate/nature/Aqua.jpg"
    ]  # per file, from debian/copyright
    assert aqua["licence"] == "GPL-2.0-or-later" and "Charles Barbin" in aqua["copyright"]
    assert by_member["skimage/data/coffee.png"]["copyright"] == "Rachel Michetti"


def test_a_build_without_the_library_says_what_to_run(tmp_path):
    done = _cli("build", "configs/grasp_tabletop.yaml", "--out", str(tmp_path / "out"), library=tmp_path)  # fmt: skip
    assert done.returncode == 2 and done.stdout == ""
    assert done.stderr.splitlines() == [
        f"datagen: config error: configs/grasp_tabletop.yaml: photos: the picture library is not "
        f"installed ({tmp_path}/manifest.json does not exist): run `datagen library install` "
        "(bash scripts/install.sh does it too)"
    ]
    assert not (tmp_path / "out").exists()


def test_sources_are_checked_and_a_held_out_source_cannot_be_drawn():
    with pytest.raises(ConfigError, match=r"photos.held_out: \['skimage-data'\] also in photos.sources"):  # fmt: skip
        config_from_dict({"photos": {"sources": ["skimage-data"], "held_out": ["skimage-data"]}})
    with pytest.raises(ConfigError, match=r"photos.sources: expected one of \[.*\] \(library source\), got 'flickr'"):  # fmt: skip
        config_from_dict({"photos": {"sources": ["flickr"]}})
    assert not config_from_dict({"photos": {"enabled": False, "sources": []}}).photos.enabled


def test_a_photograph_turned_by_its_exif_orientation_is_stored_upright():
    """A phone's JPEG stores 60x40 pixels and says "turn me 90 degrees" (EXIF orientation 6):
    OpenCV's colour decoding turns it, and the bounded decoder accepts the turned size."""
    import io

    import numpy as np
    from PIL import Image

    exif = Image.Exif()
    exif[0x0112] = 6
    buffer = io.BytesIO()
    Image.fromarray(np.zeros((40, 60, 3), np.uint8)).save(buffer, "JPEG", exif=exif.tobytes())
    _, width, height = installer._stored_picture(buffer.getvalue(), "turned.jpg")
    assert (width, height) == (40, 60)
