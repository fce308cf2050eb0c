"""Croissant 1.0 metadata (MLCommons, JSON-LD): ``croissant.json`` beside a dataset's manifest and
in each export folder, for catalogues and loaders (``mlcroissant``) to find what the files hold.

A dataset's distribution is its shards (``cr:FileObject``, tar, with the manifest's sha256) and,
inside them, one ``cr:FileSet`` per kind of part (``rgb.png``, ``json``, ``wrist.depth.png``,
``f<k>.rgb.png``, ...: a frame number in a part name is a wildcard); each kind is a
``cr:RecordSet`` of one record per file: the sample key (from the file's name), the name and the
content (decoded for images and text; not for binary parts, nor for optical flow, whose 16-bit
colour PNG mlcroissant's image decoder, PIL, would cut to 8 bits). mlcroissant extracts a shard
before reading it, and tries zip before tar: a shard never ends near a zip's signature
(``datagen.writer.tar_end``). An export folder's distribution is its files: the top-level ones
(with sha256) and one ``cr:FileSet`` per folder and file type; a set of images is also a record
set of file name and content (mlcroissant reads JSON, YAML or Parquet files as tables, not as
content).
"""

from __future__ import annotations

import re
from collections import defaultdict
from pathlib import Path
from typing import Any

from datagen.sample import KEY_DIGITS
from datagen.shards import file_sha256

CONFORMS_TO = "http://mlcommons.org/croissant/1.0"
CONTEXT = {
    "@language": "en",
    "@vocab": "https://schema.org/",
    "citeAs": "cr:citeAs",
    "column": "cr:column",
    "conformsTo": "dct:conformsTo",
    "cr": "http://mlcommons.org/croissant/",
    "rai": "http://mlcommons.org/croissant/RAI/",
    "data": {"@id": "cr:data", "@type": "@json"},
    "dataType": {"@id": "cr:dataType", "@type": "@vocab"},
    "dct": "http://purl.org/dc/terms/",
    "equivalentProperty": "cr:equivalentProperty",
    "examples": {"@id": "cr:examples", "@type": "@json"},
    "extract": "cr:extract",
    "field": "cr:field",
    "fileProperty": "cr:fileProperty",
    "fileObject": "cr:fileObject",
    "fileSet": "cr:fileSet",
    "format": "cr:format",
    "includes": "cr:includes",
    "isLiveDataset": "cr:isLiveDataset",
    "jsonPath": "cr:jsonPath",
    "key": "cr:key",
    "md5": "cr:md5",
    "parentField": "cr:parentField",
    "path": "cr:path",
    "recordSet": "cr:recordSet",
    "references": "cr:references",
    "regex": "cr:regex",
    "repeated": "cr:repeated",
    "replace": "cr:replace",
    "sc": "https://schema.org/",
    "samplingRate": "cr:samplingRate",
    "separator": "cr:separator",
    "source": "cr:source",
    "subField": "cr:subField",
    "transform": "cr:transform",
}
# file suffix -> (MIME type, Croissant data type of its content)
MEDIA = {
    "png": ("image/png", "sc:ImageObject"),
    "jpg": ("image/jpeg", "sc:ImageObject"),
    "json": ("application/json", "sc:Text"),
    "txt": ("text/plain", "sc:Text"),
    "yaml": ("application/yaml", "sc:Text"),
    "md": ("text/markdown", "sc:Text"),
    "csv": ("text/csv", "sc:Text"),
    "parquet": ("application/x-parquet", None),
}
BINARY = ("application/octet-stream", None)  # npz, ply, h5, usd, mp4 ...: listed, not decoded
FRAME = re.compile(r"^(frame|f)(\d+)$")  # a part-name component that numbers a frame
KEY_REGEX = rf"^([0-9]{{{KEY_DIGITS}}})\..*$"
HASHED_BYTES = 2**30  # an export's top-level file above this is listed without its sha256
# BibTeX's (and LaTeX's) special characters in a field, as LaTeX spells them
_BIBTEX = {
    "\\": r"\textbackslash{}",
    "{": r"\{",
    "}": r"\}",
    "%": r"\%",
    "#": r"\#",
    "&": r"\&",
    "$": r"\$",
    "_": r"\_",
    "^": r"\^{}",
    "~": r"\~{}",
}


def as_dict(value: Any) -> dict[str, Any]:
    return value if isinstance(value, dict) else {}


def as_scalar(value: Any, default: Any = "") -> Any:
    return (
        value if isinstance(value, str | int | float) and not isinstance(value, bool) else default
    )


