"""An example export format, ``labels_csv`` (docs/extending.md): one CSV row per labelled
instance in every view of every sample. Family-agnostic: it reads the views that
``datagen.dataset.views.labelled_views`` makes of any sample's metadata."""

from __future__ import annotations

import csv
from pathlib import Path

from datagen.dataset.views import labelled_views
from datagen.registries import ExportFormat

COLUMNS = ("key", "view", "instance_id", "class", "x0", "y0", "x1", "y1")


def export(dataset, manifest, out: Path, on_progress=None) -> list[Path]:
    with open(out, "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(COLUMNS)
        for i in range(len(dataset)):
            for view in labelled_views(dataset.metadata(i)):
                for thing in view.instances:
                    writer.writerow([dataset.keys[i], view.name, thing["instance_id"], thing["class"], *thing["bbox_xyxy"]])  # fmt: skip
            if on_progress:
                on_progress(i + 1, len(dataset))
    return [out]


EXPORT = ExportFormat("labels_csv", "labels.csv", "example_labels_csv:export")
