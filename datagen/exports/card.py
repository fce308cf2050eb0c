"""Dataset cards: ``README.md`` with the YAML front matter of a Hugging Face dataset card, and a
Croissant ``croissant.json`` (``datagen.exports.croissant``), beside a dataset's manifest and in
each export folder (docs/dataset-card.md).

The front matter is what the Hub indexes: ``license`` (``other``: datagen cannot know the
licence of data made from the user's assets; the body says what it can state), ``task_categories``
(from the parts the samples hold), ``size_categories`` (the Hub's buckets of the sample count),
``tags`` (synthetic, datagen, the scene, the robot) and ``configs`` (the files a loader reads).
The body is written from the manifest and a summary computed from the samples' metadata alone
(``datagen.tools.inspection.metadata_summary``: no image is decoded, so it stays cheap at the end
of a build): generator version, seed, build id, config, classes, statistics, the preview and the
exports. An export's card describes its format (the export module's docstring) and points back
to the dataset's card.
"""

from __future__ import annotations

import importlib
from pathlib import Path
from typing import Any

import yaml

from datagen.dataset.loader import ShardDataset, load
from datagen.dataset.manifest import DatasetError
from datagen.exports.card_header import (
    EXPORT_DATA_FILES,
    EXPORT_TASKS,
    LICENSE,
    front_matter,
    licence_text,
    yaml_header,
)
from datagen.exports.card_text import code, fenced, text
from datagen.exports.checks import strict_json
from datagen.exports.croissant import (
    as_dict,
    as_scalar,
    card_facts,
    dataset_croissant,
    export_croissant,
    part_kinds,
)
from datagen.exports.files import inside, replace_file
from datagen.records import ExportedDataset
from datagen.registries import EXPORTS, FAMILIES, ExportFormat

CARD, CROISSANT = "README.md", "croissant.json"
PARTS = {  # a part's last two name pieces -> what it holds
    "rgb.png": "colour image (8-bit RGB)",
    "rgb_clean.png": "colour image before the photometric camera effects",
    "depth.png": "depth along the optical axis (uint16 millimetres, 0 = nothing)",
    "depth_sensor.png": "depth as a sensor model reads it (uint16 millimetres, 0 = no reading)",
    "seg.png": "instance ids (uint16; the instances are listed in the metadata)",
    "semantic.png": "class ids (the ids of the class list below)",
    "json": "the sample's metadata: cameras, objects, boxes, randomised values, outcome",
    "trajectory.npz": "the recorded trajectory: time, joint positions, actions, ...",
    "map.png": "top-down map of the layout with the paths",
    "occupancy.png": "occupancy grid of the layout",
}


def _first_metadata(dataset: ExportedDataset) -> dict[str, Any]:
    """The first sample's metadata, or {} (the card of a dataset whose metadata cannot be read
    says less; the exports and ``inspect`` say why)."""
    try:
        return as_dict(dataset.metadata(0)) if len(dataset) else {}
    except (DatasetError, ValueError):
        return {}


def _described(meta: dict[str, Any]) -> str:
    described = as_dict(meta.get("robot")).get("description")
    return described if isinstance(described, str) else ""


def _robot(described: str, manifest: dict[str, Any]) -> str:
    """The robot's name: its description's folder (``robots/fetch/fetch.urdf`` -> fetch)."""
    if described:
        if ":" in described:
            return described.rsplit(":", 1)[-1]
        path = Path(described)
        return path.parent.name or path.stem
    return str(as_scalar(as_dict(manifest["config"].get("robot")).get("name")))


# a statistic whose name alone would mislead -> what it counts
STATISTIC_LABELS = {
    "visible_fraction_targets": "visible fraction of the targets: targets per bin of the "
    "fraction of each the workspace camera sees (one it does not see counts in the first bin)",
    "visible_fraction_distractors": "visible fraction of the distractors: the same for the "
    "distractors (class distractor), counted apart from the targets",
}


def _statistics(summary: dict[str, Any]) -> list[str]:
    if not summary:
        return ["No statistics: no sample's metadata could be summarised."]
    flat = {k: v for k, v in summary.items() if not isinstance(v, dict)}
    lines = ["| statistic | value |", "|---|---|"]
    lines += [f"| {text(str(k).replace('_', ' '))} | {text(v)} |" for k, v in flat.items()]
    for name, value in summary.items():
        if isinstance(value, dict) and value:
            label = STATISTIC_LABELS.get(name, str(name).replace("_", " "))
            lines += ["", f"**{text(label)}**", ""]
            if all(not isinstance(v, dict | list) for v in value.values()):
                rows = (f"| {text(k)} | {text(v)} |" for k, v in value.items())
                lines += ["| | |", "|---|---|", *rows]
            else:
                lines += fenced(yaml.safe_dump(value, sort_keys=False).rstrip(), "yaml")
    return lines


