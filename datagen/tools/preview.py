"""Preview grids: samples drawn with their annotations (masks, 2D boxes, 3D boxes, object axes,
labels, grasps; navigation frames with their classes, path and map).

A sample is drawn by its metadata format's tile (``datagen.formats``), never by its scene
family's name; the drawing the formats share is here (:func:`camera_tile`,
:func:`navigation_tile`). A sample whose stored values cannot be drawn is reported and left out (``datagen.tools.sample_checks``)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import cv2
import numpy as np

from datagen.dataset.views import labelled_views
from datagen.exports.files import inside, replace_file, written
from datagen.geometry import project
from datagen.outcomes import grasp_outcome, navigation_outcome
from datagen.records import CameraRecord, ViewRecord
from datagen.registries import metadata_format
from datagen.tools.drawing import depth_colour, fit, instance_colour, put_label
from datagen.tools.sample_checks import (
    OnSkip,
    Skipped,
    each_sample,
    finite_matrix,
    intrinsics,
    log_skip,
    no_sample_left,
    pixel_box,
    pixels,
    read_item,
)

# (i, j) corner pairs of the 8 box corners ordered x-major, then y, then z (see annotate.py)
_BOX_EDGES = [
    (0, 1),
    (2, 3),
    (4, 5),
    (6, 7),
    (0, 2),
    (1, 3),
    (4, 6),
    (5, 7),
    (0, 4),
    (1, 5),
    (2, 6),
    (3, 7),
]


SUCCESS_BGR, FAILURE_BGR = (60, 200, 60), (50, 50, 230)


def draw_annotations(
    rgb: np.ndarray, instance: np.ndarray, view: ViewRecord, where: str = "views.workspace"
) -> np.ndarray:
    """BGR image: masks blended in, 3D oriented boxes, 2D boxes and class labels on top.
    ``where`` names the view record in the sample's metadata, for a BadSample's message."""
    image = cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR)
    overlay = image.copy()
    for obj in view["objects"]:
        if obj["visible"]:
            overlay[instance == obj["instance_id"]] = instance_colour(obj["instance_id"])
    image = cv2.addWeighted(overlay, 0.45, image, 0.55, 0)
    camera = view.get("camera", {})
    K = intrinsics(camera, f"{where}.camera") if "intrinsics" in camera else None
    for k, obj in enumerate(view["objects"]):
        if not obj["visible"]:
            continue
        colour = instance_colour(obj["instance_id"])
        # OpenCV draws with pixel centres at integers
        corners = pixels(np.asarray(obj["obb_corners_px"], dtype=float) - 0.5)
        if corners is not None:
            for i, j in _BOX_EDGES:
                cv2.line(image, tuple(corners[i]), tuple(corners[j]), colour, 1, cv2.LINE_AA)
        if "pose_camera" in obj and K is not None:
            pose = finite_matrix(
                obj["pose_camera"]["matrix"], (4, 4), f"{where}.objects[{k}].pose_camera.matrix"
            )
            draw_axes(image, pose, K)
        x0, y0, x1, y1 = pixel_box(obj["bbox_xyxy"], f"{where}.objects[{k}].bbox_xyxy")
        cv2.rectangle(image, (x0, y0), (x1, y1), (255, 255, 255), 1)
        label = f"{str(obj['class'])[:40]} {obj['visible_fraction']:.2f}"
        put_label(image, label, (x0, max(10, y0 - 3)), 0.38)
    return image


AXIS_LENGTH = 0.03  # metres
_AXIS_BGR = ((0, 0, 230), (0, 200, 0), (230, 80, 0))  # x red, y green, z blue


def draw_axes(image: np.ndarray, pose_camera: np.ndarray, intrinsics: np.ndarray) -> None:
    """An object's frame (4x4 object -> OpenCV camera) as three projected axes."""
    points = pose_camera[:3, 3] + AXIS_LENGTH * np.vstack([np.zeros(3), pose_camera[:3, :3].T])
    if (points[:, 2] <= 0.01).any():
        return
    uv = points @ intrinsics.T
    uv = pixels(uv[:, :2] / uv[:, 2:3] - 0.5)
    if uv is None:  # an axis reaches far off the image
        return
    for axis in range(3):
        cv2.line(image, tuple(uv[0]), tuple(uv[axis + 1]), _AXIS_BGR[axis], 2, cv2.LINE_AA)


