"""Training a segmentation net and predicting with it, alike for every net and training set:
AdamW with a cosine learning-rate schedule to zero, each batch mirrored and jittered."""

from __future__ import annotations

from collections.abc import Callable

BATCH = 32


def augmented(x, y, generator):
    """Each image mirrored left-right with probability 0.5, its contrast scaled by 0.8-1.2
    about its mean and its brightness moved by -0.1..0.1 (images in 0..1): the usual
    photometric and geometric augmentation, applied alike to every training set."""
    import torch

    n = len(x)
    flip = (torch.rand(n, generator=generator) < 0.5).to(x.device)
    x = torch.where(flip[:, None, None, None], x.flip(-1), x)
    y = torch.where(flip[:, None, None], y.flip(-1), y)
    contrast = (0.8 + 0.4 * torch.rand(n, 1, 1, 1, generator=generator)).to(x.device)
    brightness = (0.2 * torch.rand(n, 1, 1, 1, generator=generator) - 0.1).to(x.device)
    mean = x.mean(dim=(1, 2, 3), keepdim=True)
    return ((x - mean) * contrast + mean + brightness).clamp(0, 1), y


def autocast(device, precision: str):
    """bfloat16 convolutions with ``precision="bf16"``, else float32."""
    import torch

    return torch.autocast(device.type, dtype=torch.bfloat16, enabled=precision == "bf16")


def train(
    x,
    y,
    make_net: Callable,
    epochs: int,
    seed: int,
    augment: bool = True,
    precision: str = "fp32",
):
    """``make_net()`` (called after seeding, so ``seed`` fixes its first weights) trained on
    float images ``x`` (N, 3, H, W) and class maps ``y`` (N, H, W); (the net in eval mode, the
    mean loss of each epoch). The cosine schedule's last epochs settle the weights, so the
    score depends less on where the seed left them. ``precision="bf16"`` runs the
    convolutions in bfloat16 (weights stay float32)."""
    import torch
    from torch import nn

    torch.manual_seed(seed)
    net = make_net().to(x.device, memory_format=torch.channels_last)
    optimiser = torch.optim.AdamW(net.parameters(), lr=3e-3, weight_decay=1e-4)
    steps = epochs * ((len(x) + BATCH - 1) // BATCH)
    schedule = torch.optim.lr_scheduler.CosineAnnealingLR(optimiser, steps)
    generator = torch.Generator().manual_seed(seed)
    losses = []
    for _ in range(epochs):
        order = torch.randperm(len(x), generator=generator).to(x.device)
        total = 0.0
        for batch in order.split(BATCH):
            xb, yb = augmented(x[batch], y[batch], generator) if augment else (x[batch], y[batch])
            with autocast(x.device, precision):
                logits = net(xb.contiguous(memory_format=torch.channels_last))
            loss = nn.functional.cross_entropy(logits.float(), yb)
            optimiser.zero_grad()
            loss.backward()
            optimiser.step()
            schedule.step()
            total += loss.item() * len(batch)
        losses.append(round(total / len(x), 4))
    return net.eval(), losses


def predict(net, x, precision: str = "fp32"):
    """(N, H, W) class indices: each pixel's most likely class."""
    import torch

    with torch.no_grad(), autocast(x.device, precision):
        return torch.cat(
            [net(b.contiguous(memory_format=torch.channels_last)).argmax(1) for b in x.split(64)]
        )
