"""``datagen inspect DIR``: a summary, pictures of samples with their annotations, and plots.

Writes next to the dataset: ``inspect/overview.png`` (annotated grid; grasp attempts drawn on
their pre-grasp frame, green for success and red for failure) and ``inspect/distributions.png``
(histograms of randomised parameters and of visibility), for frames ``inspect/randomisation.png``
(the appearance randomisation: textures, rooms, distractors, camera effects, depth sensor), for
recorded grasp attempts ``inspect/trajectories.png`` (the joint positions over time of up to
``TRAJECTORY_SAMPLES`` attempts, green for success and red for failure), and returns the summary. The summary
and plots are chosen by the samples' metadata format (``datagen.formats``), never by the scene
family's name; campaign statistics are added wherever the metadata holds grasp attempts.

A sample whose metadata cannot be read or summarised, or one of the overview's samples that
cannot be drawn, is reported through ``on_skip``, left out of the summary, the plots and the
pictures, and counted as ``skipped_samples`` (``datagen.tools.sample_checks``).
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from datagen.campaign_stats import campaign_stats
from datagen.dataset.loader import DatasetError, ShardDataset, load
from datagen.dataset.trajectory import decode_trajectory
from datagen.exports.files import inside, replace_file, tool_folder, written
from datagen.outcomes import grasp_outcome
from datagen.records import SampleMetadata
from datagen.registries import METADATA_FORMATS, MetadataFormat, metadata_format
from datagen.tools.preview import sample_tile, tile_grid
from datagen.tools.sample_checks import (
    OnSkip,
    Skipped,
    check_plottable,
    each_sample,
    log_skip,
    no_sample_left,
    read_item,
    read_metadata,
)

GRID_SAMPLES = 12
TRAJECTORY_SAMPLES = 24


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


def _trajectories(dataset: ShardDataset, indices: list[int], on_skip: OnSkip) -> dict[int, dict]:
    """The decoded ``trajectory.npz`` of the first ``TRAJECTORY_SAMPLES`` of ``indices`` that
    have one; a bad one is reported and left out of this plot (the summary keeps its sample)."""
    with_part = [i for i in indices if "trajectory.npz" in dataset.part_names(i)]
    return each_sample(
        dataset,
        with_part[:TRAJECTORY_SAMPLES],
        lambda i: decode_trajectory(dataset.raw(i, {"trajectory.npz"})["trajectory.npz"]),
        on_skip,
    )


def _plot_trajectories(trajectories: list[tuple[dict, bool]], path: Path) -> None:
    """One panel per joint (of the first attempt's robot): position over time per attempt."""
    from matplotlib.figure import Figure

    joints = trajectories[0][0]["names"]["joint_names"]
    columns = 3
    fig = Figure(figsize=(12, 3 * -(-len(joints) // columns)))
    axes = fig.subplots(-(-len(joints) // columns), columns, squeeze=False).ravel()
    for trajectory, success in trajectories:
        if trajectory["names"]["joint_names"] != joints:
            continue
        for j, ax in enumerate(axes[: len(joints)]):
            colour = "#3a9a4a" if success else "#c0392b"
            ax.plot(trajectory["time"], trajectory["qpos"][:, j], color=colour, lw=0.8, alpha=0.7)
    for j, ax in enumerate(axes):
        if j < len(joints):
            ax.set_title(joints[j], fontsize=10)
            ax.set_xlabel("time (s)", fontsize=8)
        else:
            ax.axis("off")
    fig.suptitle(
        f"joint positions (rad; m for prismatic joints) of {len(trajectories)} recorded attempts"
    )
    fig.tight_layout()
    fig.savefig(path, dpi=80)


def _summarisable(kind: MetadataFormat, meta: SampleMetadata) -> SampleMetadata:
    """``meta`` if it is of format ``kind`` and the summary, the plots and the campaign
    statistics can take it (numbers finite, names text), else the error of the first that
    cannot."""
    if meta.get("format") != kind.name:
        raise DatasetError(f"metadata format {repr(meta.get('format'))[:80]}, not {kind.name!r}")
    check_plottable(kind.function("summary")([meta]), "its summary")
    check_plottable(kind.function("distributions")([meta]), "its distributions")
    if check := kind.optional("check"):
        check(meta)
    if "attempt" in meta:
        check_plottable(campaign_stats([grasp_outcome(meta["attempt"])]), "its grasp attempt")
    return meta


def inspect_dataset(
    root: str | Path, on_skip: OnSkip = log_skip
) -> tuple[dict[str, Any], list[Path]]:
    """Summary of the dataset and the picture files written under ``root/inspect/``
    (DatasetError if that is a link; a link at a file's name is replaced, never followed)."""
    root = Path(root)
    dataset = load(root)
    skipped = Skipped(on_skip)
    readable = each_sample(
        dataset, range(len(dataset)), lambda i: read_metadata(dataset, i), skipped
    )
    first = next(iter(readable.values())) if readable else {"format": "datagen.sample/1"}
    kind = metadata_format(first, str(root))
    usable = each_sample(dataset, readable, lambda i: _summarisable(kind, readable[i]), skipped)
    # the overview's samples spread over the dataset; one that cannot be drawn is left out
    indices = list(usable)
    chosen = [
        indices[k]
        for k in np.linspace(0, len(indices) - 1, min(GRID_SAMPLES, len(indices))).astype(int)
    ]
    tiles = each_sample(dataset, chosen, lambda i: sample_tile(read_item(dataset, i)), skipped)
    if not tiles:
        raise no_sample_left(root, skipped, "inspect")
    undrawable = set(chosen) - set(tiles)  # found bad too: left out of everything
    metas = [meta for i, meta in usable.items() if i not in undrawable]
    summary = kind.function("summary")(metas)
    if skipped:
        summary["skipped_samples"] = len(dataset) - len(metas)
    attempts = [grasp_outcome(m["attempt"]) for m in metas if "attempt" in m]
    if attempts:
        summary["campaign"] = dataset.manifest.get("campaign") or campaign_stats(attempts)
    values = kind.function("distributions")(metas)
    out = tool_folder(root, "inspect")  # refused if a link: its files go nowhere else
    title, grid = f"{len(metas)} {kind.noun}", tile_grid(list(tiles.values()))
    overview = inside(out, "overview.png")  # each written beside its name and renamed onto it
    replace_file(overview, lambda tmp: written(cv2.imwrite(str(tmp), grid), overview, "OpenCV"))
    pictures = [
        replace_file(
            inside(out, "distributions.png"), lambda tmp: _plot_distributions(values, title, tmp)
        )
    ]
    own = kind.optional("pictures")
    for name, draw in (own(metas, title) if own else {}).items():
        pictures.append(replace_file(inside(out, name), draw))
    kept = [i for i in usable if i not in undrawable and "attempt" in usable[i]]
    recorded = _trajectories(dataset, kept, skipped)
    if recorded:
        runs = [
            (t, bool(grasp_outcome(usable[i]["attempt"])["success"])) for i, t in recorded.items()
        ]
        pictures.append(
            replace_file(inside(out, "trajectories.png"), lambda tmp: _plot_trajectories(runs, tmp))
        )
    return summary, [overview, *pictures]


def metadata_summary(root: str | Path, on_skip: OnSkip = log_skip) -> dict[str, Any]:
    """The summary ``inspect`` reports, from the samples' metadata alone (no image decoded, no
    picture drawn): what a dataset card states. {} for a metadata format with no summary.
    Streams: each sample's metadata is checked, then cut to the fields the summary reads
    (its format's ``summary_fields``) and kept as compact JSON bytes, about 1-2 KB a sample."""
    dataset = load(root)
    skipped = Skipped(on_skip)
    first = each_sample(
        dataset, range(min(len(dataset), 1)), lambda i: read_metadata(dataset, i), skipped
    )
    fmt = first[0].get("format") if first else None
    if not isinstance(fmt, str) or fmt not in METADATA_FORMATS:
        return {}
    kind = METADATA_FORMATS[fmt]
    cut = kind.function("summary_fields")
    usable = each_sample(
        dataset,
        range(len(dataset)),
        lambda i: _packed(cut(_summarisable(kind, read_metadata(dataset, i)))),
        skipped,
    )
    metas = _Unpacked(list(usable.values()))
    summary = kind.function("summary")(metas) if metas else {}
    if skipped:
        summary["skipped_samples"] = len(dataset) - len(metas)
    attempts = [grasp_outcome(m["attempt"]) for m in metas if "attempt" in m]
    if attempts:
        summary["campaign"] = dataset.manifest.get("campaign") or campaign_stats(attempts)
    return summary


def _packed(meta: SampleMetadata) -> bytes:
    return json.dumps(meta, separators=(",", ":")).encode()


class _Unpacked(Sequence[SampleMetadata]):
    """Packed metadata read as a list: each item decoded when it is read."""

    def __init__(self, packed: list[bytes]):
        self.packed = packed

    def __len__(self) -> int:
        return len(self.packed)

    def __getitem__(self, i):  # an int (a slice is not needed by the summaries)
        return json.loads(self.packed[i])
