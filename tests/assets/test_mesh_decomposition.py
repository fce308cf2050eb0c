"""Users' meshes decomposed once per machine (datagen/assets/mesh_decomposition.py): a warm
cache decomposes nothing, in this process or another; processes starting together decompose
each mesh once between them; the parts read back are the computed ones, bit for bit; an entry
that is not what the cache writes is decomposed again and replaced; no usable cache folder
means decomposing in each process, as before."""

from __future__ import annotations

import io
import json
import os
import subprocess
import sys

import numpy as np
import pytest
import trimesh

from datagen.assets.mesh_decomposition import (
    MAX_PARTS,
    cache_dir,
    entry_bytes,
    entry_key,
    parts_of_entry,
)
from datagen.assets.mesh_library import load_library

# a process that loads the folder argv[1] and prints what it decomposed itself
_LOAD = """
import json, sys
from datagen.assets.mesh_library import load_library
print(json.dumps(load_library(sys.argv[1]).decomposed))
"""


def _folder(root, shapes: dict[str, trimesh.Trimesh]) -> str:
    for relative, mesh in shapes.items():
        (root / relative).parent.mkdir(parents=True, exist_ok=True)
        mesh.export(root / relative)
    return str(root)


@pytest.fixture
def meshes(tmp_path):
    """Four meshes of different cost (a torus: about 1 s of CoACD), each in its class folder."""
    shapes = {
        "ring/torus.obj": trimesh.creation.torus(0.05, 0.015),
        "washer/annulus.stl": trimesh.creation.annulus(0.02, 0.04, 0.05),
        "donut/torus.glb": trimesh.creation.torus(0.05, 0.02, major_sections=16, minor_sections=8),
        "block/box.stl": trimesh.creation.box(extents=[0.05, 0.03, 0.02]),
    }
    return _folder(tmp_path / "meshes", shapes)


@pytest.fixture
def quick(tmp_path):
    """Two meshes CoACD decomposes in milliseconds."""
    shapes = {
        "block/box.stl": trimesh.creation.box(extents=[0.05, 0.03, 0.02]),
        "can/cylinder.obj": trimesh.creation.cylinder(0.03, 0.12),
    }
    return _folder(tmp_path / "quick", shapes)


@pytest.fixture
def cache(tmp_path, monkeypatch):
    """A cold cache of this test's own, for this process and the processes it starts."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    load_library.cache_clear()
    yield cache_dir()
    load_library.cache_clear()


def _fresh_load(root: str):
    load_library.cache_clear()
    return load_library(root)


def _bits(library) -> list[tuple[str, list[tuple[str, bytes]]]]:
    return [(a.path, [(str(p.dtype), p.tobytes()) for p in a.parts]) for a in library.assets]


def _same_parts(first, second) -> bool:
    return _bits(first) == _bits(second)


def test_a_warm_cache_decomposes_nothing_and_gives_the_same_parts_bit_for_bit(meshes, cache):
    cold = _fresh_load(meshes)
    assert sorted(cold.decomposed) == sorted(a.path for a in cold.assets)
    assert len(list(cache.glob("*.npy"))) == 4
    warm = _fresh_load(meshes)
    assert warm.decomposed == [] and _same_parts(cold, warm)
    assert warm.report() == cold.report()  # the manifest's account does not change either
    another_process = subprocess.run(
        [sys.executable, "-c", _LOAD, meshes], capture_output=True, text=True, check=True
    )
    assert json.loads(another_process.stdout) == []  # a worker, or the coordinator's manifest


def test_processes_starting_together_decompose_each_mesh_once_between_them(meshes, cache):
    started = [
        subprocess.Popen([sys.executable, "-c", _LOAD, meshes], stdout=subprocess.PIPE, text=True)
        for _ in range(2)
    ]
    decomposed = [json.loads(p.communicate()[0]) for p in started]
    assert all(p.returncode == 0 for p in started)
    every_mesh = sorted(a.path for a in _fresh_load(meshes).assets)
    assert sorted(decomposed[0] + decomposed[1]) == every_mesh  # none twice, none missed


def test_the_cache_is_named_by_the_mesh_decomposed_not_its_file(quick, cache, tmp_path):
    same = tmp_path / "copy" / "tin"
    same.mkdir(parents=True)
    (same / "renamed.obj").write_bytes((tmp_path / "quick/can/cylinder.obj").read_bytes() + b"\n")
    _fresh_load(quick)
    assert (
        _fresh_load(str(tmp_path / "copy")).decomposed == []
    )  # a trailing newline decides nothing


def _npy(array: np.ndarray) -> bytes:
    buffer = io.BytesIO()
    np.save(buffer, array, allow_pickle=True)
    return buffer.getvalue()


def _part(index: float, points: int = 8) -> np.ndarray:
    """Rows of an entry: a box's corners labelled as part ``index``."""
    corners = trimesh.creation.box(extents=[0.5, 0.5, 0.5]).vertices[:points]
    return np.column_stack([corners, np.full(len(corners), index)])