def draw_grasp(image: np.ndarray, attempt: dict[str, Any], camera: CameraRecord) -> None:
    """The gripper as two fingers and the approach, projected into the (BGR) image, green for a
    successful attempt, red for a failed one."""
    grasp = attempt["grasp"]
    if grasp is None:
        return
    pose = finite_matrix(grasp["pose_world"], (4, 4), "attempt.grasp.pose_world")
    centre, closing, approach = pose[:3, 3], pose[:3, 1], pose[:3, 2]
    half = max(finite_matrix([[grasp["width"]]], (1, 1), "attempt.grasp.width")[0, 0], 0.02) / 2
    finger = 0.045  # metres, finger length back from the tool centre point
    tips = [centre + s * half * closing for s in (-1, 1)]
    points = np.array(
        [*tips, *(t - finger * approach for t in tips), centre - (finger + 0.06) * approach]
    )
    K = intrinsics(camera, "views.workspace.camera")
    E = finite_matrix(
        camera["extrinsics_world_to_camera"],
        (4, 4),
        "views.workspace.camera.extrinsics_world_to_camera",
    )
    uv = pixels(project(points, K, E)[0])
    if uv is None:
        return
    outcome = grasp_outcome(attempt)
    colour = SUCCESS_BGR if outcome["success"] else FAILURE_BGR
    for a, b in ((0, 2), (1, 3), (2, 3)):
        cv2.line(image, tuple(uv[a]), tuple(uv[b]), colour, 2, cv2.LINE_AA)
    palm = (uv[2] + uv[3]) // 2
    cv2.line(image, tuple(palm), tuple(uv[4]), colour, 2, cv2.LINE_AA)
    label = "success" if outcome["success"] else str(outcome["failure_mode"])
    put_label(image, label, (int(uv[4][0]) + 4, int(uv[4][1])), 0.45)


# BGR per navigation class; background stays unblended
_NAV_COLOURS = {
    "floor": (90, 160, 90),
    "wall": (200, 170, 120),
    "door": (60, 200, 240),
    "obstacle": (60, 90, 230),
    "goal_marker": (240, 60, 240),
    "robot": (160, 160, 160),
}


def draw_navigation_frame(
    frame: dict[str, Any], classes: list[str], camera: CameraRecord, path_xy: np.ndarray
) -> np.ndarray:
    """BGR: semantic classes blended in, the expert path projected onto the floor, 2-D boxes of
    the labelled things, and the frame's state (distance to goal, command, collision)."""
    image = cv2.cvtColor(frame["rgb"], cv2.COLOR_RGB2BGR)
    overlay = image.copy()
    for class_id, name in enumerate(classes):
        if name in _NAV_COLOURS:
            overlay[frame["semantic"] == class_id] = _NAV_COLOURS[name]
    image = cv2.addWeighted(overlay, 0.35, image, 0.65, 0)
    meta = frame["meta"]
    if len(path_xy) > 1:  # the planned path, densified to 5 cm, on the floor (z = 0)
        s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(path_xy, axis=0).T))])
        t = np.arange(0.0, s[-1], 0.05)
        points = np.stack(
            [np.interp(t, s, path_xy[:, 0]), np.interp(t, s, path_xy[:, 1]), 0 * t], 1
        )
        K = intrinsics(camera, "camera")
        E = finite_matrix(
            meta["extrinsics_world_to_camera"], (4, 4), "frames[].extrinsics_world_to_camera"
        )
        uv, depth = project(points, K, E)
        ahead = (depth > 0.05) & (np.abs(uv) < 1e4).all(axis=1)
        for a, b in zip(
            uv[:-1][ahead[:-1] & ahead[1:]], uv[1:][ahead[:-1] & ahead[1:]], strict=True
        ):
            cv2.line(
                image,
                tuple(np.rint(a).astype(int)),
                tuple(np.rint(b).astype(int)),
                (230, 140, 30),
                2,
                cv2.LINE_AA,
            )
    for thing in meta["things"]:
        x0, y0, x1, y1 = pixel_box(thing["bbox_xyxy"], "frames[].things[].bbox_xyxy")
        cv2.rectangle(image, (x0, y0), (x1, y1), (255, 255, 255), 1)
        put_label(image, str(thing["class"])[:40], (x0 + 2, max(10, y0 + 12)), 0.38)
    v, w = meta["command"]
    state = f"d={meta['distance_to_goal']:.2f}m v={v:.2f} w={w:+.2f}"
    put_label(image, state, (6, image.shape[0] - 8), 0.45)
    if meta["collision"]:
        put_label(image, "COLLISION", (6, image.shape[0] - 26), 0.5)
    return image


