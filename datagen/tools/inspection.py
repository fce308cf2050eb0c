"""``datagen inspect DIR``: a summary, pictures of samples with their annotations, and plots.

Writes next to the dataset: ``inspect/overview.png`` (annotated grid; grasp attempts drawn on
their pre-grasp frame, green for success and red for failure) and ``inspect/distributions.png``
(histograms of randomised parameters and of visibility), for frames ``inspect/randomisation.png``
(the appearance randomisation: textures, rooms, distractors, camera effects, depth sensor), for
recorded grasp attempts ``inspect/trajectories.png`` (the joint positions over time of up to
``TRAJECTORY_SAMPLES`` attempts, green for success and red for failure), and returns the summary. The summary
and plots are chosen by the samples' metadata format (``SUMMARIES``), never by the scene
family's name; campaign statistics are added wherever the metadata holds grasp attempts.

A sample whose metadata cannot be read or summarised, or one of the overview's samples that
cannot be drawn, is reported through ``on_skip``, left out of the summary, the plots and the
pictures, and counted as ``skipped_samples`` (``datagen.tools.sample_checks``).
"""

from __future__ import annotations

import json
from collections import Counter
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from datagen.dataset.loader import DatasetError, ShardDataset, load
from datagen.dataset.trajectory import decode_trajectory
from datagen.exports.files import inside, replace_file, tool_folder, written
from datagen.grasping.stats import campaign_stats
from datagen.outcomes import grasp_outcome, navigation_outcome
from datagen.records import SampleMetadata
from datagen.tools.aerial_inspection import aerial_distributions, aerial_summary
from datagen.tools.fleet_inspection import fleet_distributions, fleet_summary
from datagen.tools.preview import sample_tile, tile_grid
from datagen.tools.randomisation_plots import plot_randomisation, randomisation_panels
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


# name -> the values of one sample; a name whose fields a family's metadata lacks is left out
_SAMPLE_VALUES: dict[str, Callable[[SampleMetadata], list[float]]] = {
    "objects per scene": lambda m: [len(m["objects"])],
    "object mass (kg)": lambda m: [o["mass"] for o in m["objects"]],
    "object friction": lambda m: [o["friction"] for o in m["objects"]],
    "visible fraction, targets": lambda m: _visible(m, "target"),
    "visible fraction, distractors": lambda m: _visible(m, "distractor"),
    "ambient light": lambda m: [m["randomisation"]["lighting"]["ambient"]],
    "lights": lambda m: [len(m["randomisation"]["lighting"]["lights"])],
    "camera fovy (deg)": lambda m: [m["randomisation"]["camera"]["fovy_deg"]],
    "camera eye z (m)": lambda m: [m["randomisation"]["camera"]["eye"][2]],
}


def _visible(meta: SampleMetadata, role: str) -> list[float]:
    """Visible fractions of the workspace view's objects of one ``role`` (target, distractor)."""
    objects = meta["views"]["workspace"]["objects"]
    return [o["visible_fraction"] for o in objects if o.get("role", "target") == role]


def _sample_distributions(metas: list[SampleMetadata]) -> dict[str, list[float]]:
    values = {}
    for name, of_sample in _SAMPLE_VALUES.items():
        try:
            values[name] = [v for m in metas for v in of_sample(m)]
        except KeyError:
            continue
    attempts = [m["attempt"] for m in metas if "attempt" in m]
    if attempts:
        values["grasp lift height (m)"] = [a["outcome"]["lift_height"] for a in attempts]
    return values


def _navigation_distributions(metas: list[SampleMetadata]) -> dict[str, list[float]]:
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


def _histogram(values: list[float], bins: int = 5) -> dict[str, int]:
    counts, edges = np.histogram(values, bins=bins, range=(0, 1))
    return {
        f"{lo:.1f}-{hi:.1f}": int(c) for lo, hi, c in zip(edges, edges[1:], counts, strict=False)
    }


