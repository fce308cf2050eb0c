"""Ultralytics YOLO detection and segmentation datasets: ``DIR/yolo/detect/`` and
``DIR/yolo/segment/``, each ``data.yaml`` + ``images/{train,val}/`` + ``labels/{train,val}/``.

Layout and every mapping decision: docs/export-yolo.md. In short: one image per labelled view
(``datagen.dataset.views``, as in the COCO export), named ``<key>.<view>.png`` (the workspace
camera: ``<key>.png``), the sample's stored PNG as it is; the segment tree's images are hard links
to the detect tree's (a copy where the file system has no links). One label file per image (empty
when nothing is visible): ``class cx cy w h`` in detect, ``class x1 y1 ... xn yn`` in segment, all
normalised to [0, 1] by the image size. Class ids are the countable classes
(``thing_classes``) numbered 0..nc-1 in the dataset's class order. The split is by sample key
(``datagen.exports.splits``): every view of a sample is in the same split.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import cv2
import numpy as np
import yaml

from datagen.dataset.views import LabelledView, labelled_views, thing_classes
from datagen.exports.checks import sample_metadata, view_boxes
from datagen.exports.files import inside
from datagen.exports.splits import split_of
from datagen.images import decode_image
from datagen.records import ExportedDataset, Manifest, SampleProgress

TASKS = ("detect", "segment")
SPLITS = ("train", "val")
PARTIAL = ".partial"  # the runner writes into .NAME.partial and renames it to NAME when done


def export(
    dataset: ExportedDataset,
    manifest: Manifest,
    out: Path,
    on_progress: SampleProgress | None = None,
) -> list[Path]:
    """Writes ``out/detect`` and ``out/segment`` (``out``: a fresh folder); returns them."""
    classes = dataset.metadata(0)["classes"] if len(dataset) else manifest.get("classes", [])
    ids = {name: k for k, name in enumerate(thing_classes(classes))}  # class name -> YOLO id
    trees = {task: out / task for task in TASKS}
    for tree in trees.values():
        for split in SPLITS:
            (tree / "images" / split).mkdir(parents=True)
            (tree / "labels" / split).mkdir(parents=True)
    for i in range(len(dataset)):
        key, meta = dataset.keys[i], sample_metadata(dataset, i)
        views = labelled_views(meta)
        wanted = {f"{v.prefix}{part}" for v in views for part in ("rgb.png", "seg.png")}
        raw = dataset.raw(i, wanted)
        split = split_of(key)
        for view in views:
            image = inside(trees["detect"] / "images" / split, f"{key}.{view.prefix}png")
            image.write_bytes(raw[f"{view.prefix}rgb.png"])  # as stored
            _link(image, inside(trees["segment"] / "images" / split, image.name))
            seg = decode_image(raw[f"{view.prefix}seg.png"], what=f"part {view.prefix}seg.png")
            boxes, polygons = _labels(view, seg, ids)
            label = f"{key}.{view.prefix}txt"
            inside(trees["detect"] / "labels" / split, label).write_text(boxes)
            inside(trees["segment"] / "labels" / split, label).write_text(polygons)
        if on_progress:
            on_progress(i + 1, len(dataset))
    names = {k: name for name, k in ids.items()}
    has_val = any((trees["detect"] / "images" / "val").iterdir())
    for tree in trees.values():
        _data_yaml(tree, _final(out) / tree.name, names, manifest, has_val)
    return list(trees.values())


def _link(source: Path, path: Path) -> None:
    try:
        os.link(source, path)
    except OSError:  # no hard links here (another file system type): a copy
        path.write_bytes(source.read_bytes())


def _final(out: Path) -> Path:
    """Where ``out`` will be once the runner has renamed it into place (``out`` itself when it
    is not the runner's ``.NAME.partial``)."""
    name = out.name
    if name.startswith(".") and name.endswith(PARTIAL):
        name = name[1 : -len(PARTIAL)]
    return out.parent.resolve() / name


def _data_yaml(
    tree: Path, final: Path, names: dict[int, str], manifest: Manifest, has_val: bool
) -> None:
    """``has_val``: whether any sample fell in the validation split; a dataset too small for
    one (about 10 % of the keys are) validates on its training images, since ultralytics stops
    on an empty validation folder."""
    val = "images/val" if has_val else "images/train"
    doc = {"path": str(final), "train": "images/train", "val": val, "names": names}
    scene, build = (_quoted(manifest.get(k, "")) for k in ("scene", "build_id"))
    header = (
        f"# datagen {tree.name} dataset of scene {scene}, build {build}: docs/export-yolo.md\n"
        "# moved elsewhere? set path to this folder, or delete it (ultralytics then uses the "
        "folder of this file)\n"
    )
    if not has_val:
        header += "# no sample fell in the validation split (images/val is empty): val = train\n"
    (tree / "data.yaml").write_text(header + yaml.safe_dump(doc, sort_keys=False))


def _quoted(value: object) -> str:
    """``value`` as a JSON string, ASCII: in a YAML comment it cannot end the line."""
    return json.dumps(str(value))


def _number(value: float) -> str:
    return f"{value:.6f}"


def _labels(view: LabelledView, seg: np.ndarray, ids: dict[str, int]) -> tuple[str, str]:
    """The view's detect and segment label files' text."""
    height, width = seg.shape[:2]
    boxes, polygons = [], []
    for inst, (x0, y0, x1, y1) in zip(
        view.instances, view_boxes(view, (width, height)), strict=True
    ):
        cls = ids[inst["class"]]  # the box: inclusive pixel indices
        box = ((x0 + x1 + 1) / 2 / width, (y0 + y1 + 1) / 2 / height)
        size = ((x1 - x0 + 1) / width, (y1 - y0 + 1) / height)
        boxes.append(" ".join([str(cls), *map(_number, (*box, *size))]))
        points = polygon(seg == inst["instance_id"])
        if points is not None:
            scaled = (points + 0.5) / np.array([width, height])  # pixel centres, normalised
            polygons.append(" ".join([str(cls), *map(_number, scaled.ravel())]))
    return "".join(f"{row}\n" for row in boxes), "".join(f"{row}\n" for row in polygons)


def polygon(mask: np.ndarray) -> np.ndarray | None:
    """One closed outline of a mask, (K >= 3, 2) pixel (x, y) indices, or None for an empty mask.

    The contours of its pieces and of their holes (OpenCV, two levels), joined into one polygon
    as ultralytics' ``merge_multi_segment`` joins a COCO object's polygons: each hole into its
    piece, then each further piece (largest first) into the outline, spliced in at their nearest
    points, the way there and back along one zero-width bridge. Filled as ultralytics fills it
    (``cv2.fillPoly``), it gives back the mask's pixels, its holes left empty, plus the bridges'
    pixels. A contour of 1 or 2 points (a lone pixel, a 1-pixel line) is walked there and back.
    """
    contours, hierarchy = cv2.findContours(
        mask.astype(np.uint8), cv2.RETR_CCOMP, cv2.CHAIN_APPROX_SIMPLE
    )
    if not contours:
        return None
    parents = hierarchy[0, :, 3]
    pieces = []
    for k, contour in enumerate(contours):
        if parents[k] < 0:
            outline = _corners(contour.reshape(-1, 2))
            for hole in (c for j, c in enumerate(contours) if parents[j] == k):
                outline = _splice(outline, _corners(hole.reshape(-1, 2)))
            pieces.append((cv2.contourArea(contour), outline))
    pieces.sort(key=lambda piece: -piece[0])
    outline = pieces[0][1]
    for _, piece in pieces[1:]:
        outline = _splice(outline, piece)
    return outline


def _splice(outline: np.ndarray, piece: np.ndarray) -> np.ndarray:
    """``outline`` with ``piece`` walked round from their nearest points, and back."""
    distance = ((outline[:, None, :] - piece[None, :, :]) ** 2).sum(-1)
    a, b = np.unravel_index(int(distance.argmin()), distance.shape)
    loop = np.concatenate([piece[b:], piece[: b + 1]])  # around the piece, back to b
    return np.concatenate([outline[: a + 1], loop, outline[a:]])


def _corners(points: np.ndarray) -> np.ndarray:
    """A contour of 1 or 2 points (a lone pixel, a line) walked there and back: 3 points."""
    if len(points) >= 3:
        return points
    return np.concatenate([points, points[::-1]])[:3] if len(points) == 2 else points[[0, 0, 0]]
