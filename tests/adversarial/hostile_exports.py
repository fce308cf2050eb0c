"""Datasets made hostile for the exports (issue 38): the real grasp samples of
``forged_datasets.tiny_build`` and one real navigation episode (rendered once per test session in
this process, about 3 s), copied, then their manifest, a sample's metadata or a part replaced, and
the manifest re-signed from the shards, so that only the crafted content is wrong. The commands
are the real command line: in this process (``cli``), or as a user runs it (``real_cli``: what a
process prints as it exits, under a memory limit if asked)."""

from __future__ import annotations

import json
import re
import resource
import shutil
import struct
import subprocess
import sys
import zlib
from collections.abc import Callable
from pathlib import Path
from typing import Any

import yaml
from conftest import NAVIGATION, write_dataset  # tests/conftest.py
from markdown_it import MarkdownIt

from adversarial.forged_datasets import resign, rewrite_shard, tiny_build
from adversarial.grasp_dataset import cli as cli  # the in-process command line, for the tests
from datagen.config import config_from_dict
from datagen.registries import FAMILIES
from datagen.shards import write_json_durably

REPO = Path(__file__).resolve().parents[2]
GRASP_KEY = "000000000"  # the first grasp sample, alone in shard-0-000000.tar
_BUILT: dict[str, Path] = {}
# the keys datagen writes into a card's front matter and a YOLO data.yaml
FRONT_MATTER = {
    "license",
    "license_name",
    "license_link",
    "pretty_name",
    "task_categories",
    "size_categories",
    "tags",
    "configs",
}
DATA_YAML = {"path", "train", "val", "names"}


def grasp_source(tmp_path_factory) -> Path:
    """Two real grasp samples, one per shard, with the manifest a build writes: a build id,
    seed, versions and date beside the scene, classes and config. Copy it before changing it."""
    if "grasp" not in _BUILT:
        out = tmp_path_factory.mktemp("grasp-source") / "ds"
        shutil.copytree(tiny_build(tmp_path_factory), out)
        _stamp(out, "grasp-1", 0)
        _BUILT["grasp"] = out
    return _BUILT["grasp"]


def navigation_source(tmp_path_factory) -> Path:
    """One real navigation episode (``conftest.NAVIGATION``: 96x72, frames at 2 Hz) as a dataset."""
    if "navigation" not in _BUILT:
        out = tmp_path_factory.mktemp("navigation-source") / "ds"
        config = config_from_dict(NAVIGATION, source="conftest.NAVIGATION")
        family = FAMILIES[config.scene]
        write_dataset(out, [family.produce_sample(config, config.seed, 0)], 1)
        manifest = json.loads((out / "manifest.json").read_text())
        extra = {"scene": config.scene, "classes": list(family.class_names(config))}
        write_json_durably(out, manifest | extra | {"config": config.to_dict()})
        _stamp(out, "navigation-1", config.seed)
        _BUILT["navigation"] = out
    return _BUILT["navigation"]


def _stamp(root: Path, build_id: str, seed: int) -> None:
    manifest = json.loads((root / "manifest.json").read_text())
    versions = {"datagen": "0.1.0", "python": "3.11.0", "platform": "Linux"}
    stamp = {"build_id": build_id, "seed": seed, "num_samples": manifest["samples"]}
    made = {"versions": versions, "created_utc": "2025-01-01T00:00:00Z"}
    write_json_durably(root, manifest | stamp | made)


def forged(
    source: Path,
    dest: Path,
    meta: Callable[[dict[str, Any]], None] | None = None,
    parts: dict[str, bytes] | None = None,
    manifest: Callable[[dict[str, Any]], None] | None = None,
    key: str = GRASP_KEY,
) -> Path:
    """``source`` copied to ``dest``; sample ``key``'s metadata changed in place by ``meta``,
    its parts named in ``parts`` replaced, the manifest re-signed, then changed by ``manifest``."""
    root = Path(shutil.copytree(source, dest))
    found = set()

    def change(members):
        for info, data in members:
            name = info.name.partition(".")[2] if info.name.startswith(f"{key}.") else None
            if name == "json" and meta is not None:
                doc = json.loads(data)
                meta(doc)
                data = json.dumps(doc).encode()
            elif name in (parts or {}):
                data = parts[name]
            found.add(name)
            info.size = len(data)
            yield info, data

    for shard in sorted(root.glob("shard-*.tar")):
        rewrite_shard(shard, lambda members: list(change(members)))
    assert set(parts or {}) | ({"json"} if meta else set()) <= found, f"sample {key}: {found}"
    resign(root)
    if manifest is not None:
        doc = json.loads((root / "manifest.json").read_text())
        manifest(doc)
        (root / "manifest.json").write_text(json.dumps(doc))
    return root


def real_cli(*argv: object, memory: int | None = None) -> tuple[int, str, str]:
    """``datagen ARGV`` as a user runs it; ``memory``: its address-space limit in bytes."""

    def limit() -> None:
        if memory:
            resource.setrlimit(resource.RLIMIT_AS, (memory, memory))

    done = subprocess.run(
        [sys.executable, "-m", "datagen.cli", *map(str, argv)],
        capture_output=True,
        text=True,
        cwd=REPO,
        timeout=120,
        preexec_fn=limit,
    )
    return done.returncode, done.stdout, done.stderr


def png_bomb(width: int, height: int, depth: int = 1) -> bytes:
    """A valid greyscale PNG of zeros declaring ``width`` x ``height`` pixels: 1-bit 32000x32000
    is 124 KB and decodes to 1 GB."""

    def chunk(kind: bytes, data: bytes) -> bytes:
        crc = struct.pack(">I", zlib.crc32(kind + data))
        return struct.pack(">I", len(data)) + kind + data + crc

    row = b"\0" * (1 + (width * depth + 7) // 8)
    packer = zlib.compressobj(9)
    body = b"".join(packer.compress(row) for _ in range(height)) + packer.flush()
    header = struct.pack(">IIBBBBB", width, height, depth, 0, 0, 0, 0)
    return (
        b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", body) + chunk(b"IEND", b"")
    )


def front_matter(text: str) -> tuple[dict, str]:
    """(the YAML front matter of a card, its Markdown body)."""
    match = re.match(r"\A---\n(.*?)\n---\n(.*)\Z", text, re.S)
    assert match, text[:300]
    return yaml.safe_load(match[1]), match[2]


def rendered(body: str) -> tuple[list, str]:
    """(every token, the text it shows) of Markdown as CommonMark with GFM tables reads it."""
    tokens = MarkdownIt("commonmark").enable("table").parse(body)
    flat = []
    for token in tokens:
        flat += [token, *(token.children or [])]
    shown = "\n".join(t.content for t in flat if t.type in ("text", "code_inline", "fence"))
    return flat, shown


def link_targets(tokens: list) -> set:
    """Where the links and pictures among markdown-it ``tokens`` point."""
    found = (t for t in tokens if t.type in ("link_open", "image"))
    return {t.attrs.get("href") or t.attrs.get("src") for t in found}