def card_facts(manifest: Any) -> dict[str, Any]:
    """What a card states of a manifest, each value of the type a card needs (a manifest is
    input: a key of another type reads as missing rather than breaking the card)."""
    manifest = as_dict(manifest)
    shards = []
    for shard in manifest.get("shards", []) if isinstance(manifest.get("shards"), list) else []:
        shard = as_dict(shard)
        if isinstance(shard.get("name"), str):
            size = shard.get("bytes")
            digest = shard.get("sha256")
            shards.append(
                {
                    "name": shard["name"],
                    **(
                        {"bytes": size}
                        if isinstance(size, int) and not isinstance(size, bool)
                        else {}
                    ),
                    **({"sha256": digest} if isinstance(digest, str) else {}),
                }
            )
    samples = manifest.get("num_samples")
    classes = manifest.get("classes")
    return {
        **{k: str(as_scalar(manifest.get(k))) for k in ("scene", "build_id", "created_utc")},
        "seed": seed if type(seed := manifest.get("seed")) is int else None,
        "num_samples": samples if isinstance(samples, int) and samples >= 0 else 0,
        "versions": {
            str(k): str(v)
            for k, v in as_dict(manifest.get("versions")).items()
            if as_scalar(v, None) is not None
        },
        "config": as_dict(manifest.get("config")),
        "classes": [str(c) for c in classes] if isinstance(classes, list) else [],
        "shards": shards,
        "exports": {k: as_dict(v) for k, v in as_dict(manifest.get("exports")).items()},
    }


def _id(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9_-]", "_", text)


def bibtex(value: str) -> str:
    """``value`` as the text of a BibTeX field: on one line, its special characters escaped."""
    flat = " ".join(str(value).split())
    return "".join(_BIBTEX.get(c, c) for c in flat)


def _media(name: str) -> tuple[str, str | None]:
    if name.split(".")[-2:] == ["flow", "png"]:  # 16-bit colour: PIL (mlcroissant) reads 8 bits
        return MEDIA["png"][0], None
    return MEDIA.get(name.rsplit(".", 1)[-1].lower(), BINARY)


def part_kinds(part_names: list[str]) -> dict[str, list[str]]:
    """Part-name kinds (a frame number replaced by ``<k>``: ``f<k>.rgb.png``) -> tar-member globs
    of one sample key and that kind (one per frame-number width seen)."""
    kinds: dict[str, set[str]] = defaultdict(set)
    for part in part_names:
        kind, glob = [], []
        for piece in part.split("."):
            frame = FRAME.match(piece)
            kind.append(f"{frame[1]}<k>" if frame else piece)
            glob.append(f"{frame[1]}{'[0-9]' * len(frame[2])}" if frame else piece)
        kinds[".".join(kind)].add("?" * KEY_DIGITS + "." + ".".join(glob))
    return {kind: sorted(globs) for kind, globs in sorted(kinds.items())}


def _record_set(name: str, file_set: str, data_type: str | None, key: dict | None) -> dict:
    fields = []
    if key:
        fields.append(
            {
                "@type": "cr:Field",
                "@id": f"{name}/key",
                "name": f"{name}/key",
                "description": "the sample key (also the tar member's name before the first dot)",
                "dataType": "sc:Text",
                "source": {
                    "fileSet": {"@id": file_set},
                    "extract": {"fileProperty": "filename"},
                    "transform": key,
                },
            }
        )
    fields.append(
        {
            "@type": "cr:Field",
            "@id": f"{name}/name",
            "name": f"{name}/name",
            "description": "the file's name",
            "dataType": "sc:Text",
            "source": {"fileSet": {"@id": file_set}, "extract": {"fileProperty": "filename"}},
        }
    )
    if data_type:
        fields.append(
            {
                "@type": "cr:Field",
                "@id": f"{name}/content",
                "name": f"{name}/content",
                "description": "the file's content",
                "dataType": data_type,
                "source": {"fileSet": {"@id": file_set}, "extract": {"fileProperty": "content"}},
            }
        )
    return {"@type": "cr:RecordSet", "@id": name, "name": name, "field": fields}


