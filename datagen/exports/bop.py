"""BOP (6D object pose) export of tabletop samples: ``DIR/bop/`` in the layout of the BOP
benchmark's datasets (``docs/export-bop.md`` explains each choice).

``models/`` holds one model per distinct object shape (:mod:`datagen.exports.bop_models`), and
``train_pbr/{scene_id:06d}/`` one scene per sample (its position in the dataset), one image per
labelled camera (``im_id`` 0 = workspace, then view1, ..., wrist): ``rgb/`` (JPEG, as BOP's
PBR scenes), ``depth/`` (16-bit mm, ``depth_scale`` 1.0), ``mask/`` (the whole silhouette,
rasterised from the model) and ``mask_visib/`` (``seg.png == instance_id``) as
``{im_id:06d}_{gt_id:06d}.png``, and
``scene_camera.json``, ``scene_gt.json``, ``scene_gt_info.json``. A view with lens distortion
is resampled to its pinhole ``render_intrinsics`` (BOP has no distortion model). Only the
sample's objects are annotated: distractors and the robot occlude them, as BOP's own
distractors do.
"""

from __future__ import annotations

import functools
from pathlib import Path
from typing import Any, cast

import cv2
import numpy as np

from datagen.dataset.assets import check_asset_paths
from datagen.dataset.parts import decode_parts
from datagen.dataset.values import pose_matrix
from datagen.dataset.views import LabelledView, labelled_views
from datagen.exports.bop_models import ModelSet, dump_json, silhouette
from datagen.exports.checks import (
    lens_distortion,
    sample_metadata,
    strict_json,
    view_camera,
    view_name,
)
from datagen.exports.files import inside, written
from datagen.images import decode_image
from datagen.records import ExportedDataset, Manifest, SampleMetadata, SampleProgress

SPLIT = "train_pbr"  # BOP's name for synthetic training scenes (bop_toolkit's split_type "pbr")
NO_BOX = [-1, -1, -1, -1]  # BOP's box of an empty mask
JPEG_QUALITY = 95  # BlenderProc's BOP writer's


@functools.lru_cache(maxsize=8)
def _undistort_maps(
    K: tuple, D: tuple, K_pinhole: tuple, w: int, h: int
) -> tuple[np.ndarray, np.ndarray]:
    """Per pinhole pixel, the stored (distorted) image's column and row it shows (cv2.remap's
    maps). Pixel centres are (col + .5, row + .5) in K's convention, integers in cv2's."""
    kp = np.asarray(K_pinhole).reshape(3, 3)
    cols, rows = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)
    rays = np.stack(
        [(cols - kp[0, 2]) / kp[0, 0], (rows - kp[1, 2]) / kp[1, 1], np.ones_like(cols)], -1
    )
    uv, _ = cv2.projectPoints(
        rays.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), np.asarray(K).reshape(3, 3), np.asarray(D)
    )
    uv = (uv.reshape(h, w, 2) - 0.5).astype(np.float32)
    return uv[..., 0].copy(), uv[..., 1].copy()


def _box(mask: np.ndarray) -> list[int] | None:
    """[x0, y0, x1, y1] (inclusive) of a mask's pixels; None when it has none."""
    ys, xs = np.nonzero(mask)
    return [int(xs.min()), int(ys.min()), int(xs.max()), int(ys.max())] if len(xs) else None


def _union(*boxes: list[int] | None) -> list[int] | None:
    """The box around the given [x0, y0, x1, y1] boxes (None: none)."""
    found = np.array([b for b in boxes if b])
    return [*found[:, :2].min(0).tolist(), *found[:, 2:].max(0).tolist()] if len(found) else None


def _xywh(box: list[int] | None) -> list[int]:
    """BOP's (x, y, w, h) (bop_toolkit's calc_2d_bbox: w = x_max - x_min), -1s for no box."""
    return [box[0], box[1], box[2] - box[0], box[3] - box[1]] if box else NO_BOX


def _png(path: Path, image: np.ndarray) -> None:
    written(cv2.imwrite(str(path), image), path, "OpenCV")


def _view_images(
    raw: dict[str, bytes], view: LabelledView
) -> tuple[np.ndarray, Any, np.ndarray, np.ndarray, np.ndarray]:
    """(BGR image, the depth image to write: PNG bytes as stored or an array, depth uint16 mm,
    seg ids, K) of a view, undistorted to its pinhole render where it has lens distortion."""
    p, camera = view.prefix, view.camera
    item = decode_parts({"depth.png": raw[f"{p}depth.png"], "seg.png": raw[f"{p}seg.png"]})
    depth, seg = item["depth"], item["seg"]
    K = view_camera(view)[0]
    rgb = decode_image(raw[f"{p}rgb.png"], what=f"part {p}rgb.png", flags=cv2.IMREAD_COLOR)
    if rgb.shape[:2] != seg.shape:
        raise ValueError(f"part {p}rgb.png is not a {seg.shape[1]}x{seg.shape[0]} image")
    if "distortion" not in camera:
        return rgb, raw[f"{p}depth.png"], depth, seg, K
    pinhole = view_camera(view, "render_intrinsics")[0]
    maps = _undistort_maps(
        tuple(K.ravel()), lens_distortion(view), tuple(pinhole.ravel()), seg.shape[1], seg.shape[0]
    )
    rgb = cv2.remap(rgb, *maps, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT)
    depth = cv2.remap(depth, *maps, cv2.INTER_NEAREST, borderMode=cv2.BORDER_CONSTANT)
    seg = cv2.remap(seg, *maps, cv2.INTER_NEAREST, borderMode=cv2.BORDER_CONSTANT)
    return rgb, depth, depth, seg, pinhole


