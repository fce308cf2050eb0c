"""The YOLO export (docs/export-yolo.md), written by the real command line from grasp frames (two
cameras) and navigation episodes (a sequence of frames), checked by an independent reader of
ultralytics' rules (yolo_checker.py) and against the dataset's own records."""

from __future__ import annotations

import hashlib
from pathlib import Path

import cv2
import numpy as np
import pytest
from conftest import export_copy  # tests/conftest.py: copy a session dataset, export it
from yolo_checker import Row, box_pixels, check_tree, polygon_mask  # tests/exports

import datagen
from datagen.dataset.views import labelled_views
from datagen.exports.yolo import polygon

REPO = Path(__file__).resolve().parents[2]
STUFF = {"background", "floor", "wall", "table", "tray"}  # docs/export-yolo.md: not counted


def _split(key: str) -> str:  # docs/export-yolo.md, written here from the page
    return "val" if int.from_bytes(hashlib.sha256(key.encode()).digest()[:8], "big") % 100 < 10 else "train"  # fmt: skip


def _export(source: Path, tmp_path: Path) -> Path:
    root = tmp_path / source.name
    done = export_copy(source, root, "yolo")
    assert done.returncode == 0, done.stderr[-2000:]
    return root


def _holes(mask: np.ndarray) -> int:
    """Background regions (4-connected) enclosed by the mask."""
    padded = np.pad(~mask, 1, constant_values=True).astype(np.uint8)
    return cv2.connectedComponents(padded, connectivity=4)[0] - 2


@pytest.fixture(params=["frames_dataset", "navigation_dataset"])
def source(request) -> Path:
    return request.getfixturevalue(request.param)


@pytest.mark.sim
def test_yolo_export_follows_ultralytics_rules_and_our_records(source, tmp_path):
    root = _export(source, tmp_path)
    dataset = datagen.load(root)
    classes = dataset.metadata(0)["classes"]
    names = [c for c in classes if c not in STUFF]
    trees = {}
    for task in ("detect", "segment"):
        data, images = check_tree(root / "yolo" / task, task)
        assert list(data["names"].values()) == names
        trees[task] = {image.path.name: image for image in images}
    assert trees["detect"].keys() == trees["segment"].keys()
    views = 0
    for i in range(len(dataset)):
        key = dataset.keys[i]
        for view in labelled_views(dataset.metadata(i)):
            views += 1
            name = f"{key}.{view.prefix}png"
            parts = dataset.raw(i, {f"{view.prefix}rgb.png", f"{view.prefix}seg.png"})
            seg = cv2.imdecode(np.frombuffer(parts[f"{view.prefix}seg.png"], np.uint8), -1)
            detect, segment = trees["detect"][name], trees["segment"][name]
            assert detect.split == segment.split == _split(key)
            assert detect.path.read_bytes() == parts[f"{view.prefix}rgb.png"]  # our PNG
            assert segment.path.read_bytes() == parts[f"{view.prefix}rgb.png"]
            assert (detect.width, detect.height) == (seg.shape[1], seg.shape[0])
            assert len(detect.rows) == len(segment.rows) == len(view.instances)
            for box, outline, inst in zip(detect.rows, segment.rows, view.instances, strict=True):
                assert names[box.cls] == names[outline.cls] == inst["class"]
                x0, y0, x1, y1 = inst["bbox_xyxy"]  # inclusive pixels: edges x0 .. x1 + 1
                edges = box_pixels(box, detect.width, detect.height)
                assert np.allclose(edges, (x0, y0, x1 + 1, y1 + 1), atol=1.0), (name, inst)
                # the polygon as ultralytics fills it: every pixel of the instance, and beyond
                # them only the bridges joining its pieces and holes (docs/export-yolo.md)
                mask, filled = seg == inst["instance_id"], polygon_mask(outline, segment.width, segment.height)  # fmt: skip
                assert not (mask & ~filled).any(), (name, inst)
                pieces = cv2.connectedComponents(mask.astype(np.uint8), connectivity=8)[0] - 1
                bridges = pieces - 1 + _holes(mask)
                extra = int((filled & ~mask).sum()) + int((mask & ~filled).sum())
                assert extra <= bridges * ((x1 - x0 + 1) + (y1 - y0 + 1)), (name, inst, extra)
                assert not filled[:y0].any() and not filled[y1 + 1 :].any()
                assert not filled[:, :x0].any() and not filled[:, x1 + 1 :].any()
    assert len(trees["detect"]) == views
    if source.name == "frames":  # the page's snippet, as printed
        doc = (REPO / "docs" / "export-yolo.md").read_text()
        marker = "<!-- snippet: tested by tests/exports/test_yolo.py -->\n```python\n"
        code = doc.split(marker, 1)[1].split("```", 1)[0]
        code = code.replace("datasets/grasp_tabletop", str(root))
        exec(compile(code, "export-yolo.md", "exec"), {})


def test_polygon_of_pieces_and_holes_fills_back_to_the_mask():
    """A ring (one hole), a lone pixel and a 1-pixel line: one polygon of them, filled as
    ultralytics fills it, is the mask plus its three bridges (docs/export-yolo.md)."""
    mask = np.zeros((40, 40), np.uint8)
    cv2.circle(mask, (20, 20), 12, 1, -1)
    cv2.circle(mask, (20, 20), 5, 0, -1)
    mask[2, 2], mask[35:38, 30] = 1, 1
    mask = mask.astype(bool)
    outline = polygon(mask)
    row = Row(0, ((outline + 0.5) / 40).ravel())  # as the export normalises it
    filled = polygon_mask(row, 40, 40)
    assert not (mask & ~filled).any()
    assert filled[20, 20] == 0  # the hole stays a hole
    assert 0 < (filled & ~mask).sum() <= 3 * (40 + 40)
    assert polygon(np.zeros((4, 4), bool)) is None