ONE_BOX = entry_bytes((_part(0)[:, :3],))
CORRUPT = {
    "empty": b"",
    "random bytes": np.random.default_rng(0).bytes(500),
    "truncated": ONE_BOX[:-9],
    "trailing bytes": ONE_BOX + b"\0" * 32,
    "a pickled object array": _npy(np.array([{"a": 1}], dtype=object)),
    "float32": _npy(_part(0).astype(np.float32)),
    "three columns": _npy(_part(0)[:, :3]),
    "a NaN": _npy(np.where(np.arange(32).reshape(8, 4) == 5, np.nan, _part(0))),
    "a point far away": _npy(_part(0) * [[40, 1, 1, 1]]),
    "parts out of order": _npy(np.vstack([_part(1), _part(0)])),
    "a part index of 0.5": _npy(np.vstack([_part(0), _part(0.5)])),
    "too many parts": _npy(np.vstack([_part(i) for i in range(MAX_PARTS + 1)])),
    "a part of three points": _npy(np.vstack([_part(0), _part(1, points=3)])),
    "a declared 10^12 points": ONE_BOX.replace(b"(8, 4)", b"(1000000000000, 4)"),
}


@pytest.mark.parametrize("damage", CORRUPT)
def test_an_entry_that_is_not_what_the_cache_writes_is_refused(damage):
    with pytest.raises(ValueError):
        parts_of_entry(CORRUPT[damage])


def test_an_entry_holds_the_parts_exactly():
    rng = np.random.default_rng(3)
    parts = tuple(rng.uniform(-0.5, 0.5, (n, 3)) for n in (4, 31, 256))
    back = parts_of_entry(entry_bytes(parts))
    assert [p.tobytes() for p in back] == [p.tobytes() for p in parts]


@pytest.mark.parametrize("damage", ["random bytes", "a NaN", "a declared 10^12 points"])
def test_a_corrupt_entry_is_decomposed_again_and_replaced(quick, cache, damage, caplog):
    first = _fresh_load(quick)
    entry = cache / f"{entry_key(first.find('can/cylinder.obj').visual)}.npy"
    entry.write_bytes(CORRUPT[damage])
    again = _fresh_load(quick)
    assert again.decomposed == ["can/cylinder.obj"] and _same_parts(first, again)
    assert f"{entry.name} unusable" in caplog.text
    assert parts_of_entry(entry.read_bytes())  # replaced by a whole entry
    assert _fresh_load(quick).decomposed == []


def test_a_link_in_place_of_an_entry_is_not_followed(quick, cache, tmp_path):
    first = _fresh_load(quick)
    entry = cache / f"{entry_key(first.find('can/cylinder.obj').visual)}.npy"
    elsewhere = tmp_path / "elsewhere.npy"
    elsewhere.write_bytes(entry.read_bytes())
    entry.unlink()
    entry.symlink_to(elsewhere)
    assert _fresh_load(quick).decomposed == ["can/cylinder.obj"]
    assert not entry.is_symlink() and elsewhere.read_bytes() == entry.read_bytes()


def test_without_a_usable_cache_folder_each_process_decomposes_as_before(quick, tmp_path):
    (tmp_path / "not a folder").write_text("")
    env = os.environ | {"XDG_CACHE_HOME": str(tmp_path / "not a folder")}
    run = subprocess.run(
        [sys.executable, "-c", _LOAD, quick], capture_output=True, text=True, env=env, check=True
    )
    assert len(json.loads(run.stdout)) == 2 and "not cached" in run.stderr


@pytest.mark.sim
@pytest.mark.slow
def test_a_sample_made_from_cached_parts_has_the_bytes_of_one_made_from_parts_decomposed_now(
    meshes, cache
):
    from datagen.config import config_from_dict
    from datagen.families.grasp_tabletop.produce import produce

    objects = {"source": "folder", "assets_dir": meshes, "count": [3, 3]}
    config = config_from_dict({"render": {"width": 64, "height": 48}, "objects": objects})
    decomposed_now = produce(config, 5, 1)
    assert load_library(meshes).decomposed  # this process decomposed them
    load_library.cache_clear()
    from_cache = produce(config, 5, 1)
    assert load_library(meshes).decomposed == []
    assert from_cache.parts == decomposed_now.parts
    shapes = [o["shape"] for o in json.loads(from_cache.parts["json"])["objects"]]
    assert any(len(shape["parts"]) > 1 for shape in shapes)  # concave meshes, several parts