def navigation_tile(
    item: dict[str, Any],
    k: int,
    frame: dict[str, Any],
    camera: CameraRecord,
    path: list,
    episode: dict[str, Any],
) -> np.ndarray:
    """A loaded navigation episode's frame ``k`` (its images and ``meta``, the state drawn)
    annotated with the ``path`` planned (x, y points), above the top-down map labelled with the
    ``episode``'s outcome and lengths."""
    meta, frames = item["meta"], item["frames"]
    image = draw_navigation_frame(frame, meta["classes"], camera, np.asarray(path))
    put_label(image, f"{item['key']} f{k}/{len(frames)} {meta['family']}", (6, 18), 0.5)
    overview = fit(cv2.cvtColor(item["map"], cv2.COLOR_RGB2BGR), *image.shape[:2])
    outcome = "success" if navigation_outcome(episode)["success"] else "failure"
    summary = (
        f"{outcome} {episode['path_length_m']:.1f} m (shortest {episode['shortest_path_m']:.1f} m)"
    )
    put_label(overview, summary, (6, 18), 0.5)
    return np.vstack([image, overview])


def camera_tile(item: dict[str, Any]) -> np.ndarray:
    """One loaded sample of cameras: the workspace camera's annotated colour image (and its
    grasp, if any) above its depth map, above a strip of its other cameras annotated (the
    extra views of ``render.views``, the wrist camera), if it has any, above the film of a
    recorded grasp attempt (:func:`film_strip`), if it was filmed."""
    view = item["meta"]["views"]["workspace"]
    image = draw_annotations(item["rgb"], item["seg"], view)
    attempt = item["meta"].get("attempt")
    if attempt:
        draw_grasp(image, attempt, view["camera"])
    put_label(image, item["key"], (6, 18), 0.55)
    others = [v for v in labelled_views(item["meta"]) if v.name in item.get("views", {})]
    strip = [other_views_strip(item, others, image.shape[1])] if others else []
    if item.get("trajectory", {}).get("frames"):
        strip.append(film_strip(item["trajectory"], image.shape[1]))
    return np.vstack([image, depth_colour(item["depth"]), *strip])


FILM_FRAMES, FILM_COLUMNS = 6, 3  # frames of a filmed attempt shown, spread over its duration


