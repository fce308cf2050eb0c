"""A small grasp-quality net in the manner of GQ-CNN: convolutions over the depth crop, a dense
layer over the grasp's features, joined into one logit of success. Its input scales are fixed
(crop / ``CROP_RANGE_M``, features by ``FEATURE_SCALE``) and inside the net, so the ONNX file
takes the contract's raw inputs."""

from __future__ import annotations

import torch
from torch import nn

from datagen.grasp_model.inputs import CROP_RANGE_M, GRASP_FEATURES

# centre depth (~0.2-1 m), width (~0-0.08 m), approach and closing (unit vectors) in the
# camera frame; centre (~0-1 m) and approach (a unit vector) in the robot's base frame
FEATURE_SCALE = (2.0, 20.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 2.0, 2.0, 2.0, 1.0, 1.0, 1.0)
CROP_DIVISOR = 8  # three 2x poolings: a crop side must be a multiple of this


class GraspQualityNet(nn.Module):
    def __init__(self, size: int = 32, width: int = 16):
        super().__init__()
        if size % CROP_DIVISOR:
            raise ValueError(f"crop size {size}: expected a multiple of {CROP_DIVISOR}")
        self.size = size  # pixels a side of the depth crop it takes
        self.register_buffer("feature_scale", torch.tensor(FEATURE_SCALE))
        self.depth = nn.Sequential(
            nn.Conv2d(1, width, 5, padding=2),
            nn.ReLU(),
            nn.MaxPool2d(2),
            nn.Conv2d(width, 2 * width, 3, padding=1),
            nn.ReLU(),
            nn.MaxPool2d(2),
            nn.Conv2d(2 * width, 2 * width, 3, padding=1),
            nn.ReLU(),
            nn.MaxPool2d(2),
            nn.Flatten(),
        )
        self.grasp = nn.Sequential(nn.Linear(GRASP_FEATURES, 2 * width), nn.ReLU())
        joined = 2 * width * (size // CROP_DIVISOR) ** 2 + 2 * width
        self.head = nn.Sequential(
            nn.Linear(joined, 4 * width), nn.ReLU(), nn.Dropout(0.2), nn.Linear(4 * width, 1)
        )

    def forward(self, crop: torch.Tensor, grasp: torch.Tensor) -> torch.Tensor:
        """(N,) logits of success."""
        seen = self.depth(crop / CROP_RANGE_M)
        told = self.grasp(grasp * self.get_buffer("feature_scale"))
        return self.head(torch.cat([seen, told], dim=1))[:, 0]


class SuccessProbability(nn.Module):
    """What the ONNX file holds: the net's logit turned into a probability of success."""

    def __init__(self, net: GraspQualityNet):
        super().__init__()
        self.net = net

    def forward(self, crop: torch.Tensor, grasp: torch.Tensor) -> torch.Tensor:
        return torch.sigmoid(self.net(crop, grasp))
