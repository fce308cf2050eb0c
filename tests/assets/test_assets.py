"""Users' own meshes (objects.source: folder): every supported format, broken files skipped with
a report, convex decomposition, and a real build whose classes are the folder names."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import trimesh
from pxr import Usd, UsdGeom

from datagen.assets.mesh_library import AssetError, load_library
from datagen.config import BuildConfig as Config
from datagen.config import config_from_dict
from datagen.config.sections import ObjectsConfig, RenderConfig
from datagen.dataset.loader import load, verify
from datagen.errors import ConfigError
from datagen.pipeline.run import run_build


def _usd_cube(path):
    stage = Usd.Stage.CreateNew(str(path))
    mesh = UsdGeom.Mesh.Define(stage, "/cube")
    box = trimesh.creation.box(extents=[0.04, 0.06, 0.03])
    mesh.CreatePointsAttr([tuple(map(float, v)) for v in box.vertices])
    mesh.CreateFaceVertexCountsAttr([3] * len(box.faces))
    mesh.CreateFaceVertexIndicesAttr([int(i) for i in box.faces.ravel()])
    stage.GetRootLayer().Save()


@pytest.fixture(scope="module")
def assets(tmp_path_factory):
    root = tmp_path_factory.mktemp("assets")
    for name in ("mug", "bottle", "toy", "block", "flat"):
        (root / name).mkdir()
    trimesh.creation.torus(0.05, 0.015).export(root / "mug" / "mug.obj")  # concave
    trimesh.creation.cylinder(0.03, 0.12).export(root / "bottle" / "bottle.stl")
    trimesh.creation.box(extents=[0.05, 0.03, 0.02]).export(root / "toy" / "toy.glb")
    _usd_cube(root / "block" / "block.usda")
    (root / "mug" / "empty.obj").write_text("")
    (root / "bottle" / "garbage.stl").write_bytes(np.random.default_rng(0).bytes(300))
    (root / "flat" / "point.obj").write_text("v 0 0 0\nv 0 0 0\nv 0 0 0\nf 1 2 3\n")
    (root / "toy" / "notes.txt").write_text("not a mesh")
    trimesh.creation.box().export(root / "loose.obj")  # not in a class folder
    return root


def test_library_reads_every_format_and_reports_broken_files(assets):
    library = load_library(str(assets))
    assert library.classes == ["block", "bottle", "mug", "toy"]
    skipped = dict(library.skipped)
    assert set(skipped) == {"mug/empty.obj", "bottle/garbage.stl", "flat/point.obj", "loose.obj"}
    assert "class folder" in skipped["loose.obj"]
    for asset in library.assets:
        assert asset.visual.extents.max() == pytest.approx(1.0)
        for part in asset.parts:  # every part is convex and lies within the normalised mesh
            assert trimesh.convex.convex_hull(part).is_convex
            assert (np.abs(part) <= 0.5 + 0.02).all()
    mug = next(a for a in library.assets if a.class_name == "mug")
    assert len(mug.parts) > 1  # the torus is decomposed, not wrapped in one hull


def test_no_usable_mesh_is_a_clear_error(tmp_path):
    (tmp_path / "cls").mkdir()
    (tmp_path / "cls" / "bad.obj").write_text("")
    with pytest.raises(AssetError, match=r"no usable mesh .*cls/bad.obj"):
        load_library(str(tmp_path))
    with pytest.raises(ConfigError, match=r"objects\.assets_dir"):
        config_from_dict({"objects": {"source": "folder", "assets_dir": str(tmp_path / "none")}})


@pytest.mark.sim
@pytest.mark.mqtt
@pytest.mark.slow
def test_build_with_user_meshes(assets, tmp_path):
    config = Config(
        num_samples=4,
        seed=2,
        render=RenderConfig(width=128, height=96),
        objects=dataclasses.replace(
            ObjectsConfig(), source="folder", assets_dir=str(assets), count=(3, 5)
        ),
    )
    run_build(config, tmp_path / "ds", workers=2)
    manifest = verify(tmp_path / "ds")
    classes = manifest["classes"]
    assert manifest["samples"] == 4 and classes[5:9] == ["block", "bottle", "mug", "toy"]
    assert {s["path"] for s in manifest["assets"]["skipped"]} >= {"mug/empty.obj", "bottle/garbage.stl"}  # fmt: skip
    dataset = load(tmp_path / "ds")
    seen = set()
    for item in dataset:
        for obj in item["meta"]["views"]["workspace"]["objects"]:
            if obj["visible"]:
                values = np.unique(item["semantic"][item["seg"] == obj["instance_id"]])
                assert values.tolist() == [classes.index(obj["class"])]
                seen.add(obj["class"])
        for obj in item["meta"]["objects"]:
            assert obj["shape"]["asset"]["path"].split("/")[0] == obj["class"]
    assert len(seen) >= 2
