"""A user's mesh with a vertex at 1e300, NaN or infinity (``objects.source: folder``) is refused
when the config is checked, naming the file, like one with too many faces: it never reaches the
workers, where it would be normalised into a point and fail samples (issue 22, medium)."""

from __future__ import annotations

import contextlib
import io
from pathlib import Path

import numpy as np
import pytest
import trimesh

from datagen.cli import main

pytestmark = [pytest.mark.adversarial]

TETRAHEDRON = "v 0 0 0\nv 0.05 0 0\nv 0 0.05 0\nv 0 0 {z}\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"


def check(tmp_path: Path, assets: Path) -> tuple[int, str]:
    config = tmp_path / "meshes.yaml"
    config.write_text(
        f"scene: grasp_tabletop\nobjects:\n  source: folder\n  assets_dir: {assets}\n"
    )
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        code = main(["build", str(config), "--out", str(tmp_path / "out"), "--check"])
    return code, err.getvalue()


@pytest.mark.parametrize("z", ["1e300", "-1e300", "nan", "inf", "1e7"])
def test_an_obj_vertex_out_of_range_is_refused_naming_the_file(tmp_path, z):
    assets = tmp_path / "assets"
    (assets / "mug").mkdir(parents=True)
    trimesh.creation.icosphere(subdivisions=1, radius=0.04).export(assets / "mug" / "good.obj")
    (assets / "mug" / "far.obj").write_text(TETRAHEDRON.format(z=z))
    code, err = check(tmp_path, assets)
    assert code == 2, err
    assert "Traceback" not in err and err.count("\n") == 1, err
    assert "objects.assets_dir" in err and str(assets / "mug" / "far.obj") in err, err
    assert not (tmp_path / "out").exists()


def test_a_binary_stl_with_a_nan_vertex_is_refused(tmp_path):
    assets = tmp_path / "assets"
    (assets / "box").mkdir(parents=True)
    mesh = trimesh.creation.box(extents=[0.05, 0.04, 0.03])
    mesh.vertices[0] = [np.nan, 0.0, 0.0]
    mesh.export(assets / "box" / "box.stl")
    code, err = check(tmp_path, assets)
    assert code == 2 and "box.stl" in err and "non-finite" in err, err


def test_meshes_in_millimetres_pass(tmp_path):
    assets = tmp_path / "assets"
    (assets / "mug").mkdir(parents=True)
    trimesh.creation.icosphere(subdivisions=1, radius=40.0).export(assets / "mug" / "mm.obj")
    code, err = check(tmp_path, assets)
    assert code == 0, err
