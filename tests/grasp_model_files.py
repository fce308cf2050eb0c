"""Grasp model files made in the tests: tiny nets exported to ONNX by torch, each one scoring
with a rule a test can check."""

from __future__ import annotations

import io
import warnings
from collections.abc import Callable
from pathlib import Path

import torch
from torch import nn

from datagen.grasp_model.inputs import GRASP_FEATURES


class Rule(nn.Module):
    def __init__(self, rule: Callable[[torch.Tensor, torch.Tensor], torch.Tensor]):
        super().__init__()
        self.rule = rule

    def forward(self, crop: torch.Tensor, grasp: torch.Tensor) -> torch.Tensor:
        # both inputs stay in the graph, whichever the rule reads
        return self.rule(crop, grasp) + 0 * crop.mean() + 0 * grasp.mean()


def onnx_file(
    path: Path,
    rule: Callable[[torch.Tensor, torch.Tensor], torch.Tensor],
    size: int = 32,
    names: tuple[str, str] = ("crop", "grasp"),
    features: int = GRASP_FEATURES,
) -> Path:
    """An ONNX file of ``rule(crop, grasp)`` with inputs named ``names`` (any batch size)."""
    buffer = io.BytesIO()
    example = (torch.zeros(2, 1, size, size), torch.zeros(2, features))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        torch.onnx.export(
            Rule(rule),
            example,
            buffer,
            dynamo=False,
            input_names=list(names),
            output_names=["score"],
            dynamic_axes={names[0]: {0: "n"}, names[1]: {0: "n"}},
        )
    path.write_bytes(buffer.getvalue())
    return path


def prefers_feature(path: Path, column: int, sign: float = 1.0) -> Path:
    """A model whose score is ``sign`` times one of the grasp's features."""
    return onnx_file(path, lambda crop, grasp: sign * grasp[:, column])
