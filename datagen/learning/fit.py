"""Training a grasp-quality net on campaign examples, scoring it on attempts it never saw, and
writing it as the ONNX file the learned sampler loads."""

from __future__ import annotations

import io
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
from torch import nn

from datagen.grasp_model.inputs import GRASP_FEATURES
from datagen.grasp_model.model_file import CROP_INPUT, GRASP_INPUT
from datagen.learning.examples import GraspExamples
from datagen.learning.grasp_net import GraspQualityNet, SuccessProbability
from datagen.learning.metrics import auc_by_class, scores_of, within_scene_auc
from datagen.seeding import sample_rng

BATCH = 64
LEARNING_RATE = 1e-3
WEIGHT_DECAY = 1e-4


@dataclass
class Fitted:
    net: GraspQualityNet
    held_out: GraspExamples
    probabilities: np.ndarray  # (held-out N,) the net's success probability on each
    scores: dict  # metrics.scores_of on the held-out examples
    losses: list[float]  # mean training loss per epoch


def split(scenes: Sequence[str], held_out: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """(training rows, held-out rows) of examples tried in ``scenes``: a ``held_out`` share of
    the scenes, drawn from the ``grasp_model.split`` stream of ``seed``, with every example of
    each (the candidates of one scene share its picture: split apart, the held-out score would
    be of pictures the net trained on). One example a scene: a share of the examples."""
    names = list(dict.fromkeys(scenes))
    order = sample_rng(seed, 0, "grasp_model.split").permutation(len(names))
    held = {names[i] for i in order[: round(held_out * len(names))]}
    in_held = np.array([scene in held for scene in scenes], bool)
    rows = np.arange(len(scenes))
    return rows[~in_held], rows[in_held]


def fit(
    examples: GraspExamples,
    epochs: int = 40,
    seed: int = 0,
    held_out: float = 0.2,
    on_epoch: Callable[[int, float], None] | None = None,
) -> Fitted:
    """A net (:func:`train_net`) trained on all but a ``held_out`` share of ``examples`` for
    ``epochs``, scored on that share."""
    if len(examples) < 2 or len(set(examples.success.tolist())) < 2:
        raise ValueError(
            f"{len(examples)} examples, {int(examples.success.sum())} of them successes: "
            "a model needs both successes and failures to learn from"
        )
    train_rows, test_rows = split(examples.scene_names(), held_out, seed)
    net, losses = train_net(examples.subset(train_rows), epochs, seed, on_epoch)
    test = examples.subset(test_rows)
    probabilities = predict(net, test.crops, test.features)
    scores = scores_of(probabilities, test.success)
    scores["classes"] = auc_by_class(probabilities, test.success, test.families)
    scores["within_scene"] = within_scene_auc(probabilities, test.success, test.scene_names())
    return Fitted(net, test, probabilities, scores, losses)


def train_net(
    examples: GraspExamples,
    epochs: int,
    seed: int,
    on_epoch: Callable[[int, float], None] | None = None,
) -> tuple[GraspQualityNet, list[float]]:
    """A net trained on every one of ``examples`` for ``epochs`` (AdamW, cosine schedule,
    failures and successes weighed equally), and its mean training loss per epoch."""
    torch.manual_seed(seed)
    net = GraspQualityNet(examples.crops.shape[-1])
    crops = torch.from_numpy(examples.crops)
    features = torch.from_numpy(examples.features)
    labels = torch.from_numpy(examples.success.astype(np.float32))
    positive = float(labels.mean())
    weight = torch.tensor((1 - positive) / max(positive, 1e-6))  # balances the two classes
    loss_of = nn.BCEWithLogitsLoss(pos_weight=weight)
    optimiser = torch.optim.AdamW(net.parameters(), LEARNING_RATE, weight_decay=WEIGHT_DECAY)
    steps = epochs * max(1, -(-len(labels) // BATCH))
    schedule = torch.optim.lr_scheduler.CosineAnnealingLR(optimiser, steps)
    shuffle = torch.Generator().manual_seed(seed)
    losses: list[float] = []
    for epoch in range(epochs):
        net.train()
        total = 0.0
        for rows in torch.randperm(len(labels), generator=shuffle).split(BATCH):
            optimiser.zero_grad()
            loss = loss_of(net(crops[rows], features[rows]), labels[rows])
            loss.backward()
            optimiser.step()
            schedule.step()
            total += float(loss.detach()) * len(rows)
        losses.append(total / len(labels))
        if on_epoch:
            on_epoch(epoch + 1, losses[-1])
    return net, losses


def predict(net: GraspQualityNet, crops: np.ndarray, features: np.ndarray) -> np.ndarray:
    net.eval()
    with torch.no_grad():
        logits = net(torch.from_numpy(crops), torch.from_numpy(features))
    return torch.sigmoid(logits).numpy().astype(np.float64)


def onnx_bytes(net: GraspQualityNet) -> bytes:
    """The net as an ONNX graph of the learned sampler's contract (any batch size)."""
    size = net.size
    example = (torch.zeros(2, 1, size, size), torch.zeros(2, GRASP_FEATURES))
    buffer = io.BytesIO()
    net.eval()
    with warnings.catch_warnings():  # the TorchScript-based exporter says it is the legacy one
        warnings.simplefilter("ignore")
        torch.onnx.export(
            SuccessProbability(net),
            example,
            buffer,  # type: ignore[arg-type]  # a file object is accepted (torch.onnx docs)
            dynamo=False,
            input_names=[CROP_INPUT, GRASP_INPUT],
            output_names=["success"],
            dynamic_axes={CROP_INPUT: {0: "n"}, GRASP_INPUT: {0: "n"}, "success": {0: "n"}},
        )
    return buffer.getvalue()


def write_model(net: GraspQualityNet, path: Path) -> None:
    """The ONNX file, written beside ``path`` and renamed over it (never half written)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    partial = path.with_name(path.name + ".partial")
    partial.write_bytes(onnx_bytes(net))
    partial.replace(path)
