"""A grasp model file is hostile input: bounded, never read through a link, never unpickled,
held to its contract at load with a one-line error naming the file."""

from __future__ import annotations

import hashlib
import os
import warnings

import numpy as np
import onnx
import pytest
import torch
from grasp_model_files import onnx_file, prefers_feature  # tests/grasp_model_files.py

from datagen.grasp_model import model_file
from datagen.grasp_model.inputs import GRASP_FEATURES
from datagen.grasp_model.model_file import ModelFileError, load_model


def one_line_error(path, *needles, sha256=None) -> str:
    with pytest.raises(ModelFileError) as caught:
        load_model(path, sha256)
    message = str(caught.value)
    assert "\n" not in message and str(path) in message
    for needle in needles:
        assert needle in message, message
    return message


def test_a_model_of_the_contract_loads_and_scores(tmp_path):
    path = prefers_feature(tmp_path / "m.onnx", column=0, sign=-1.0)
    model = load_model(path)
    assert model.crop_size == 32 and model.name == str(path)
    assert model.sha256 == hashlib.sha256(path.read_bytes()).hexdigest()
    features = np.zeros((3, GRASP_FEATURES), np.float32)
    features[:, 0] = [0.5, 0.3, 0.9]
    scores = model.score(np.zeros((3, 1, 32, 32), np.float32), features)
    assert scores.tolist() == pytest.approx([-0.5, -0.3, -0.9])


@pytest.mark.parametrize(
    ("content", "needle"),
    [
        (b"not a model at all\n", "not a usable ONNX model"),
        (b"\x89PNG\r\n\x1a\n" + bytes(64), "not a usable ONNX model"),
        (b"", "not a usable ONNX model"),
    ],
)
def test_a_file_that_is_no_model(tmp_path, content, needle):
    path = tmp_path / "bad.onnx"
    path.write_bytes(content)
    one_line_error(path, needle)


def test_a_truncated_model(tmp_path):
    path = prefers_feature(tmp_path / "m.onnx", column=0)
    path.write_bytes(path.read_bytes()[: len(path.read_bytes()) // 2])
    one_line_error(path, "not a usable ONNX model")


def test_inputs_and_outputs_off_the_contract(tmp_path):
    named = onnx_file(tmp_path / "names.onnx", lambda c, g: g[:, 0], names=("image", "pose"))
    one_line_error(named, "expected inputs 'crop'", "'image'")
    features = onnx_file(tmp_path / "f.onnx", lambda c, g: g[:, 0], features=6)
    one_line_error(features, "input 'grasp'", f"(N, {GRASP_FEATURES})")
    odd = onnx_file(tmp_path / "odd.onnx", lambda c, g: g[:, 0], size=5)
    one_line_error(odd, "input 'crop'", "from 8 to 256")
    two = onnx_file(tmp_path / "two.onnx", lambda c, g: g[:, :2])
    one_line_error(two, "one finite score per candidate")
    nan = onnx_file(tmp_path / "nan.onnx", lambda c, g: g[:, 0] * float("nan"))
    one_line_error(nan, "NaN or infinite")


def test_a_link_a_large_file_and_a_changed_file_are_refused(tmp_path, monkeypatch):
    path = prefers_feature(tmp_path / "m.onnx", column=0)
    link = tmp_path / "link.onnx"
    link.symlink_to(path)
    one_line_error(link, "a link")
    monkeypatch.setattr(model_file, "MODEL_MAX_BYTES", 100)
    one_line_error(path, "more than the 100 allowed")
    monkeypatch.undo()
    one_line_error(path, "the file changed", sha256="0" * 64)
    fifo = tmp_path / "fifo.onnx"
    os.mkfifo(fifo)
    one_line_error(fifo, "not a regular file")


class Weighted(torch.nn.Module):
    """A net with weights (initialisers, which ONNX can keep in a file beside the graph)."""

    def __init__(self):
        super().__init__()
        self.fc = torch.nn.Linear(GRASP_FEATURES, 1)

    def forward(self, crop, grasp):
        return self.fc(grasp)[:, 0] + 0 * crop.mean()


def test_a_model_that_points_at_files_outside_is_refused_without_reading_them(tmp_path):
    """ONNX may keep weights in external files named by relative paths; loaded from bytes,
    onnxruntime refuses them instead of opening them."""
    path = tmp_path / "m.onnx"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        torch.onnx.export(
            Weighted(),
            (torch.zeros(2, 1, 32, 32), torch.zeros(2, GRASP_FEATURES)),
            path,
            dynamo=False,
            input_names=["crop", "grasp"],
            dynamic_axes={"crop": {0: "n"}, "grasp": {0: "n"}},
        )
    graph = onnx.load(str(path))
    outside = tmp_path / "elsewhere"
    outside.mkdir()
    onnx.save_model(
        graph,
        str(outside / "m.onnx"),
        save_as_external_data=True,
        all_tensors_to_one_file=True,
        location="weights.bin",
        size_threshold=0,
    )
    assert (outside / "weights.bin").is_file()
    one_line_error(outside / "m.onnx", "keeps tensors in other files")


def test_a_custom_operator_domain_is_refused(tmp_path):
    path = prefers_feature(tmp_path / "m.onnx", column=0)
    graph = onnx.load(str(path))
    graph.graph.node[-1].domain = "evil.ops"
    graph.opset_import.append(onnx.helper.make_opsetid("evil.ops", 1))
    onnx.save_model(graph, str(path))
    one_line_error(path, "not a usable ONNX model")
