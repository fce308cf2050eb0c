"""The tools write only where they say and read only what the dataset's config names (issue 22).

A dataset is hostile input: links planted at the default outputs inside it (``preview.png``,
``replay-KEY.png``, the ``inspect/`` folder and its files) must never carry a tool's writes
outside it: a link at a file's name is replaced by the real output, an ``inspect`` folder that
is a link is refused in one line (exit 2). A sample's metadata that names an asset folder or a
picture outside the folders of the dataset's own config (``objects.assets_dir``,
``materials.textures_dir``, ``background.images_dir``) is refused by ``export --to usd`` and
``replay`` in one line naming the sample and the key, and nothing outside is read: an audit
hook (``sys.addaudithook``) records every file opened and every folder listed under a sentinel
folder, or a listing of ``/``, and stops it.

The samples are the real grasp samples of ``grasp_dataset`` (rendered once per session); the
commands are the real CLI in this process."""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import shutil
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest
from conftest import write_dataset  # tests/conftest.py: shards and a manifest, no MQTT

from adversarial.forged_datasets import snapshot
from adversarial.grasp_dataset import (
    cli,
    grasp_samples,
    metadata,
    usd_dataset,
    with_json,
    write_grasp_dataset,
)
from adversarial.refusals import refused
from datagen.shards import write_json_durably

pytestmark = [pytest.mark.adversarial, pytest.mark.sim]
KEY = "000000000"
PRECIOUS = b"precious: not datagen's to write\n"
PNG = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def exported(tmp_path_factory) -> Path:
    return usd_dataset(tmp_path_factory.mktemp("tools") / "ds", write_dataset)


@pytest.fixture
def dataset(exported, tmp_path) -> Path:
    return Path(shutil.copytree(exported, tmp_path / "ds"))


def victim_file(folder: Path, name: str) -> Path:
    folder.mkdir(exist_ok=True)
    (folder / name).write_bytes(PRECIOUS)
    return folder / name


def replaced(path: Path) -> None:
    """``path`` holds the tool's real output now, not the link planted there."""
    assert not path.is_symlink() and path.is_file()
    assert path.read_bytes().startswith(b"{" if path.suffix == ".json" else PNG)


# -- links planted at the default outputs --------------------------------------------------------


@pytest.mark.parametrize("link", ["symbolic", "hard"])
def test_preview_replaces_a_link_planted_at_its_output(dataset, tmp_path, link):
    victim = victim_file(tmp_path / "home", ".bashrc")
    plant = (dataset / "preview.png").symlink_to if link == "symbolic" else (dataset / "preview.png").hardlink_to  # fmt: skip
    plant(victim)
    code, _, err = cli("preview", dataset)
    assert code == 0, err
    assert victim.read_bytes() == PRECIOUS
    replaced(dataset / "preview.png")
    assert not [p.name for p in dataset.glob(".preview*")]  # no temporary left


def test_inspect_refuses_an_inspect_folder_that_is_a_link(dataset, tmp_path):
    elsewhere = tmp_path / "elsewhere"
    victim_file(elsewhere, "overview.png")
    (dataset / "inspect").symlink_to(elsewhere, target_is_directory=True)
    before = snapshot(elsewhere)
    refused(cli("inspect", dataset), f"{dataset / 'inspect'}", "link")
    assert snapshot(elsewhere) == before


def test_inspect_replaces_links_planted_at_its_files(dataset, tmp_path):
    names = ("overview.png", "distributions.png", "randomisation.png", "summary.json")
    (dataset / "inspect").mkdir()
    victims = [victim_file(tmp_path / "home", name) for name in names]
    for name, victim in zip(names, victims, strict=True):
        (dataset / "inspect" / name).symlink_to(victim)
    code, _, err = cli("inspect", dataset)
    assert code == 0, err
    assert [v.read_bytes() for v in victims] == [PRECIOUS] * len(names)
    for name in names:
        replaced(dataset / "inspect" / name)
    assert sorted(p.name for p in (dataset / "inspect").iterdir()) == sorted(names)


def test_replay_replaces_a_link_planted_at_its_output(dataset, tmp_path):
    victim = victim_file(tmp_path / "home", ".profile")
    (dataset / f"replay-{KEY}.png").symlink_to(victim)
    code, _, err = cli("replay", dataset, KEY)
    assert code == 0, err
    assert victim.read_bytes() == PRECIOUS
    replaced(dataset / f"replay-{KEY}.png")


# -- metadata naming assets outside the config's folders ----------------------------------------

_WATCHED: list[str] = []  # folders nothing may be read from ("/": only its listing)
_READS: list[str] = []


def _audit(event: str, args: tuple) -> None:
    if not _WATCHED or event not in ("open", "os.scandir", "os.listdir"):
        return
    if not args or not isinstance(args[0], str | bytes | os.PathLike):
        return  # a file descriptor
    path = os.path.abspath(os.fsdecode(args[0]))
    for folder in _WATCHED:
        if (path == folder and event != "open") or (folder != "/" and path.startswith(f"{folder}/")):  # fmt: skip
            _READS.append(f"{event} {path}")
            raise PermissionError(13, "read outside the dataset's asset folders", path)