PREFIXES = {
    "frame<k>": "frame k",
    "f<k>": "frame k",
    "wrist": "wrist camera",
    "post": "after the hold",
}


def _describe_part(kind: str) -> str:
    pieces = kind.split(".")
    known = ".".join(pieces[-2:]) in PARTS
    what = PARTS.get(".".join(pieces[-2:]), PARTS.get(pieces[-1], ""))
    prefix = pieces[:-2] if known else pieces[:-1]
    where = ", ".join(PREFIXES.get(p, f"camera {p}") for p in prefix)
    return f"{what}; {where}" if where and what else what


def _exports_section(root: Path, manifest: dict[str, Any]) -> list[str]:
    records = {k: v for k, v in manifest["exports"].items() if k in EXPORTS}
    if not records:
        return ["None yet: `datagen export DIR --to FORMAT` writes one beside the shards."]
    lines = ["| format | where | size | what |", "|---|---|---|---|"]
    for name, record in sorted(records.items()):
        path = EXPORTS[name].path
        card = f"[{path}/]({path}/{CARD})" if (root / path).is_dir() else f"`{path}`"
        what = _layout(EXPORTS[name]).split("\n\n")[0].replace("\n", " ")
        size = record.get("bytes") if type(record.get("bytes")) is int else 0
        lines.append(f"| {name} | {card} | {size / 2**20:.1f} MiB | {what} |")
    return lines


def dataset_card(
    root: Path, manifest: dict[str, Any], parts: list[str], described: str, summary: dict[str, Any]
) -> str:
    scene = manifest["scene"]
    family = FAMILIES.get(scene)
    version = manifest["versions"].get("datagen", "")
    shards, config, classes = manifest["shards"], manifest["config"], manifest["classes"]
    size = sum(s.get("bytes", 0) for s in shards) / 2**20
    build_id = manifest["build_id"]
    body = [
        f"# {text(scene)} dataset (datagen build {text(build_id)})",
        "",
        f"Synthetic data made by datagen {text(version)}"
        + (f": {family.summary}" if family else "")
        + f". {manifest['num_samples']} samples of scene {code(scene)}, "
        f"seed {manifest['seed']}, build id {code(build_id)}, "
        f"made {text(manifest['created_utc'])}.",
        "",
    ]
    if (root / "preview.png").is_file():
        body += ["![samples with their annotations drawn](preview.png)", ""]
    body += [
        "## Files",
        "",
        f"- `shard-*.tar`: {len(shards)} WebDataset shard{'' if len(shards) == 1 else 's'} "
        f"({size:.1f} MiB); a sample is the "
        "tar members `KEY.PART` of one key (9 digits). Its parts:",
        "",
        "| part | holds |",
        "|---|---|",
        *(f"| `{kind}` | {_describe_part(kind)} |" for kind in part_kinds(parts)),
        "",
        "- `manifest.json`: how it was made, every shard's and sample's sha256;",
        f"- `{CROISSANT}`: the same files described in Croissant 1.0 (MLCommons) for catalogues "
        "and `mlcroissant`.",
        "",
        "Load it with datagen (`datagen.load(DIR)`), with the `webdataset` "
        "package, or with Hugging Face `datasets` (the `configs` above read the shards).",
        "",
        "## Classes",
        "",
        "The id is the value in `semantic.png` (and COCO's `category_id`).",
        "",
        "| id | class |",
        "|---|---|",
        *(f"| {i} | {text(name)} |" for i, name in enumerate(classes)),
        "",
        "## Statistics",
        "",
        "Computed from the samples' metadata (as `datagen inspect` reports them).",
        "",
        *_statistics(summary),
        "",
        "## Exports",
        "",
        *_exports_section(root, manifest),
        "",
        "## Licence",
        "",
        licence_text(manifest, described),
        "",
        "## How it was made",
        "",
        f"`datagen build CONFIG --out DIR` with this config and seed {manifest['seed']} "
        "makes the same samples again.",
        "",
        *fenced(yaml.safe_dump(config, sort_keys=True).rstrip(), "yaml"),
        "",
        "| software | version |",
        "|---|---|",
        *(f"| {text(k)} | {text(v)} |" for k, v in manifest["versions"].items() if k != "platform"),
    ]
    return "\n".join(body) + "\n"


