"""An independent check of an ultralytics YOLO dataset tree, written from ultralytics' rules
(``ultralytics/data/utils.py``: ``check_det_dataset``, ``img2label_paths``,
``verify_image_label``, ``polygon2mask``) and not from datagen's writer, which it does not import.

``check_tree(tree, task)`` reads ``tree/data.yaml`` and every image and label file of its splits
and raises AssertionError naming the file at the first broken rule; it returns what it read, for
a test to compare with the dataset's own records.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
import yaml

IMAGE_SUFFIXES = {"bmp", "dng", "jpeg", "jpg", "mpo", "png", "tif", "tiff", "webp", "pfm", "heic"}
MIN_IMAGE_PX = 10  # verify_image_label: "image size <10 pixels"


@dataclass
class Row:
    cls: int
    values: np.ndarray  # normalised: cx cy w h (detect) or x1 y1 ... xn yn (segment)


@dataclass
class Image:
    path: Path
    split: str
    width: int
    height: int
    rows: list[Row]


def label_path(image: Path) -> Path:
    """img2label_paths: the last ``/images/`` becomes ``/labels/``, the suffix ``.txt``."""
    images, labels = f"{os.sep}images{os.sep}", f"{os.sep}labels{os.sep}"
    text = str(image)
    head, tail = text.rsplit(images, 1)
    return Path(labels.join([head, tail]).rsplit(".", 1)[0] + ".txt")


def check_tree(tree: Path, task: str) -> tuple[dict, list[Image]]:
    """(data.yaml, every image with its label rows) of ``tree``; ``task``: detect or segment."""
    data = yaml.safe_load((tree / "data.yaml").read_text())
    missing = {"path", "train", "val", "names"} - set(data)
    assert not missing, f"{tree}/data.yaml: keys {sorted(missing)} missing"
    root = Path(data["path"])
    assert root.is_absolute() and root.resolve() == tree.resolve(), f"path {root} is not {tree}"
    names = data["names"]
    assert isinstance(names, dict) and sorted(names) == list(range(len(names))), names
    assert all(isinstance(n, str) and n for n in names.values()), names
    images, labels_seen, folders = [], set(), set()
    for split in ("train", "val"):
        folder = root / data[split]
        assert folder.is_dir(), f"{folder}: the {split} images folder is missing"
        if folder in folders:  # a dataset too small for a validation split validates on train
            assert not any((root / "images" / split).iterdir()), f"{split}: images not read"
            continue
        folders.add(folder)
        for path in sorted(folder.iterdir()):
            assert path.suffix[1:].lower() in IMAGE_SUFFIXES, f"{path}: not an image suffix"
            picture = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
            assert picture is not None, f"{path}: unreadable"
            height, width = picture.shape[:2]
            assert min(height, width) >= MIN_IMAGE_PX, f"{path}: {width}x{height} < 10 px"
            label = label_path(path)
            assert label.is_file(), f"{path}: no label file {label}"
            labels_seen.add(label)
            rows = _rows(label, task, len(names))
            images.append(Image(path, folder.name, width, height, rows))
    every_label = {p for p in (root / "labels").rglob("*.txt")}
    assert every_label == labels_seen, f"labels without an image: {every_label - labels_seen}"
    return data, images


def _rows(label: Path, task: str, nc: int) -> list[Row]:
    rows, lines = [], [line.split() for line in label.read_text().splitlines() if line.strip()]
    assert len({tuple(line) for line in lines}) == len(lines), f"{label}: duplicate rows"
    for line in lines:
        if task == "detect":
            assert len(line) == 5, f"{label}: a detect row has 5 columns: {line}"
        else:
            assert len(line) >= 7 and len(line) % 2 == 1, f"{label}: a polygon of < 3 points"
        assert line[0].isdigit(), f"{label}: class {line[0]!r} is not an integer"
        cls, values = int(line[0]), np.array([float(v) for v in line[1:]])
        assert 0 <= cls < nc, f"{label}: class {cls} not below nc {nc}"
        assert np.all((values >= 0) & (values <= 1)), f"{label}: a coordinate outside [0, 1]"
        if task == "detect":
            assert np.all(values[2:] > 0), f"{label}: a box of no size"
        rows.append(Row(cls, values))
    return rows


def box_pixels(row: Row, width: int, height: int) -> tuple[float, float, float, float]:
    """A detect row as pixel edges (left, top, right, bottom)."""
    cx, cy, w, h = row.values * np.array([width, height, width, height])
    return cx - w / 2, cy - h / 2, cx + w / 2, cy + h / 2


def polygon_mask(row: Row, width: int, height: int) -> np.ndarray:
    """A segment row filled as ultralytics' ``polygon2mask`` does: scaled to pixels, truncated to
    int32, ``cv2.fillPoly``; (H, W) bool."""
    points = (row.values.reshape(-1, 2) * np.array([width, height])).astype(np.int32)
    mask = np.zeros((height, width), np.uint8)
    cv2.fillPoly(mask, [points], color=1)
    return mask.astype(bool)
