"""Dataset cards (docs/dataset-card.md): ``README.md`` with a Hugging Face dataset card's front
matter and ``croissant.json`` (Croissant 1.0), written by ``datagen build`` beside the manifest and
by ``datagen export`` in each export folder; the Croissant documents are loaded by mlcroissant in
its own environment (``readers_python``), which fails on any validation error, and their record
sets read back from the real files."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from datagen.exports.card_header import size_category
from datagen.exports.croissant import part_kinds

pytestmark = pytest.mark.sim

REPO = Path(__file__).resolve().parents[2]

HUB_TASKS = {"robotics", "object-detection", "image-segmentation", "depth-estimation"}
HUB_SIZES = {"n<1K", "1K<n<10K", "10K<n<100K", "100K<n<1M", "1M<n<10M", "10M<n<100M", "100M<n<1B", "1B<n<10B", "10B<n<100B", "100B<n<1T", "n>1T"}  # fmt: skip
# loads a croissant.json (mlcroissant raises on a validation error) and counts its records; one
# process and cache each: mlcroissant caches a shard's files by its name, the same in every dataset
READ_BACK = """
import json, sys, mlcroissant as mlc
dataset = mlc.Dataset(sys.argv[1])
print(json.dumps({rs.uuid: sum(1 for _ in dataset.records(rs.uuid)) for rs in dataset.metadata.record_sets}))
"""


def _card(path: Path) -> tuple[dict, str]:
    text = path.read_text()
    match = re.fullmatch(r"---\n(.*?)\n---\n(.*)", text, re.S)
    assert match, f"{path}: no YAML front matter"
    return yaml.safe_load(match[1]), match[2]


def _check_front_matter(header: dict, scene: str, folder: Path) -> None:
    assert header["license"] == "other" and header["license_name"] == "user-defined"
    assert set(header["task_categories"]) <= HUB_TASKS and "robotics" in header["task_categories"]
    assert header["size_categories"] == ["n<1K"] and set(header["size_categories"]) <= HUB_SIZES
    assert {"synthetic", "datagen", scene} <= set(header["tags"])
    for config in header.get("configs", []):
        for files in config["data_files"]:
            assert list(folder.glob(files["path"])), files  # it names files that are there


def _read_back(readers_python: Path, path: Path, cache: Path) -> dict[str, int]:
    done = subprocess.run(
        [str(readers_python), "-c", READ_BACK, str(path)], capture_output=True, text=True,
        timeout=300, check=False,
        env={"CROISSANT_CACHE": str(cache), "PATH": "/usr/bin:/bin", "HOME": str(cache)},
    )  # fmt: skip
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_size_buckets_and_part_kinds_follow_the_hub_and_the_tar_names():
    assert [size_category(n) for n in (0, 999, 1000, 123_456, 10**12)] == ["n<1K", "n<1K", "1K<n<10K", "100K<n<1M", "n>1T"]  # fmt: skip
    kinds = part_kinds(["rgb.png", "view1.rgb.png", "frame3.rgb.png", "frame12.wrist.rgb.png", "f0001.rgb.png"])  # fmt: skip
    assert kinds == {
        "f<k>.rgb.png": ["?????????.f[0-9][0-9][0-9][0-9].rgb.png"],
        "frame<k>.rgb.png": ["?????????.frame[0-9].rgb.png"],
        "frame<k>.wrist.rgb.png": ["?????????.frame[0-9][0-9].wrist.rgb.png"],
        "rgb.png": ["?????????.rgb.png"],  # not view1.rgb.png: '?' is one character
        "view1.rgb.png": ["?????????.view1.rgb.png"],
    }


def test_a_build_writes_its_card_and_croissant(
    frames_dataset, navigation_dataset, campaign_dataset, readers_python, tmp_path
):
    manifest = json.loads((frames_dataset / "manifest.json").read_text())
    header, body = _card(frames_dataset / "README.md")
    _check_front_matter(header, "grasp_tabletop", frames_dataset)
    assert set(header["task_categories"]) == HUB_TASKS and "panda" in header["tags"]
    assert header["configs"][0]["data_files"] == [{"split": "train", "path": "shard-*.tar"}]
    assert f"seed {manifest['seed']}" in body and manifest["build_id"] in body
    assert "datagen 0." in body and "![samples with their annotations drawn](preview.png)" in body
    for class_id, name in enumerate(manifest["classes"]):
        assert f"| {class_id} | {name} |" in body
    config = yaml.safe_load(body.split("```yaml\n")[-1].split("```")[0])
    assert config == manifest["config"]  # the config, whole, as the build used it
    assert "| samples | 4 |" in body and "**objects per class**" in body  # inspect's statistics
    assert "**visible fraction of the targets:" in body  # each role counted apart
    assert "**visible fraction of the distractors:" in body
    header, body = _card(navigation_dataset / "README.md")
    _check_front_matter(header, "navigation", navigation_dataset)
    assert "fetch" in header["tags"] and "| episodes | 2 |" in body and "success rate" in body
    header, body = _card(campaign_dataset / "README.md")
    assert "| `frame<k>.wrist.rgb.png` |" in body and "success_rate:" in body  # campaign stats
    frames = _read_back(readers_python, frames_dataset / "croissant.json", tmp_path / "c1")
    assert frames["rgb_png"] == frames["view1_rgb_png"] == frames["json"] == 4
    navigation = _read_back(readers_python, navigation_dataset / "croissant.json", tmp_path / "c2")
    metas = [json.loads(p.read_text()) for p in _members(navigation_dataset, "json", tmp_path)]
    assert navigation["f_k_rgb_png"] == sum(m["episode"]["frames"] for m in metas) > 0
    campaign = _read_back(readers_python, campaign_dataset / "croissant.json", tmp_path / "c3")
    assert campaign["json"] == 3 and all(campaign.values())  # tests/exports/test_croissant.py


def _members(dataset: Path, part: str, tmp: Path) -> list[Path]:
    import tarfile

    out = tmp / "members"
    for shard in sorted(dataset.glob("shard-*.tar")):
        with tarfile.open(shard) as tar:
            names = [m for m in tar.getmembers() if m.name.endswith(f".{part}")]
            tar.extractall(out, members=names, filter="data")
    return sorted(out.glob(f"*.{part}"))


def test_an_export_writes_its_card_and_the_dataset_card_lists_it(
    frames_dataset, readers_python, tmp_path
):
    dataset = tmp_path / "datasets" / "grasp_tabletop"
    shutil.copytree(frames_dataset, dataset)
    victim = tmp_path / "victim.md"
    victim.write_text("precious")
    for name in ("README.md", "croissant.json"):  # links planted at the card's names
        (dataset / name).unlink()
        (dataset / name).symlink_to(victim)
    done = subprocess.run(
        [sys.executable, "-m", "datagen.cli", "export", str(dataset), "--to", "coco,hdf5"],
        capture_output=True, text=True, cwd=REPO, timeout=300, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr[-3000:]
    header, body = _card(dataset / "coco" / "README.md")
    _check_front_matter(header, "grasp_tabletop", dataset / "coco")
    assert "coco" in header["tags"] and "object-detection" in header["task_categories"]
    assert "[card](../README.md)" in body and "annotations.json" in body and "seed 2" in body
    assert victim.read_text() == "precious" and not (dataset / "README.md").is_symlink()
    _, body = _card(dataset / "README.md")  # rewritten: the manifest recorded the exports
    assert "| coco | [coco/](coco/README.md) |" in body and "| hdf5 | `episodes.h5` |" in body
    assert not (dataset / "episodes.h5.README.md").exists()  # a one-file export has no card
    counts = _read_back(readers_python, dataset / "coco" / "croissant.json", tmp_path / "c1")
    assert counts == {"images_png": 12}  # 4 samples x 3 views (workspace, view1, wrist)
    # the loading snippet of docs/dataset-card.md, as printed, on this dataset
    doc = (REPO / "docs" / "dataset-card.md").read_text()
    snippet = doc.split("<!-- snippet: tested by tests/exports/test_card.py -->\n```python\n")[1]
    snippet = snippet.split("```")[0]
    ran = subprocess.run(
        [str(readers_python), "-c", snippet], capture_output=True, text=True, cwd=tmp_path,
        timeout=300, check=False,
        env={"CROISSANT_CACHE": str(tmp_path / "cache2"), "PATH": "/usr/bin:/bin", "HOME": str(tmp_path)},
    )  # fmt: skip
    assert ran.returncode == 0, ran.stderr[-3000:]
    assert "000000003 (120, 160)" in ran.stdout


# the cut is at most this fraction of a sample's metadata: an aerial episode's keeps every
# drone's position and velocity in every frame (its altitude and speed figures read them)
@pytest.mark.parametrize(
    ("name", "fraction"),
    [("frames_dataset", 10), ("campaign_dataset", 10), ("navigation_dataset", 10),
     ("aerial_dataset", 5)],
)  # fmt: skip
def test_the_card_statistics_keep_a_small_part_of_each_sample_and_equal_inspects(
    name, fraction, request
):
    """The card's statistics stream: each sample's metadata is cut to what the summary reads
    (a tenth of it or less; a fifth for aerial episodes), and the summary of the cut samples is
    inspect's."""
    from datagen.dataset.loader import load
    from datagen.registries import metadata_format
    from datagen.tools.inspection import metadata_summary

    dataset = load(request.getfixturevalue(name))
    metas = [dataset.metadata(i) for i in range(len(dataset))]
    kind = metadata_format(metas[0], name)
    summarise, summary_fields = kind.function("summary"), kind.function("summary_fields")
    cut = [summary_fields(meta) for meta in metas]
    sizes = [(len(json.dumps(c)), len(json.dumps(m))) for c, m in zip(cut, metas, strict=True)]
    assert all(c * fraction < m for c, m in sizes), sizes
    summary = metadata_summary(dataset.root)
    summary.pop("campaign", None)  # the manifest's campaign statistics
    assert summary and summary == summarise(metas) == summarise(cut)
