"""The notebooks run top to bottom (real kernel, real dataset built by the pipeline)."""

from __future__ import annotations

from pathlib import Path

import nbformat
import pytest
from nbclient import NotebookClient

from datagen.config import BuildConfig
from datagen.config.sections import OutputConfig, RenderConfig
from datagen.pipeline.run import run_build

pytestmark = [pytest.mark.sim, pytest.mark.mqtt, pytest.mark.slow]  # a real build, then a kernel

NOTEBOOKS = Path(__file__).resolve().parents[2] / "notebooks"


@pytest.fixture(scope="module")
def tiny_dataset(tmp_path_factory):
    out = tmp_path_factory.mktemp("notebook") / "tiny"
    config = BuildConfig(
        num_samples=16,
        seed=11,
        render=RenderConfig(width=160, height=120),
        output=OutputConfig(shard_size=6, formats=("webdataset", "coco")),
    )
    run_build(config, out, workers=2)
    return out


@pytest.mark.parametrize("name", ["explore_dataset.ipynb", "train_segmentation.ipynb"])
def test_notebook_runs(name, tiny_dataset, tmp_path, monkeypatch):
    monkeypatch.setenv("DATAGEN_DATASET", str(tiny_dataset))
    monkeypatch.delenv("MPLBACKEND", raising=False)  # the kernel's inline backend keeps figures
    notebook = nbformat.read(NOTEBOOKS / name, as_version=4)
    assert not any(c.get("outputs") for c in notebook.cells if c.cell_type == "code"), (
        f"{name} is committed with outputs; clear them"
    )
    NotebookClient(
        notebook,
        timeout=600,
        kernel_name="python3",
        resources={"metadata": {"path": str(NOTEBOOKS)}},
    ).execute()
    images = [
        o for c in notebook.cells if c.cell_type == "code" for o in c.outputs
        if "image/png" in o.get("data", {})
    ]  # fmt: skip
    assert images, f"{name} showed no picture"