def film_strip(trajectory: dict[str, Any], width: int) -> np.ndarray:
    """Up to ``FILM_FRAMES`` frames of a filmed grasp attempt in rows of ``FILM_COLUMNS``,
    ``width`` pixels wide, each labelled with its time and phase, the wrist camera's frame
    under the workspace camera's when filmed."""
    frames = trajectory["frames"]
    chosen = np.unique(np.linspace(0, len(frames) - 1, min(FILM_FRAMES, len(frames))).astype(int))
    rows, phases = trajectory["step"], trajectory["names"]["phases"]
    kinds = ["rgb", "wrist_rgb"] if all("wrist_rgb" in f for f in frames) else ["rgb"]
    cell_w = width // FILM_COLUMNS
    cell_h = max(1, frames[0]["rgb"].shape[0] * cell_w // frames[0]["rgb"].shape[1])
    block = cell_h * len(kinds)  # one frame: its cameras stacked
    strip = np.zeros((block * -(-len(chosen) // FILM_COLUMNS), width, 3), np.uint8)
    for j, k in enumerate(chosen):
        row = max(0, int(np.searchsorted(rows, trajectory["frame_step"][k], side="right")) - 1)
        y, x = (j // FILM_COLUMNS) * block, (j % FILM_COLUMNS) * cell_w
        for r, kind in enumerate(kinds):
            cell = fit(cv2.cvtColor(frames[k][kind], cv2.COLOR_RGB2BGR), cell_h, cell_w)
            if r == 0:
                label = f"{frames[k]['time']:.2f}s {phases[int(trajectory['phase'][row])]}"
                put_label(cell, label, (4, 14), 0.4)
            strip[y + r * cell_h : y + (r + 1) * cell_h, x : x + cell_w] = cell
    return strip


def other_views_strip(item: dict[str, Any], views: list, width: int) -> np.ndarray:
    """The given views of a loaded sample annotated side by side, ``width`` pixels in all."""
    cell_w = width // len(views)
    cell_h = max(1, item["rgb"].shape[0] * cell_w // item["rgb"].shape[1])
    strip = np.zeros((cell_h, width, 3), np.uint8)
    for k, view in enumerate(views):
        images = item["views"][view.name]
        drawn = draw_annotations(images["rgb"], images["seg"], view.record, f"views.{view.name}")
        put_label(drawn, view.name, (6, 18), 0.55)
        strip[:, k * cell_w : (k + 1) * cell_w] = fit(drawn, cell_h, cell_w)
    return strip


def sample_tile(item: dict[str, Any]) -> np.ndarray:
    """One loaded sample, drawn by its metadata format's ``tile``."""
    return metadata_format(item["meta"], f"sample {item.get('key')}").function("tile")(item)


def tile_grid(tiles: list[np.ndarray], columns: int = 4, max_width: int = 2400) -> np.ndarray:
    """The tiles in rows of ``columns``; a tile of another size than the first is fitted to it."""
    tiles = [t if t.shape == tiles[0].shape else fit(t, *tiles[0].shape[:2]) for t in tiles]
    blank = np.zeros_like(tiles[0])
    while len(tiles) % columns and len(tiles) > columns:
        tiles.append(blank)
    grid = np.vstack([np.hstack(tiles[r : r + columns]) for r in range(0, len(tiles), columns)])
    scale = min(1.0, max_width / grid.shape[1])
    if scale < 1.0:
        grid = cv2.resize(grid, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA)
    return grid


def write_preview(
    dataset_dir: Path,
    out_path: Path | None = None,
    count: int = 8,
    columns: int = 4,
    on_skip: OnSkip = log_skip,
) -> Path:
    """A grid of the first ``count`` samples, drawn by :func:`sample_tile`, written to
    ``out_path`` as named, or by default to ``dataset_dir/preview.png`` (a link found there is
    replaced, never written through); a sample that cannot be drawn is reported through
    ``on_skip`` and left out (DatasetError if none is left)."""
    from datagen.dataset.loader import load

    dataset = load(dataset_dir)
    skipped = Skipped(on_skip)
    indices = range(min(count, len(dataset)))
    tiles = list(
        each_sample(
            dataset, indices, lambda i: sample_tile(read_item(dataset, i)), skipped
        ).values()
    )
    if not tiles:
        raise no_sample_left(dataset_dir, skipped, "preview")
    grid = tile_grid(tiles, columns)
    if out_path is None:
        out_path = inside(Path(dataset_dir), "preview.png")
        return replace_file(
            out_path, lambda tmp: written(cv2.imwrite(str(tmp), grid), out_path, "OpenCV")
        )
    out_path.parent.mkdir(parents=True, exist_ok=True)
    written(cv2.imwrite(str(out_path), grid), out_path, "OpenCV")
    return out_path
