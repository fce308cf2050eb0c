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
from datagen.preview import sample_tile, tile_grid

GRID_SAMPLES = 12


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
    cv2.imwrite(str(overview), tile_grid([sample_tile(dataset[int(i)]) for i in chosen]))
    distributions = out / "distributions.png"
    _plot_distributions(metas, distributions)
    return summary, [overview, distributions]