def _sample_summary(metas: Sequence[SampleMetadata]) -> dict[str, Any]:
    classes = Counter(o["class"] for m in metas for o in m["objects"])
    targets = [v for m in metas for v in _visible(m, "target")]
    distractors = [v for m in metas for v in _visible(m, "distractor")]
    panels = randomisation_panels(metas)
    return {
        "samples": len(metas),
        "objects": sum(classes.values()),
        "objects_per_class": dict(sorted(classes.items())),
        "visible_fraction_targets": _histogram(targets),
        "visible_fraction_distractors": _histogram(distractors),
        "surface_textures": dict(sorted(panels["surface textures"].items())),
        "distractors": int(sum(panels["distractors per scene"])),
    }


def _navigation_summary(metas: Sequence[SampleMetadata]) -> dict[str, Any]:
    episodes = [m["episode"] for m in metas]
    things = Counter(t["class"] for m in metas for f in m["frames"] for t in f["things"])
    return {
        "episodes": len(episodes),
        "frames": sum(e["frames"] for e in episodes),
        "families": dict(Counter(m["family"] for m in metas)),
        "success_rate": round(
            float(np.mean([navigation_outcome(e)["success"] for e in episodes])), 4
        ),
        "mean_path_length_m": round(float(np.mean([e["path_length_m"] for e in episodes])), 3),
        "mean_shortest_path_m": round(float(np.mean([e["shortest_path_m"] for e in episodes])), 3),
        "mean_spl": round(float(np.mean([e["spl"] for e in episodes])), 4),
        "frames_with_collision": sum(f["collision"] for m in metas for f in m["frames"]),
        "things_seen_per_class": dict(sorted(things.items())),
        "spl_histogram": _histogram([e["spl"] for e in episodes]),
    }


@dataclass(frozen=True)
class Summary:
    """How ``inspect`` summarises the samples of one metadata format."""

    summary: Callable[[Sequence[SampleMetadata]], dict[str, Any]]
    distributions: Callable[[list[SampleMetadata]], dict[str, list[float]]]
    noun: str  # what one sample is called in the plots' title


# metadata format (meta["format"]) -> its summary
SUMMARIES: dict[str, Summary] = {
    "datagen.sample/1": Summary(_sample_summary, _sample_distributions, "samples"),
    "datagen.nav_episode/1": Summary(_navigation_summary, _navigation_distributions, "episodes"),
    "datagen.aerial_episode/1": Summary(aerial_summary, aerial_distributions, "episodes"),
    "datagen.nav_fleet/1": Summary(fleet_summary, fleet_distributions, "episodes"),
}