@contextlib.contextmanager
def watching(*folders: Path):
    """Records (and stops) every read in ``folders`` while in the block."""
    if not getattr(sys, "_datagen_tool_outputs_audit", False):
        sys.addaudithook(_audit)  # hooks stay for the process: it does nothing when unwatched
        sys._datagen_tool_outputs_audit = True
    _WATCHED[:], _READS[:] = [str(f) for f in folders], []
    try:
        yield _READS
    finally:
        _WATCHED.clear()


def _mesh(root: str):
    def change(meta: dict) -> None:
        asset = {"root": root, "path": "cup/mesh.obj", "sha256": "0" * 64, "scale": 0.05}
        for shape in (meta["objects"][0]["shape"], meta["randomisation"]["objects"][0]["shape"]):
            shape["asset"] = asset

    return change


def _picture(root: str, path: str, sha256: str = "0" * 64):
    def change(meta: dict) -> None:
        meta["randomisation"]["materials"]["table"]["texture"] = {
            "family": "image", "root": root, "path": path, "sha256": sha256,
            "aspect": 1.0, "scale_m": 0.3, "rotation_deg": 0.0,
        }  # fmt: skip

    return change


# attack (given the sentinel folder and the config's picture folder) -> (change, key named)
ATTACKS = {
    "mesh root /": (lambda s, p: _mesh("/"), "objects[0].shape.asset.root"),
    "mesh root outside": (lambda s, p: _mesh(str(s)), "objects[0].shape.asset.root"),
    "picture root outside": (lambda s, p: _picture(str(s), "pic.png"), "randomisation.materials.table.texture.root"),
    "picture path leading out": (lambda s, p: _picture(str(p), "../sentinel/pic.png"), "randomisation.materials.table.texture.path"),
}  # fmt: skip


def _picture_bytes() -> bytes:
    return cv2.imencode(".png", np.full((16, 16, 3), 200, np.uint8))[1].tobytes()


def _write_picture(path: Path) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(_picture_bytes())


def _stage_with(stage: Path, randomisation: dict) -> None:
    """The stage's ``datagen:randomisation`` replaced by ``randomisation`` (as the attacker
    writes it, so that replay finds the stage and the metadata in agreement)."""
    from pxr import Usd

    opened = Usd.Stage.Open(str(stage))
    opened.GetDefaultPrim().SetCustomDataByKey("datagen:randomisation", json.dumps(randomisation, sort_keys=True))  # fmt: skip
    opened.GetRootLayer().Save()


def _dataset_naming(exported: Path, tmp_path: Path, attack) -> Path:
    """A dataset of the real samples, the first's metadata changed by ``attack(sentinel,
    pictures)``, with ``tmp_path/pictures`` as the config's ``materials.textures_dir`` and the
    stage replay reads made to agree with the metadata; ``tmp_path/sentinel`` holds a mesh and
    a picture that nothing may read."""
    sentinel, pictures = tmp_path / "sentinel", tmp_path / "pictures"
    (sentinel / "cup").mkdir(parents=True)
    (sentinel / "cup" / "mesh.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 2 4\nf 1 3 4\nf 2 3 4\n")  # fmt: skip
    _write_picture(sentinel / "pic.png")
    _write_picture(pictures / "wood.png")  # the config's own folder: readable
    meta = metadata(grasp_samples()[0])
    attack(sentinel, pictures)(meta)
    samples = [with_json(grasp_samples()[0], json.dumps(meta)), grasp_samples()[1]]
    ds = write_grasp_dataset(tmp_path / "ds", samples, write_dataset)
    manifest = json.loads((ds / "manifest.json").read_text())
    manifest["config"]["materials"]["textures_dir"] = str(pictures)
    write_json_durably(ds, manifest)
    shutil.copytree(exported / "usd", ds / "usd")
    _stage_with(ds / "usd" / f"{KEY}.usda", meta["randomisation"])
    return ds


@pytest.mark.parametrize("attack", list(ATTACKS))
def test_metadata_naming_assets_outside_the_configs_folders_is_refused_unread(
    exported, tmp_path, attack
):
    make, key_named = ATTACKS[attack]
    ds = _dataset_naming(exported, tmp_path, make)
    watched = [tmp_path / "sentinel", Path("/")] if "/" in attack else [tmp_path / "sentinel"]
    with watching(*watched) as reads:
        exporting = cli("export", ds, "--to", "usd")
        replaying = cli("replay", ds, KEY)
    assert reads == []
    refused(exporting, f"sample {KEY}", key_named)
    refused(replaying, f"sample {KEY}", key_named)
    assert not (ds / f"replay-{KEY}.png").exists()
    assert json.loads((ds / "manifest.json").read_text()).get("exports") is None


def test_a_picture_of_the_configs_folder_is_still_exported_and_replayed(exported, tmp_path):
    digest = hashlib.sha256(_picture_bytes()).hexdigest()
    ds = _dataset_naming(exported, tmp_path, lambda s, p: _picture(str(p), "wood.png", digest))
    with watching(tmp_path / "sentinel") as reads:
        exporting = cli("export", ds, "--to", "usd")
        replaying = cli("replay", ds, KEY)
    assert reads == []
    assert exporting[0] == 0 and replaying[0] == 0, exporting[2] + replaying[2]
    assert (ds / "usd" / "textures" / KEY / "table.png").is_file()
    replaced(ds / f"replay-{KEY}.png")