def _part_names(dataset: ShardDataset) -> list[str]:
    """Every part name the samples hold, in first-seen order (from the shards' index only)."""
    return list(dict.fromkeys(p for i in range(len(dataset)) for p in dataset.part_names(i)))


def card_is_current(root: Path) -> bool:
    """Whether ``root``'s card was written after its manifest last changed (an export recorded)."""
    card, manifest = root / CARD, root / "manifest.json"
    if card.is_symlink() or not card.is_file():  # a link planted there is not its card
        return False
    return card.stat().st_mtime_ns >= manifest.stat().st_mtime_ns


def write_dataset_card(root: str | Path, summary: dict[str, Any] | None = None) -> list[Path]:
    """Writes ``root/README.md`` and ``root/croissant.json`` (each replaced whole, never written
    through a link); ``summary``: ``datagen.tools.inspection.metadata_summary(root)``."""
    root = Path(root)
    dataset = load(root)
    manifest = card_facts(dataset.manifest)
    parts = _part_names(dataset)
    described = _described(_first_metadata(dataset))
    robot = _robot(described, manifest)
    header = front_matter(manifest, parts, robot, [{"split": "train", "path": "shard-*.tar"}])
    card = yaml_header(header) + dataset_card(root, manifest, parts, described, summary or {})
    description = f"Synthetic {manifest['scene']} data made by datagen (seed {manifest['seed']})"
    doc = dataset_croissant(manifest, parts, _slug(header["pretty_name"]), description, LICENSE)
    return [
        _write(root, CARD, card),
        _write(root, CROISSANT, strict_json(doc, CROISSANT, indent=1)),
    ]


def write_export_card(folder: Path, fmt: ExportFormat, dataset: ExportedDataset) -> list[Path]:
    """Writes ``folder/README.md`` and ``folder/croissant.json`` for the ``fmt`` export written
    into ``folder`` from ``dataset`` (nothing for a format that writes one file)."""
    if not folder.is_dir() or folder.is_symlink():
        return []
    manifest = card_facts(dataset.manifest)
    robot = _robot(_described(_first_metadata(dataset)), manifest)
    data_files = [
        {"split": split, "path": files}
        for split, files in EXPORT_DATA_FILES.get(fmt.name, [])
        if next(folder.glob(files), None)  # a split with no file would break the Hub's loader
    ]
    header = front_matter(manifest, [], robot, data_files, EXPORT_TASKS.get(fmt.name, ()))
    header["pretty_name"] = f"{header['pretty_name']} ({fmt.name})"
    header["license_link"] = f"../{CARD}#licence"
    header["tags"].append(fmt.name)
    layout = _layout(fmt)
    body = [
        f"# {fmt.name} export of the {text(manifest['scene'])} dataset "
        f"(datagen build {text(manifest['build_id'])})",
        "",
        f"Written by `datagen export DIR --to {fmt.name}` (datagen "
        f"{text(manifest['versions'].get('datagen', ''))}) from the dataset one folder up: its "
        f"[card](../{CARD}) has the config, seed {manifest['seed']}, classes, statistics and "
        f"licence; its shards are the source of truth.",
        "",
        "## Layout",
        "",
        layout.strip(),
        "",
        f"`{CROISSANT}` lists these files in Croissant 1.0.",
    ]
    description = f"The {fmt.name} export of datagen build {manifest['build_id']}"
    doc = export_croissant(folder, manifest, _slug(header["pretty_name"]), description, LICENSE)
    card = yaml_header(header) + "\n".join(body) + "\n"
    return [
        _write(folder, CARD, card),
        _write(folder, CROISSANT, strict_json(doc, CROISSANT, indent=1)),
    ]


def _layout(fmt: ExportFormat) -> str:
    """What the format's files hold: its module's docstring (double backticks are Markdown too)."""
    return (importlib.import_module(fmt.export.partition(":")[0]).__doc__ or "").strip()


def _slug(text: str) -> str:
    return "-".join("".join(c if c.isalnum() else " " for c in text).split())


def _write(folder: Path, name: str, content: str) -> Path:
    return replace_file(inside(folder, name), lambda tmp: tmp.write_text(content, encoding="utf-8"))