def _summarisable(kind: Summary, meta: SampleMetadata) -> SampleMetadata:
    """``meta`` if the summary, the plots and the campaign statistics can take it (numbers
    finite, names text), else the error of the first that cannot."""
    check_plottable(kind.summary([meta]), "its summary")
    check_plottable(kind.distributions([meta]), "its distributions")
    if meta.get("format") == "datagen.sample/1":
        check_plottable(randomisation_panels([meta]), "its randomisation")
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
    fmt = next(iter(readable.values())).get("format") if readable else "datagen.sample/1"
    if not isinstance(fmt, str) or fmt not in SUMMARIES:
        raise DatasetError(
            f"{root}: no inspect summary for metadata format {repr(fmt)[:80]}; "
            f"expected one of {list(SUMMARIES)}"
        )
    kind = SUMMARIES[fmt]
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
    summary = kind.summary(metas)
    if skipped:
        summary["skipped_samples"] = len(dataset) - len(metas)
    attempts = [grasp_outcome(m["attempt"]) for m in metas if "attempt" in m]
    if attempts:
        summary["campaign"] = dataset.manifest.get("campaign") or campaign_stats(attempts)
    values = kind.distributions(metas)
    out = tool_folder(root, "inspect")  # refused if a link: its files go nowhere else
    title, grid = f"{len(metas)} {kind.noun}", tile_grid(list(tiles.values()))
    overview = inside(out, "overview.png")  # each written beside its name and renamed onto it
    replace_file(overview, lambda tmp: written(cv2.imwrite(str(tmp), grid), overview, "OpenCV"))
    pictures = [
        replace_file(
            inside(out, "distributions.png"), lambda tmp: _plot_distributions(values, title, tmp)
        )
    ]
    if fmt == "datagen.sample/1":
        pictures.append(
            replace_file(
                inside(out, "randomisation.png"), lambda tmp: plot_randomisation(metas, title, tmp)
            )
        )
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
    (:func:`summary_fields`) and kept as compact JSON bytes, about 1-2 KB a sample."""
    dataset = load(root)
    skipped = Skipped(on_skip)
    first = each_sample(
        dataset, range(min(len(dataset), 1)), lambda i: read_metadata(dataset, i), skipped
    )
    fmt = first[0].get("format") if first else None
    if not isinstance(fmt, str) or fmt not in SUMMARIES:
        return {}
    kind = SUMMARIES[fmt]
    usable = each_sample(
        dataset,
        range(len(dataset)),
        lambda i: _packed(summary_fields(_summarisable(kind, read_metadata(dataset, i)))),
        skipped,
    )
    metas = _Unpacked(list(usable.values()))
    summary = kind.summary(metas) if metas else {}
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


def _texture_only(material: dict[str, Any]) -> dict[str, Any]:
    texture = material.get("texture")
    if texture is None:
        return {}
    return {"texture": {"family": texture["family"]} if "family" in texture else {}}


def summary_fields(meta: SampleMetadata) -> SampleMetadata:
    """``meta`` cut to what the summaries (``SUMMARIES``) and the campaign statistics read: a few
    hundred bytes instead of tens of kilobytes per sample."""
    cut: dict[str, Any] = {"format": meta["format"]}
    if "attempt" in meta:
        attempt = meta["attempt"]
        cut["attempt"] = {
            "sampler": attempt["sampler"],
            "target": {"class": attempt["target"]["class"]},
            "outcome": {k: attempt["outcome"][k] for k in ("success", "failure_mode")},
        }
    if meta["format"] == "datagen.nav_episode/1":
        heavy = ("trajectory", "layout", "planned_path")
        cut["family"] = meta["family"]
        cut["episode"] = {k: v for k, v in meta["episode"].items() if k not in heavy}
        cut["frames"] = [
            {"collision": f["collision"], "things": [{"class": t["class"]} for t in f["things"]]}
            for f in meta["frames"]
        ]
        return cut  # type: ignore[return-value]
    cut["objects"] = [
        {"class": o["class"], "shape": {"family": o["shape"]["family"]}} for o in meta["objects"]
    ]
    seen = meta["views"]["workspace"]["objects"]
    kept = [
        {"visible_fraction": o["visible_fraction"], "role": o.get("role", "target")} for o in seen
    ]
    cut["views"] = {"workspace": {"objects": kept}}
    drawn = meta.get("randomisation", {})
    materials = drawn.get("materials", {})
    cut["randomisation"] = {
        "materials": {
            name: [_texture_only(m) for m in value] if name == "objects" else _texture_only(value)
            for name, value in materials.items()
            if name == "objects" or isinstance(value, dict)
        },
        "distractors": [
            {"material": _texture_only(d["material"])} if "material" in d else {}
            for d in drawn.get("distractors", [])
        ],
    }
    if "distractors" not in drawn:
        del cut["randomisation"]["distractors"]
    if "background" in drawn:  # the panels also read its room
        background = drawn["background"]
        walls = {k: _texture_only(w) for k, w in background.get("walls", {}).items()}
        cut["randomisation"]["background"] = {"walls": walls, "room": background["room"]}
    return cut  # type: ignore[return-value]
