"""Segmentation nets users know, trained from scratch: torchvision's LR-ASPP on a
MobileNetV3-Large (Howard et al. 2019) where torchvision loads, else a small U-Net
(Ronneberger et al. 2015). Each maps (N, 3, H, W) images in 0..1 to (N, classes, H, W) logits."""

from __future__ import annotations

from collections.abc import Callable


def torchvision_problem() -> str | None:
    """Why torchvision's segmentation models cannot be used here, or None when they can. A
    torchvision wheel built for CUDA fails to load its operators under a CPU-only torch."""
    try:
        import torchvision.models.segmentation  # noqa: F401
    except (ImportError, OSError, RuntimeError) as error:
        return f"{type(error).__name__}: {error}"
    return None


def lraspp(num_classes: int):
    """``lraspp_mobilenet_v3_large(weights=None, weights_backbone=None)``, its ``out`` only."""
    from torch import nn
    from torchvision.models.segmentation import lraspp_mobilenet_v3_large

    class OutputOnly(nn.Module):
        def __init__(self) -> None:
            super().__init__()
            self.net = lraspp_mobilenet_v3_large(
                weights=None, weights_backbone=None, num_classes=num_classes
            )

        def forward(self, x):
            return self.net(x)["out"]

    return OutputOnly()


def small_unet(num_classes: int, width: int = 16):
    """A U-Net of four levels (``width`` to 8 ``width`` channels, two 3x3 convolutions with
    batch norm and ReLU each), max-pooled down, bilinearly up to the skip's size (so any image
    size works) and concatenated with it."""
    import torch
    from torch import nn
    from torch.nn import functional

    def double_conv(into: int, out: int):
        return nn.Sequential(
            nn.Conv2d(into, out, 3, padding=1, bias=False),
            nn.BatchNorm2d(out),
            nn.ReLU(inplace=True),
            nn.Conv2d(out, out, 3, padding=1, bias=False),
            nn.BatchNorm2d(out),
            nn.ReLU(inplace=True),
        )

    class SmallUNet(nn.Module):
        def __init__(self) -> None:
            super().__init__()
            channels = [width, 2 * width, 4 * width, 8 * width]
            self.down = nn.ModuleList(
                double_conv(a, b) for a, b in zip([3, *channels[:-1]], channels, strict=True)
            )
            self.up = nn.ModuleList(
                double_conv(deep + skip, skip)
                for deep, skip in zip(channels[:0:-1], channels[-2::-1], strict=True)
            )
            self.head = nn.Conv2d(width, num_classes, 1)

        def forward(self, x):
            skips = []
            for level, block in enumerate(self.down):
                x = block(x if level == 0 else functional.max_pool2d(x, 2))
                skips.append(x)
            for block, skip in zip(self.up, skips[-2::-1], strict=True):
                x = functional.interpolate(x, size=skip.shape[-2:], mode="bilinear")
                x = block(torch.cat([x, skip], dim=1))
            return self.head(x)

    return SmallUNet()


NETS: dict[str, Callable] = {"lraspp": lraspp, "unet": small_unet}


def chosen_net(name: str) -> tuple[str, str]:
    """(net, why): ``auto`` is ``lraspp`` where torchvision loads, else ``unet``."""
    problem = torchvision_problem()
    if name == "lraspp" and problem:
        raise SystemExit(f"--net lraspp needs torchvision: {problem}")
    if name != "auto":
        return name, "chosen"
    if problem:
        return "unet", f"torchvision unavailable ({problem.splitlines()[0][:120]})"
    return "lraspp", "torchvision loads"
