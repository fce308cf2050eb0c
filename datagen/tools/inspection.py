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

from datagen.dataset.loader import load
from datagen.grasping.stats import campaign_stats
from datagen.tools.preview import sample_tile, tile_grid

GRID_SAMPLES = 12


def _grasp_distributions(metas: list[dict[str, Any]]) -> dict[str, list[float]]:
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
    return values


def _navigation_distributions(metas: list[dict[str, Any]]) -> dict[str, list[float]]:
    episodes = [m["episode"] for m in metas]
    return {
        "path length (m)": [e["path_length_m"] for e in episodes],
        "shortest path (m)": [e["shortest_path_m"] for e in episodes],
        "SPL": [e["spl"] for e in episodes],
        "frames per episode": [e["frames"] for e in episodes],
        "obstacles": [len(e["layout"]["obstacles"]) for e in episodes],
        "wall height (m)": [m["randomisation"]["wall_height"] for m in metas],
        "camera height (m)": [m["camera"]["height_m"] for m in metas],
        "camera pitch down (deg)": [m["camera"]["pitch_down_deg"] for m in metas],
        "camera fovy (deg)": [m["camera"]["fovy_deg"] for m in metas],
    }


def _plot_distributions(values: dict[str, list[float]], title: str, path: Path) -> None:
    from matplotlib.figure import Figure  # no pyplot: leaves the caller's backend alone

    fig = Figure(figsize=(12, 9))
    axes = fig.subplots(3, 3)
    for ax, (name, data) in zip(axes.ravel(), values.items(), strict=False):
        ax.hist(data, bins=20, color="#4878a8")
        ax.set_title(name, fontsize=10)
    for ax in axes.ravel()[len(values) :]:
        ax.axis("off")
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=80)


def _histogram(values: list[float], bins: int = 5) -> dict[str, int]:
    counts, edges = np.histogram(values, bins=bins, range=(0, 1))
    return {
        f"{lo:.1f}-{hi:.1f}": int(c) for lo, hi, c in zip(edges, edges[1:], counts, strict=False)
    }


def _grasp_summary(dataset, metas: list[dict[str, Any]]) -> dict[str, Any]:
    classes = Counter(o["class"] for m in metas for o in m["objects"])
    visible = [o["visible_fraction"] for m in metas for o in m["views"]["workspace"]["objects"]]
    summary: dict[str, Any] = {
        "samples": len(metas),
        "objects": sum(classes.values()),
        "objects_per_class": dict(sorted(classes.items())),
        "visible_fraction_histogram": _histogram(visible),
    }
    attempts = [m["attempt"] for m in metas if "attempt" in m]
    if attempts:
        summary["campaign"] = dataset.manifest.get("campaign") or campaign_stats(attempts)
    return summary


def _navigation_summary(metas: list[dict[str, Any]]) -> dict[str, Any]:
    episodes = [m["episode"] for m in metas]
    things = Counter(t["class"] for m in metas for f in m["frames"] for t in f["things"])
    return {
        "episodes": len(episodes),
        "frames": sum(e["frames"] for e in episodes),
        "families": dict(Counter(m["family"] for m in metas)),
        "success_rate": round(float(np.mean([e["success"] for e in episodes])), 4),
        "mean_path_length_m": round(float(np.mean([e["path_length_m"] for e in episodes])), 3),
        "mean_shortest_path_m": round(float(np.mean([e["shortest_path_m"] for e in episodes])), 3),
        "mean_spl": round(float(np.mean([e["spl"] for e in episodes])), 4),
        "frames_with_collision": sum(f["collision"] for m in metas for f in m["frames"]),
        "things_seen_per_class": dict(sorted(things.items())),
        "spl_histogram": _histogram([e["spl"] for e in episodes]),
    }


def inspect_dataset(root: str | Path) -> tuple[dict[str, Any], list[Path]]:
    """Summary of the dataset and the picture files written under ``root/inspect/``."""
    root = Path(root)
    dataset = load(root)
    metas = [dataset.metadata(i) for i in range(len(dataset))]
    navigation = bool(metas) and "episode" in metas[0]
    if navigation:
        summary = _navigation_summary(metas)
        values = _navigation_distributions(metas)
    else:
        summary = _grasp_summary(dataset, metas)
        values = _grasp_distributions(metas)
    out = root / "inspect"
    out.mkdir(exist_ok=True)
    chosen = np.linspace(0, len(dataset) - 1, min(GRID_SAMPLES, len(dataset))).astype(int)
    overview = out / "overview.png"
    cv2.imwrite(str(overview), tile_grid([sample_tile(dataset[int(i)]) for i in chosen]))
    distributions = out / "distributions.png"
    _plot_distributions(
        values, f"{len(metas)} {'episodes' if navigation else 'samples'}", distributions
    )
    return summary, [overview, distributions]