def _object_to_camera(obj: dict[str, Any], view: LabelledView) -> np.ndarray:
    """The view's ``pose_camera`` of the object, else world pose seen through the extrinsics."""
    where = f"{view_name(view)}: instance {obj['instance_id']!r}"
    for seen in cast(dict[str, Any], view.record).get("objects", []):
        if seen.get("instance_id") == obj["instance_id"] and "pose_camera" in seen:
            return pose_matrix(seen["pose_camera"]["matrix"], f"{where} pose_camera.matrix")
    E = view_camera(view)[1]
    return E @ pose_matrix(obj["pose_world"]["matrix"], f"{where} pose_world.matrix")


def _export_view(
    scene: Path,
    im_id: int,
    view: LabelledView,
    raw: dict[str, bytes],
    meta: SampleMetadata,
    models: ModelSet,
) -> tuple[dict[str, Any], list[dict[str, Any]], list[dict[str, Any]]]:
    """Writes one image's files; returns its scene_camera record and scene_gt, scene_gt_info lists."""
    rgb, depth_image, depth, seg, K = _view_images(raw, view)
    h, w = seg.shape
    path = inside(scene, "rgb", f"{im_id:06d}.jpg")  # JPEG: bop_toolkit reads train_pbr's so
    written(cv2.imwrite(str(path), rgb, [cv2.IMWRITE_JPEG_QUALITY, JPEG_QUALITY]), path, "OpenCV")
    path = inside(scene, "depth", f"{im_id:06d}.png")
    if isinstance(depth_image, bytes):
        path.write_bytes(depth_image)  # as stored: a pinhole view
    else:
        _png(path, depth_image)
    E = view_camera(view)[1]
    camera = {
        "cam_K": K.ravel().tolist(),
        "depth_scale": 1.0,
        "cam_R_w2c": E[:3, :3].ravel().tolist(),
        "cam_t_w2c": (E[:3, 3] * 1000).tolist(),
        "datagen_key": meta["key"],
        "datagen_view": view.name or "workspace",
    }
    gts, infos = [], []
    for gt_id, stored in enumerate(meta["objects"]):
        obj = cast(dict[str, Any], stored)  # read as the JSON the sample stored
        model = models.model(obj, meta["key"])
        pose = model.to_model(_object_to_camera(obj, view))
        whole = silhouette(model, pose, K, (w, h), float(view.camera.get("near", 0.01)))
        visib = seg == obj["instance_id"]
        full = whole.image | visib  # the renderer's visible pixels are part of the whole
        count_all = whole.count + int((visib & ~whole.image).sum())
        count_visib = int(visib.sum())
        box_visib = _box(visib)
        box_all = _union(whole.box, box_visib)
        stem = f"{im_id:06d}_{gt_id:06d}.png"
        _png(inside(scene, "mask", stem), full.astype(np.uint8) * 255)
        _png(inside(scene, "mask_visib", stem), visib.astype(np.uint8) * 255)
        gts.append(
            {
                "obj_id": model.obj_id,
                "cam_R_m2c": pose[:3, :3].ravel().tolist(),
                "cam_t_m2c": (pose[:3, 3] * 1000).tolist(),
                "datagen_instance_id": obj["instance_id"],
            }
        )
        infos.append(
            {
                "bbox_obj": _xywh(box_all),
                "bbox_visib": _xywh(box_visib),
                "px_count_all": count_all,
                "px_count_valid": int((full & (depth > 0)).sum()),
                "px_count_visib": count_visib,
                "visib_fract": count_visib / count_all if count_all else 0.0,
            }
        )
    return camera, gts, infos


def _export_scene(
    dataset: ExportedDataset, i: int, meta: SampleMetadata, scene: Path, models: ModelSet
) -> None:
    for sub in ("rgb", "depth", "mask", "mask_visib"):
        (scene / sub).mkdir(parents=True)
    cameras, gts, infos = {}, {}, {}
    for im_id, view in enumerate(labelled_views(meta)):
        raw = dataset.raw(i, {f"{view.prefix}{p}" for p in ("rgb.png", "depth.png", "seg.png")})
        cameras[str(im_id)], gts[str(im_id)], infos[str(im_id)] = _export_view(
            scene, im_id, view, raw, meta, models
        )
    for name, doc in (("scene_camera", cameras), ("scene_gt", gts), ("scene_gt_info", infos)):
        dump_json(scene / f"{name}.json", doc)


def export(
    dataset: ExportedDataset,
    manifest: Manifest,
    out: Path,
    on_progress: SampleProgress | None = None,
) -> list[Path]:
    """Writes into ``out`` (a fresh directory); returns the files and folders written."""
    split = out / SPLIT
    split.mkdir(parents=True)
    models = ModelSet(out / "models")
    first_camera = None
    for i in range(len(dataset)):
        meta = sample_metadata(dataset, i)
        check_asset_paths(meta, manifest, dataset.root)  # users' meshes: the config's folder only
        _export_scene(dataset, i, meta, inside(split, f"{i:06d}"), models)
        if first_camera is None and (views := labelled_views(meta)):
            first_camera = views[0].camera
        if on_progress:
            on_progress(i + 1, len(dataset))
    models.write_info()
    files = [out / "models", split]
    if first_camera is not None:  # BOP's sensor record; each image's own K is in scene_camera
        K = np.asarray(first_camera.get("render_intrinsics", first_camera["intrinsics"]), float)
        doc = {
            "width": first_camera["width"],
            "height": first_camera["height"],
            "fx": K[0, 0],
            "fy": K[1, 1],
            "cx": K[0, 2],
            "cy": K[1, 2],
            "depth_scale": 1.0,
        }
        (out / "camera.json").write_text(strict_json(doc, "camera.json", indent=1))
        files.append(out / "camera.json")
    return files
