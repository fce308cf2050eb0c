"""COCO instance annotations: ``DIR/coco/annotations.json`` and ``DIR/coco/images/*.png``.

One COCO image per labelled view (``datagen.dataset.views``: each camera of a sample, e.g. the
workspace camera, the extra views ``view1``, ... of ``render.views`` and the wrist camera; each
frame of a sequence, e.g. a navigation episode); ``datagen_view`` names it ("" = workspace).
Annotations carry the visible mask as RLE, its box and area, plus datagen's ``instance_id`` and
``visible_fraction`` where known. Category ids are the dataset's class ids, so they equal the
values in ``semantic.png``; a grasp scene's robot arm and gripper are annotations too
(categories ``robot`` and ``gripper``), after its objects.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from pycocotools import mask as mask_utils

from datagen.dataset.views import labelled_views, thing_classes
from datagen.exports.checks import sample_metadata, strict_json, view_boxes, view_camera
from datagen.exports.files import inside
from datagen.images import decode_image
from datagen.records import ExportedDataset, Manifest, SampleProgress


def _rle(mask: np.ndarray) -> dict[str, Any]:
    rle = mask_utils.encode(np.asfortranarray(mask.astype(np.uint8)))
    return {"size": [int(v) for v in rle["size"]], "counts": rle["counts"].decode("ascii")}


def export(
    dataset: ExportedDataset,
    manifest: Manifest,
    out: Path,
    on_progress: SampleProgress | None = None,
) -> list[Path]:
    """Writes into ``out`` (a fresh directory); returns the files written."""
    images_dir = out / "images"
    images_dir.mkdir(parents=True)
    classes = dataset.metadata(0)["classes"] if len(dataset) else manifest.get("classes", [])
    categories = thing_classes(classes)
    images: list[dict[str, object]] = []  # COCO's records
    annotations: list[dict[str, object]] = []
    for i in range(len(dataset)):
        key, meta = dataset.keys[i], sample_metadata(dataset, i)
        views = labelled_views(meta)
        wanted = {f"{v.prefix}{part}" for v in views for part in ("rgb.png", "seg.png")}
        raw = dataset.raw(i, wanted)
        for view in views:
            file_name = f"{key}.{view.prefix}png"
            inside(images_dir, file_name).write_bytes(raw[f"{view.prefix}rgb.png"])  # as stored
            seg = decode_image(raw[f"{view.prefix}seg.png"], what=f"part {view.prefix}seg.png")
            view_camera(view)  # checked; written as stored
            boxes = view_boxes(view, (seg.shape[1], seg.shape[0]))
            image_id = len(images) + 1
            images.append(
                {
                    "id": image_id,
                    "file_name": file_name,
                    "width": int(seg.shape[1]),
                    "height": int(seg.shape[0]),
                    "datagen_key": key,
                    "datagen_view": view.name,
                    "intrinsics": view.camera["intrinsics"],
                    "extrinsics_world_to_camera": view.camera["extrinsics_world_to_camera"],
                }
            )
            for inst, (x0, y0, x1, y1) in zip(view.instances, boxes, strict=True):
                mask = seg == inst["instance_id"]
                annotation = {
                    "id": len(annotations) + 1,
                    "image_id": image_id,
                    "category_id": categories[inst["class"]],
                    "iscrowd": 0,
                    "bbox": [x0, y0, x1 - x0 + 1, y1 - y0 + 1],
                    "area": int(mask.sum()),
                    "segmentation": _rle(mask),
                    "instance_id": inst["instance_id"],
                }
                if "visible_fraction" in inst:
                    annotation["visible_fraction"] = inst["visible_fraction"]
                annotations.append(annotation)
        if on_progress:
            on_progress(i + 1, len(dataset))
    doc = {
        "info": {
            "description": f"datagen {manifest.get('config', {}).get('scene', '')} dataset",
            "version": manifest.get("datagen_version", ""),
            "build_id": manifest.get("build_id", ""),
            "seed": manifest.get("seed"),
        },
        "licenses": [],
        "images": images,
        "annotations": annotations,
        "categories": [
            {"id": cid, "name": name, "supercategory": "thing"} for name, cid in categories.items()
        ],
    }
    path = out / "annotations.json"
    path.write_text(strict_json(doc, "annotations.json", separators=(",", ":")))
    return [path, images_dir]
