"""Training code's side: ``datagen.collate`` batches for a torch DataLoader, and the recipes of
docs/using-the-data.md (and the README's copy) run exactly as printed, each alone in a fresh
namespace as if pasted by itself, on a small dataset (synthetic shards)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
import torch
from torch.utils.data import DataLoader

import datagen

REPO = Path(__file__).resolve().parents[2]
README_PATH = "datasets/grasp_tabletop"  # the dataset the recipes name
RECIPES = REPO / "docs" / "using-the-data.md"


def tagged_python(doc: Path, tag: str) -> str | None:
    """The ```python block right after ``<!-- test: TAG -->`` in ``doc``, or None."""
    found = re.search(
        rf"<!-- test: {re.escape(tag)} -->\n```python\n(.*?)\n```\n", doc.read_text(), re.S
    )
    return found[1] if found else None


@pytest.fixture
def dataset(tmp_path, make_dataset, make_sample) -> Path:
    return make_dataset(tmp_path / "ds", [make_sample(i) for i in range(10)], shard_size=3)


def run_recipe(tag: str, dataset: Path) -> dict:
    """Runs the ```python block after ``<!-- test: TAG -->`` in docs/using-the-data.md alone (a
    fresh namespace: no imports from another block), with the dataset path it names replaced by
    ``dataset``; returns its namespace."""
    code = tagged_python(RECIPES, tag)
    assert code, f"docs/using-the-data.md has no python block tagged <!-- test: {tag} -->"
    assert f'"{README_PATH}"' in code
    code = code.replace(f'"{README_PATH}"', repr(str(dataset)))
    namespace: dict = {}
    exec(compile(code, f"docs/using-the-data.md <!-- test: {tag} -->", "exec"), namespace)
    return namespace


@pytest.mark.parametrize("tag", ["map-style", "streaming", "webdataset"])
def test_a_recipe_the_readme_prints_is_the_tested_one(tag):
    """The README's front page repeats some recipes: each copy is the block tested here."""
    printed = tagged_python(REPO / "README.md", tag)
    assert printed is None or printed == tagged_python(RECIPES, tag)


def assert_batches_match(batches: list[dict], items: dict[str, dict], size: int) -> None:
    seen = []
    for batch in batches:
        n = len(batch["key"])
        assert 1 <= n <= size and isinstance(batch["key"], list)
        assert batch["rgb"].dtype == torch.uint8 and tuple(batch["rgb"].shape) == (n, 24, 32, 3)
        assert batch["depth"].dtype == torch.int32 and tuple(batch["depth"].shape) == (n, 24, 32)
        assert batch["seg"].dtype == torch.int32
        assert batch["semantic"].dtype == torch.uint8
        assert isinstance(batch["meta"], list) and len(batch["meta"]) == n
        for j, key in enumerate(batch["key"]):
            item = items[key]
            for name in ("rgb", "depth", "seg", "semantic"):
                np.testing.assert_array_equal(batch[name][j].numpy(), item[name])
            assert batch["meta"][j] == item["meta"]
        seen += batch["key"]
    assert sorted(seen) == sorted(items) and len(seen) == len(items)


@pytest.mark.adversarial  # issue 14: a DataLoader with batch_size > 1 failed
@pytest.mark.parametrize("workers", [0, 2])
def test_collate_batches_load_and_stream(dataset, workers):
    items = {item["key"]: item for item in datagen.load(dataset)}
    for source in (datagen.load(dataset), datagen.stream(dataset, shuffle=True, buffer_size=4)):
        loader = DataLoader(source, batch_size=4, num_workers=workers, collate_fn=datagen.collate)
        assert_batches_match(list(loader), items, 4)


def test_collate_keeps_what_it_cannot_stack_as_lists():
    a = {"key": "a", "map": np.zeros((4, 5, 3), np.uint8), "depth": np.full((2, 2), 65535, np.uint16),
         "occupancy": np.ones((3, 3), bool), "frames": [{"rgb": np.zeros(1)}], "frame": 0}  # fmt: skip
    b = {"key": "b", "map": np.zeros((6, 5, 3), np.uint8), "depth": np.zeros((2, 2), np.uint16),
         "occupancy": np.zeros((3, 3), bool), "frames": [], "frame": 3, "extra.bin": b"x"}  # fmt: skip
    batch = datagen.collate([a, b])
    assert batch["key"] == ["a", "b"] and batch["frame"] == [0, 3]
    assert batch["depth"].dtype == torch.int32 and batch["depth"][0, 0, 0] == 65535
    assert batch["occupancy"].dtype == torch.bool and tuple(batch["occupancy"].shape) == (2, 3, 3)
    assert [tuple(m.shape) for m in batch["map"]] == [(4, 5, 3), (6, 5, 3)]  # shapes differ
    assert batch["frames"] == [a["frames"], []]
    assert batch["extra.bin"] == [None, b"x"]


def test_the_readme_dataloader_recipes_run_as_printed(dataset):
    items = {item["key"]: item for item in datagen.load(dataset)}
    namespace = run_recipe("map-style", dataset)
    assert_batches_match(list(namespace["loader"]), items, 8)
    namespace = run_recipe("streaming", dataset)  # alone: it has its own imports
    batches = list(namespace["loader"])
    assert sorted(k for b in batches for k in b["key"]) == sorted(items)
    assert all(b["semantic"].dtype == torch.uint8 and b["rgb"].ndim == 4 for b in batches)


@pytest.mark.adversarial  # issue 14: the recipe lost 16-bit depth
def test_the_readme_webdataset_recipe_keeps_16_bit_depth(dataset):
    namespace = run_recipe("webdataset", dataset)
    loaded = datagen.load(dataset)
    samples = list(namespace["web"])
    assert [s["__key__"] for s in samples] == loaded.keys
    for sample, item in zip(samples, loaded, strict=True):
        assert sample["depth.png"].dtype == np.uint16 and sample["depth.png"].max() > 255
        np.testing.assert_array_equal(sample["depth.png"], item["depth"])
        assert sample["seg.png"].dtype == np.uint16
        np.testing.assert_array_equal(sample["seg.png"], item["seg"])
        np.testing.assert_array_equal(sample["rgb.png"], item["rgb"])
        np.testing.assert_array_equal(sample["semantic.png"], item["semantic"])
        assert sample["json"] == item["meta"]