def _document(
    manifest: dict[str, Any], name: str, description: str, license_: str
) -> dict[str, Any]:
    version = manifest["versions"].get("datagen", "")
    note = (
        f"synthetic data generated by datagen {version}, build {manifest['build_id']}, "
        f"seed {manifest['seed']}"
    )
    doc = {
        "@context": CONTEXT,
        "@type": "sc:Dataset",
        "conformsTo": CONFORMS_TO,
        "name": name,
        "description": description,
        "license": license_,
        "url": "README.md",
        "version": version if re.fullmatch(r"\d+\.\d+\.\d+", version) else "0.0.0",
        "identifier": manifest["build_id"],
        "keywords": ["synthetic", "datagen", manifest["scene"]],
        "citeAs": (
            f"@misc{{datagen_{_id(manifest['build_id'])}, title={{{bibtex(name)}}}, "
            f"note={{{bibtex(note)}}}}}"
        ),
    }
    created = manifest["created_utc"]
    if re.fullmatch(r"\d{4}-\d{2}-\d{2}.*", created):
        doc["datePublished"] = created[:10]
    return doc


def dataset_croissant(
    manifest: dict[str, Any], part_names: list[str], name: str, description: str, license_: str
) -> dict[str, Any]:
    """The Croissant document of a dataset directory (``manifest``: its ``card_facts``;
    ``part_names``: its samples' parts)."""
    shards = manifest["shards"]
    distribution: list[dict[str, Any]] = []
    for shard in shards:
        item = {
            "@type": "cr:FileObject",
            "@id": _id(shard["name"]),
            "name": _id(shard["name"]),
            "contentUrl": shard["name"],
            "encodingFormat": "application/x-tar",
        }
        if "bytes" in shard:
            item["contentSize"] = f"{shard['bytes']} B"
        if "sha256" in shard:
            item["sha256"] = shard["sha256"]
        distribution.append(item)
    record_sets = []
    for kind, globs in part_kinds(part_names).items():
        mime, data_type = _media(kind)
        file_set = _id(f"{kind.replace('<k>', '_k')}_files")
        distribution.append(
            {
                "@type": "cr:FileSet",
                "@id": file_set,
                "name": file_set,
                "description": f"the {kind} part of every sample, inside the shards",
                "containedIn": [{"@id": _id(s["name"])} for s in shards],
                "encodingFormat": mime,
                "includes": globs,
            }
        )
        record_set = _id(kind.replace("<k>", "_k"))  # f<k>.rgb.png -> f_k_rgb_png
        record_sets.append(_record_set(record_set, file_set, data_type, {"regex": KEY_REGEX}))
    doc = _document(manifest, name, description, license_)
    return doc | {"distribution": distribution, "recordSet": record_sets}


def export_croissant(
    folder: Path, manifest: dict[str, Any], name: str, description: str, license_: str
) -> dict[str, Any]:
    """The Croissant document of an export ``folder`` (as written: its files are read;
    ``manifest``: the dataset's ``card_facts``)."""
    distribution: list[dict[str, Any]] = []
    groups: dict[tuple[str, str], bool] = {}  # (top folder, suffix) -> nested deeper
    for path in sorted(folder.rglob("*")):
        if not path.is_file() or path.is_symlink():
            continue
        relative = path.relative_to(folder)
        if len(relative.parts) == 1:
            if relative.name in ("README.md", "croissant.json"):
                continue
            item = {
                "@type": "cr:FileObject",
                "@id": _id(relative.name),
                "name": _id(relative.name),
                "contentUrl": relative.name,
                "encodingFormat": _media(relative.name)[0],
                "contentSize": f"{path.stat().st_size} B",
            }
            if path.stat().st_size <= HASHED_BYTES:
                item["sha256"] = file_sha256(path)
            distribution.append(item)
            continue
        suffix = relative.name.rsplit(".", 1)[-1] if "." in relative.name else ""
        group = (relative.parts[0], suffix)
        groups[group] = groups.get(group, False) or len(relative.parts) > 2
    record_sets = []
    for (top, suffix), nested in sorted(groups.items()):
        mime, data_type = _media(f"x.{suffix}")
        record_set = _id(f"{top}_{suffix}" if suffix else top)
        file_set = f"{record_set}_files"
        pattern = f"{top}/**/*" if nested else f"{top}/*"
        distribution.append(
            {
                "@type": "cr:FileSet",
                "@id": file_set,
                "name": file_set,
                "encodingFormat": mime,
                "includes": [f"{pattern}.{suffix}" if suffix else pattern],
            }
        )
        if data_type == "sc:ImageObject":  # mlcroissant parses JSON, YAML, ... as tables
            record_sets.append(_record_set(record_set, file_set, data_type, None))
    doc = _document(manifest, name, description, license_)
    return doc | {"distribution": distribution, "recordSet": record_sets}
