"""A dataset card's header and licence statement: the YAML front matter the Hugging Face Hub
indexes (``license``, ``task_categories``, ``size_categories``, ``tags``, ``configs``) and what
datagen can state about the licences of what it rendered (``datagen.exports.card`` writes
both into the card)."""

from __future__ import annotations

from typing import Any

import yaml

from datagen.exports.card_text import code, text
from datagen.exports.croissant import as_dict
from datagen.registries import FAMILIES, ROBOTS

LICENSE = "other"  # no config key names one: the user states it before publishing
SIZE_BUCKETS = (  # the Hub's size_categories, by upper bound of the sample count
    (10**3, "n<1K"),
    (10**4, "1K<n<10K"),
    (10**5, "10K<n<100K"),
    (10**6, "100K<n<1M"),
    (10**7, "1M<n<10M"),
    (10**8, "10M<n<100M"),
    (10**9, "100M<n<1B"),
    (10**10, "1B<n<10B"),
    (10**11, "10B<n<100B"),
    (10**12, "100B<n<1T"),
)
# an image part -> the Hub task it serves (the metadata holds the boxes beside seg.png)
TASKS = {
    "seg.png": ("object-detection", "image-segmentation"),
    "semantic.png": ("image-segmentation",),
    "depth.png": ("depth-estimation",),
}
# export format -> (split, files) its folder's Hub config reads, where files match (else none)
EXPORT_DATA_FILES = {
    "coco": [("train", "images/*.png")],
    "lerobot": [("train", "data/*/*.parquet")],
    "yolo": [("train", "detect/images/train/*"), ("validation", "detect/images/val/*")],
}
EXPORT_TASKS = {
    "coco": ("object-detection", "image-segmentation"),
    "yolo": ("object-detection",),
    "bop": ("object-detection",),
}


def size_category(samples: int) -> str:
    return next((name for bound, name in SIZE_BUCKETS if samples < bound), "n>1T")


def licence_text(manifest: dict[str, Any], described: str) -> str:
    """``described``: the robot description the samples name (their metadata's ``robot``)."""
    config = manifest["config"]
    objects, robot = as_dict(config.get("objects")), as_dict(config.get("robot"))
    urdf = as_dict(robot.get("urdf"))
    lines = [
        "datagen does not choose a licence for the data it generates, so `license` is `other`: "
        "set it in the front matter before publishing. What datagen can state:",
        "",
        "- the images, depth, masks and labels are rendered and computed by datagen; no "
        "recorded data is in them;",
    ]
    if objects.get("source") == "folder":
        lines.append(
            "- the objects are meshes of the user's folder `objects.assets_dir` "
            "(their licences apply to the renders);"
        )
    else:
        lines.append("- the objects are procedural shapes made by datagen from the seed;")
    if as_dict(config.get("background")).get("images_dir"):
        lines.append("- background pictures come from the user's `background.images_dir`;")
    if as_dict(config.get("materials")).get("textures_dir"):
        lines.append("- surface textures come from the user's `materials.textures_dir`;")
    photos = as_dict(as_dict(manifest.get("pictures")).get("photos"))
    if photos.get("files"):
        licences: dict[str, set[str]] = {}
        for entry in photos["files"]:
            if isinstance(entry, dict):
                licences.setdefault(str(entry.get("source")), set()).add(str(entry.get("licence")))
        shown = "; ".join(
            f"{text(s)} ({text(', '.join(sorted(v)))})" for s, v in sorted(licences.items())
        )
        lines.append(
            f"- pictures of datagen's picture library appear on surfaces and walls: {shown}; "
            "the manifest's `pictures.photos.files` credits each file (docs/photo-library.md);"
        )
    name, family = robot.get("name"), FAMILIES.get(manifest["scene"])
    if family and family.world == "tabletop" and urdf.get("file"):
        lines.append("- the arm is rendered from the user's description (`robot.urdf.file`).")
    elif family and family.world == "tabletop" and isinstance(name, str) and name in ROBOTS:
        licence = ROBOTS[name].load().licence
        lines.append(f"- the arm {code(name)} is rendered from its description ({licence}).")
    elif described:
        lines.append(f"- the robot is rendered from {code(described)} (its licence applies).")
    return "\n".join(lines)


def front_matter(
    manifest: dict[str, Any], parts: list[str], robot: str, data_files: list[dict], tasks=()
) -> dict[str, Any]:
    """The card's YAML header (Hugging Face dataset-card keys; ``data_files``: the Hub's
    ``{split, path}`` records of the default config)."""
    scene = manifest["scene"]
    found = ["robotics"]
    for part in parts:
        found += TASKS.get(".".join(part.split(".")[-2:]), ())
    found += tasks
    header: dict[str, Any] = {
        "license": LICENSE,
        "license_name": "user-defined",
        "license_link": "README.md#licence",
        "pretty_name": f"datagen {scene} {manifest['build_id']}".strip(),
        "task_categories": list(dict.fromkeys(found)),
        "size_categories": [size_category(manifest["num_samples"])],
        "tags": [t for t in dict.fromkeys(["synthetic", "datagen", scene, robot]) if t],
    }
    if data_files:
        header["configs"] = [{"config_name": "default", "data_files": data_files}]
    return header


def yaml_header(doc: dict[str, Any]) -> str:
    return "---\n" + yaml.safe_dump(doc, sort_keys=False, allow_unicode=True) + "---\n"
