"""Numbers no format should carry (issue 38, items 8 and 11): a navigation pose of ``1e308`` is
valid JSON and was exported to LeRobot as ``inf`` in its parquet and ``Infinity``/``NaN`` in
``meta/stats.json`` (not JSON); a box of ``1e30`` pixels became YOLO labels of 10^28 and a COCO
box as stored; a focal length of ``1e308`` became BOP's ``cam_K`` and garbage images. And a
LeRobot export failing mid-video printed two PyAV ``OutputContainer.__dealloc__`` tracebacks
after its one-line error.

Now every export applies the rules of ``datagen.dataset.values`` (those ``inspect`` applies)
to what it writes: every number of a sample's metadata finite and within float32's range, boxes
inside their image, intrinsics and poses sane, episodes finite as float32. An export refuses the
dataset at the first sample that breaks one (an export holds every sample or none: a training
set must not silently lose samples), in one line naming the sample and the key, exit 2, keeping
nothing; every JSON file is strict. A failing LeRobot export closes its videos before the
runner removes its folder, so that its one line is all it prints."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from adversarial.hostile_exports import (
    GRASP_KEY,
    cli,
    forged,
    grasp_source,
    navigation_source,
    real_cli,
)
from adversarial.refusals import refused

pytestmark = [pytest.mark.adversarial, pytest.mark.sim]
NAV_KEY = "000000000"


def _workspace(meta):
    return meta["views"]["workspace"]


def _box(meta):
    _workspace(meta)["objects"][0]["bbox_xyxy"] = [0, 0, 1e30, 1e30]


def _focal(meta):
    _workspace(meta)["camera"]["render_intrinsics"][0][0] = 1e308


def _pose(meta):
    _workspace(meta)["objects"][0]["pose_camera"]["matrix"][0][3] = 1e307


def _off_image(meta):
    _workspace(meta)["objects"][0]["bbox_xyxy"] = [0, 0, 1000, 1000]  # finite, outside 64x48


def _bad_focal(meta):
    _workspace(meta)["camera"]["intrinsics"][0][0] = 2e6  # finite, float32, beyond any camera


@pytest.mark.parametrize(
    ("fmt", "change", "named"),
    [
        (
            "yolo",
            _box,
            "instance 1 bbox_xyxy: expected whole pixel indices [x0, y0, x1, y1] with 0 <= x0 <= x1 < 64 and 0 <= y0 <= y1 < 48, got [0, 0, 1e+30, 1e+30]",
        ),
        (
            "coco",
            _box,
            "instance 1 bbox_xyxy: expected whole pixel indices [x0, y0, x1, y1] with 0 <= x0 <= x1 < 64 and 0 <= y0 <= y1 < 48, got [0, 0, 1e+30, 1e+30]",
        ),
        ("yolo", _off_image, "view workspace: instance 1 bbox_xyxy: expected whole pixel"),
        ("coco", _off_image, "view workspace: instance 1 bbox_xyxy: expected whole pixel"),
        ("bop", _focal, "views.workspace.camera.render_intrinsics[0][0] is 1e+308"),
        ("bop", _pose, "views.workspace.objects[0].pose_camera.matrix[0][3] is 1e+307"),
        ("bop", _bad_focal, "view workspace: camera.intrinsics: expected"),
        ("coco", _bad_focal, "view workspace: camera.intrinsics: expected"),
        ("hdf5", _focal, "views.workspace.camera.render_intrinsics[0][0] is 1e+308"),
        ("usd", _pose, "views.workspace.objects[0].pose_camera.matrix[0][3] is 1e+307"),
    ],
)
def test_a_value_no_format_can_carry_refuses_the_export_naming_the_key(
    tmp_path_factory, tmp_path, fmt, change, named
):
    root = forged(grasp_source(tmp_path_factory), tmp_path / "ds", meta=change)
    refused(
        cli("export", root, "--to", fmt), str(root), f"sample {GRASP_KEY}", f"{fmt} export", named
    )
    assert not list(root.glob(f"*{fmt}*")) and not (root / "episodes.h5").exists()


@pytest.mark.parametrize("fmt", ["lerobot", "robomimic", "hdf5"])
def test_a_pose_of_1e308_refuses_the_episode_exports(tmp_path_factory, tmp_path, fmt):
    def change(meta):
        meta["frames"][1]["pose"][0] = 1e308

    root = forged(navigation_source(tmp_path_factory), tmp_path / "ds", meta=change, key=NAV_KEY)
    named = "part json: frames[1].pose[0] is 1e+308; expected a finite number within +-3.4e+38"
    refused(cli("export", root, "--to", fmt), str(root), f"sample {NAV_KEY}", named)
    assert not (root / fmt).exists() and not (root / "episodes.h5").exists()


def test_a_failing_lerobot_export_prints_its_one_line_and_nothing_after(tmp_path_factory, tmp_path):
    """A late frame of another size fails the export once the video file has begun."""
    small = cv2.imencode(".png", np.zeros((8, 8, 3), np.uint8))[1].tobytes()
    source = navigation_source(tmp_path_factory)
    root = forged(source, tmp_path / "ds", parts={"f0010.rgb.png": small}, key=NAV_KEY)

    result = real_cli("export", root, "--to", "lerobot")
    refused(result, str(root), f"sample {NAV_KEY}", "a 8x8 frame among 96x72 ones")
    assert "__dealloc__" not in result[2]
    assert not (root / "lerobot").exists() and not list(root.glob(".lerobot*"))
