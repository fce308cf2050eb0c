"""``datagen inspect DIR``: a summary, pictures of samples with their annotations, and plots.

Writes next to the dataset: ``inspect/overview.png`` (annotated grid; grasp attempts drawn on
their pre-grasp frame, green for success and red for failure) and ``inspect/distributions.png``
(histograms of randomised parameters and of visibility), and returns the summary.
"""

from __future__ import annotations

from collections import Counter
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from datagen.grasping.stats import campaign_stats
from datagen.loader import load
from datagen.preview import depth_colour, draw_annotations, put_label

GRID_SAMPLES = 12
SUCCESS_BGR, FAILURE_BGR = (60, 200, 60), (50, 50, 230)


def _project(points: np.ndarray, camera: dict[str, Any]) -> np.ndarray:
    K, E = np.asarray(camera["intrinsics"]), np.asarray(camera["extrinsics_world_to_camera"])
    cam = points @ E[:3, :3].T + E[:3, 3]
    uvw = cam @ K.T
    return uvw[:, :2] / uvw[:, 2:3] - 0.5


def draw_grasp(image: np.ndarray, attempt: dict[str, Any], camera: dict[str, Any]) -> None:
    """The gripper as two fingers and the approach, projected into the (BGR) image."""
    grasp = attempt["grasp"]
    if grasp is None:
        return
    pose = np.asarray(grasp["pose_world"])
    centre, closing, approach = pose[:3, 3], pose[:3, 1], pose[:3, 2]
    half = max(grasp["width"], 0.02) / 2
    finger = 0.045  # metres, finger length back from the tool centre point
    tips = [centre + s * half * closing for s in (-1, 1)]
    points = np.array(
        [*tips, *(t - finger * approach for t in tips), centre - (finger + 0.06) * approach]
    )
    uv = np.rint(_project(points, camera)).astype(int)
    if not np.isfinite(uv).all() or np.abs(uv).max() > 1e5:
        return
    colour = SUCCESS_BGR if attempt["outcome"]["success"] else FAILURE_BGR
    for a, b in ((0, 2), (1, 3), (2, 3)):
        cv2.line(image, tuple(uv[a]), tuple(uv[b]), colour, 2, cv2.LINE_AA)
    palm = (uv[2] + uv[3]) // 2
    cv2.line(image, tuple(palm), tuple(uv[4]), colour, 2, cv2.LINE_AA)
    label = "success" if attempt["outcome"]["success"] else attempt["outcome"]["failure_mode"]
    put_label(image, label, (int(uv[4][0]) + 4, int(uv[4][1])), 0.45)


def _tile(item: dict[str, Any]) -> np.ndarray:
    view = item["meta"]["views"]["workspace"]
    image = draw_annotations(item["rgb"], item["seg"], view)
    attempt = item["meta"].get("attempt")
    if attempt:
        draw_grasp(image, attempt, view["camera"])
    put_label(image, item["key"], (6, 18), 0.55)
    return np.vstack([image, depth_colour(item["depth"])])


def _grid(tiles: list[np.ndarray], columns: int = 4) -> np.ndarray:
    blank = np.zeros_like(tiles[0])
    while len(tiles) % columns and len(tiles) > columns:
        tiles.append(blank)
    grid = np.vstack([np.hstack(tiles[r : r + columns]) for r in range(0, len(tiles), columns)])
    scale = min(1.0, 2400 / grid.shape[1])
    return (
        cv2.resize(grid, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA)
        if scale < 1
        else grid
    )


def _plot_distributions(metas: list[dict[str, Any]], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    values = {
        "objects per scene": [len(m["objects"]) for m in metas],
        "object mass (kg)": [o["mass"] for m in metas for o in m["objects"]],
        "object friction": [o["friction"] for m in metas for o in m["objects"]],
        "visible fraction": [
            o["visible_fraction"] for m in metas for o in m["views"]["workspace"]["objects"]
        ],
        "ambient light": [m["randomisation"]["lighting"]["ambient"] for m in metas],
        "lights": [len(m["randomisation"]["lighting"]["lights"]) for m in metas],
        "camera fovy (deg)": [m["randomisation"]["camera"]["fovy_deg"] for m in metas],
        "camera eye z (m)": [m["randomisation"]["camera"]["eye"][2] for m in metas],
    }
    attempts = [m["attempt"] for m in metas if "attempt" in m]
    if attempts:
        values["grasp lift height (m)"] = [a["outcome"]["lift_height"] for a in attempts]
    fig, axes = plt.subplots(3, 3, figsize=(12, 9))
    for ax, (name, data) in zip(axes.ravel(), values.items(), strict=False):
        ax.hist(data, bins=20, color="#4878a8")
        ax.set_title(name, fontsize=10)
    for ax in axes.ravel()[len(values) :]:
        ax.axis("off")
    fig.suptitle(f"{len(metas)} samples")
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)


def inspect_dataset(root: str | Path) -> tuple[dict[str, Any], list[Path]]:
    """Summary of the dataset and the picture files written under ``root/inspect/``."""
    root = Path(root)
    dataset = load(root)
    metas = [dataset.metadata(i) for i in range(len(dataset))]
    classes = Counter(o["class"] for m in metas for o in m["objects"])
    visible = [o["visible_fraction"] for m in metas for o in m["views"]["workspace"]["objects"]]
    summary: dict[str, Any] = {
        "samples": len(dataset),
        "objects": sum(classes.values()),
        "objects_per_class": dict(sorted(classes.items())),
        "visible_fraction_histogram": {
            f"{lo:.1f}-{lo + 0.2:.1f}": int(c)
            for lo, c in zip(
                np.arange(0, 1, 0.2), np.histogram(visible, bins=5, range=(0, 1))[0], strict=True
            )
        },
    }
    attempts = [m["attempt"] for m in metas if "attempt" in m]
    if attempts:
        summary["campaign"] = dataset.manifest.get("campaign") or campaign_stats(attempts)
    out = root / "inspect"
    out.mkdir(exist_ok=True)
    chosen = np.linspace(0, len(dataset) - 1, min(GRID_SAMPLES, len(dataset))).astype(int)
    overview = out / "overview.png"
    cv2.imwrite(str(overview), _grid([_tile(dataset[int(i)]) for i in chosen]))
    distributions = out / "distributions.png"
    _plot_distributions(metas, distributions)
    return summary, [overview, distributions]
