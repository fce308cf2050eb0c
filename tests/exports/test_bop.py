"""``datagen export DIR --to bop`` (docs/export-bop.md) on real rendered grasp samples, read back
with a reader written from the BOP format's documentation (tests/exports/bop_reader.py): model
points land in the visible masks where the depth image sees them, the masks agree with
scene_gt_info, models_info with the PLY models, obj ids with the samples' shapes."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest
from bop_reader import bbox, images, load_ply, project  # tests/exports
from conftest import export_copy  # tests/conftest.py: copy a session dataset, export it

import datagen

pytestmark = pytest.mark.sim
REPO = Path(__file__).resolve().parents[2]
REVOLVED = {"cylinder", "capsule", "can", "bottle", "bowl"}
# drawn as their convex parts, the silhouette datagen measures visible_fraction against
PARTS_DRAWN = {"box", "cylinder", "sphere", "capsule", "convex", "compound"}


def _export(source: Path, tmp_path: Path) -> Path:
    root = tmp_path / "ds"
    done = export_copy(source, root, "bop")
    assert done.returncode == 0, done.stderr[-3000:]
    return root


def _surface_points(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """The vertices and, on every triangle, its centroid and the midpoints towards its corners."""
    tri = vertices[faces]
    centroid = tri.mean(1, keepdims=True)
    return np.concatenate([vertices, centroid[:, 0], *(((tri + centroid) / 2).transpose(1, 0, 2))])


def _check_models(bop: Path, metas: list[dict]) -> dict[int, tuple[np.ndarray, np.ndarray, str]]:
    info = json.loads((bop / "models" / "models_info.json").read_text())
    records = json.loads((bop / "models" / "models_datagen.json").read_text())
    objects = {(m["key"], o["instance_id"]): o for m in metas for o in m["objects"]}
    distinct = {json.dumps(o["shape"], sort_keys=True) for o in objects.values()}
    assert len(info) == len(records) == len(distinct)  # one model per distinct shape
    shapes = {
        int(i): json.dumps(objects[r["first_seen"]["key"], r["first_seen"]["instance_id"]]["shape"], sort_keys=True)
        for i, r in records.items()
    }  # fmt: skip
    assert set(shapes.values()) == distinct
    models = {}
    for obj_id, record in info.items():
        vertices, faces = load_ply(bop / "models" / f"obj_{int(obj_id):06d}.ply")
        lo, hi = vertices.min(0), vertices.max(0)
        np.testing.assert_allclose([record[f"min_{a}"] for a in "xyz"], lo, atol=1e-3)
        np.testing.assert_allclose([record[f"size_{a}"] for a in "xyz"], hi - lo, atol=1e-3)
        np.testing.assert_allclose((lo + hi) / 2, 0, atol=1e-3)  # origin at the box's centre
        pairwise = np.linalg.norm(vertices[:, None] - vertices[None], axis=-1).max()
        assert record["diameter"] == pytest.approx(pairwise, abs=1e-3)
        for sym in record.get("symmetries_discrete", []):  # maps the vertices onto themselves
            moved = vertices @ np.reshape(sym, (4, 4))[:3, :3].T
            gaps = np.linalg.norm(moved[:, None] - vertices[None], axis=-1).min(1)
            assert gaps.max() < 1e-3 * record["diameter"] + 1e-4
        family = records[obj_id]["family"]
        axes = [s["axis"] for s in record.get("symmetries_continuous", [])]
        if family in REVOLVED:
            assert [0, 0, 1] in axes, (family, record)
        discrete = record.get("symmetries_discrete", [])
        if family == "box":  # a box has its three half turns, more where two sides are equal
            assert not axes and len(discrete) >= 3
        if family in ("convex", "mug"):
            assert not axes and not discrete
        models[int(obj_id)] = (vertices, faces, shapes[int(obj_id)])
    return models


@pytest.mark.parametrize("fixture", ["frames_dataset", "campaign_dataset"])
def test_bop_export_reads_back_as_the_format_documents(fixture, request, tmp_path):
    root = _export(request.getfixturevalue(fixture), tmp_path)
    check_export(root)
    if fixture == "frames_dataset":  # the page's snippet, as printed, on this export
        doc = (REPO / "docs" / "export-bop.md").read_text()
        marker = "<!-- snippet: tested by tests/exports/test_bop.py -->\n```python\n"
        code = doc.split(marker, 1)[1].split("```", 1)[0]
        exec(compile(code.replace("datasets/mine", str(root)), "export-bop.md", "exec"), {})


def check_export(root: Path) -> None:
    dataset = datagen.load(root)
    metas = [dataset.metadata(i) for i in range(len(dataset))]
    bop = root / "bop"
    models = _check_models(bop, metas)
    seen = on_mask = projected = near_silhouette = pinhole_checked = 0
    for image in images(bop):
        meta = metas[int(image.scene.name)]
        view = meta["views"][image.camera["datagen_view"]]
        assert len(image.gts) == len(meta["objects"])
        h, w = image.depth_mm.shape
        if "distortion" not in view["camera"]:  # the stored images, the colour one as JPEG
            item = dataset[int(image.scene.name)]
            stored = item if view is meta["views"]["workspace"] else item["views"][image.camera["datagen_view"]]  # fmt: skip
            assert cv2.PSNR(np.ascontiguousarray(image.rgb()[..., ::-1]), stored["rgb"]) > 28  # dB
            np.testing.assert_array_equal(image.depth_mm, stored["depth"])
        for gt_id, (gt, obj) in enumerate(zip(image.gts, meta["objects"], strict=True)):
            info, visib, whole = gt["info"], image.mask(gt_id, True), image.mask(gt_id, False)
            assert info["px_count_visib"] == visib.sum() and not (visib & ~whole).any()
            assert info["bbox_visib"] == bbox(visib)
            assert info["visib_fract"] == pytest.approx(info["px_count_visib"] / max(info["px_count_all"], 1))  # fmt: skip
            x, y, bw, bh = info["bbox_obj"]
            if x >= 0 and y >= 0 and x + bw < w and y + bh < h:  # not truncated: all of it here
                assert info["px_count_all"] == whole.sum() and info["bbox_obj"] == bbox(whole)
            assert info["px_count_valid"] == (whole & (image.depth_mm > 0)).sum()
            record = next(o for o in view["objects"] if o["instance_id"] == obj["instance_id"])
            pinhole = "distortion" not in view["camera"] and obj["shape"]["family"] in PARTS_DRAWN
            if pinhole and record["visible"] and record["in_frame_fraction"] == 1:
                # datagen's own silhouette count (visible pixels / visible fraction)
                assert abs(info["px_count_all"] - record["visible_pixels"] / record["visible_fraction"]) < 0.5  # fmt: skip
                pinhole_checked += 1
            vertices, faces, shape = models[gt["obj_id"]]
            assert shape == json.dumps(obj["shape"], sort_keys=True)  # the object's own model
            uv, z = project(_surface_points(vertices, faces), image.K, gt["R"], gt["t"])
            col, row = np.floor(uv).astype(int).T  # pixel (col, row) spans [col, col + 1)
            inside = (z > 0) & (col >= 0) & (col < w) & (row >= 0) & (row < h)
            col, row, z = col[inside], row[inside], z[inside]
            around = cv2.dilate(whole.astype(np.uint8), np.ones((3, 3), np.uint8)) > 0
            projected += len(z)
            near_silhouette += int(around[row, col].sum())  # within a pixel of the silhouette
            # Seen: the depth image holds the point's depth (within the spread of depths over a
            # pixel's footprint, z / f mm, on a slanted surface), away from the silhouette's
            # edge (a pixel there may show the table the object stands on, at the same depth).
            core = cv2.erode(whole.astype(np.uint8), np.ones((3, 3), np.uint8)) > 0
            depth = image.depth_mm[row, col]
            visible = (depth > 0) & (np.abs(depth - z) < 5 + z / image.K[0, 0]) & core[row, col]
            on_mask += int(visib[row[visible], col[visible]].sum())
            seen += int(visible.sum())
    assert pinhole_checked and seen > 1000, (pinhole_checked, seen)
    assert on_mask >= 0.95 * seen, (on_mask, seen)
    assert near_silhouette >= 0.97 * projected, (near_silhouette, projected)
