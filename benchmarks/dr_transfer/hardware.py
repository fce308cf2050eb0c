"""The machine a benchmark trains on, and the precision and threads it trains with there:
bfloat16 autocast only on a CPU with AVX-512 BF16 where a quick check finds it faster."""

from __future__ import annotations

import os
import subprocess
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path

from machine import cpu_model  # benchmarks/machine.py

BF16_MIN_SPEED_UP = 1.1  # bf16 must train this many times faster to be chosen


@dataclass
class Cpu:
    model: str
    cores: int  # cores this process may run on
    avx512_bf16: bool

    def line(self) -> str:
        flag = "with" if self.avx512_bf16 else "without"
        return f"{self.model}, {self.cores} cores, {flag} AVX-512 BF16"


def cpu_flags() -> list[str]:
    """The first CPU's flags in /proc/cpuinfo (none where it cannot be read)."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("flags"):
                return line.split(":", 1)[1].split()
    except OSError:
        pass
    return []


def this_cpu() -> Cpu:
    return Cpu(cpu_model(), len(os.sched_getaffinity(0)), "avx512_bf16" in cpu_flags())


def commit(repo: Path) -> str:
    """``git rev-parse HEAD``, with ``+changes`` when a tracked file differs from it."""

    def git(*args: str) -> str:
        return subprocess.run(
            ["git", *args], cwd=repo, capture_output=True, text=True, check=False
        ).stdout.strip()

    head = git("rev-parse", "HEAD") or "unknown"
    return head + ("+changes" if git("status", "--porcelain", "--untracked-files=no") else "")


def device_named(name: str):
    """``auto``: cuda where torch sees a GPU, else cpu."""
    import torch

    if name == "auto":
        name = "cuda" if torch.cuda.is_available() else "cpu"
    return torch.device(name)


def steps_per_second(make_net: Callable, x, y, steps: int = 2, rounds: int = 2) -> dict:
    """Training steps a second on batch ``x``, ``y`` in fp32 and in bf16: after one untimed
    step each, the faster of ``rounds`` timings of ``steps`` steps, the precisions taking
    turns (so a load that comes and goes on a shared machine weighs on both alike)."""
    from dr_transfer.training import train

    seconds = {"fp32": [], "bf16": []}
    for precision in seconds:
        train(x, y, make_net, epochs=1, seed=0, precision=precision)
    for _ in range(rounds):
        for precision, times in seconds.items():
            start = time.perf_counter()
            train(x, y, make_net, epochs=steps, seed=0, precision=precision)
            times.append(time.perf_counter() - start)
    return {precision: steps / min(times) for precision, times in seconds.items()}


def chosen_precision(requested: str, cpu: Cpu, device, make_net: Callable, x, y) -> dict:
    """``requested`` unless ``auto``: then bf16 on a CPU with AVX-512 BF16 when it trains
    ``BF16_MIN_SPEED_UP`` times faster than fp32 on a batch of ``x``, ``y``; else fp32.
    Returns the precision, why, and the measured steps a second."""
    if requested != "auto":
        return {"precision": requested, "why": "chosen"}
    if device.type != "cpu":
        return {"precision": "fp32", "why": f"{device.type}: float32"}
    if not cpu.avx512_bf16:
        return {"precision": "fp32", "why": "no AVX-512 BF16"}
    rates = steps_per_second(make_net, x, y)
    faster = rates["bf16"] >= BF16_MIN_SPEED_UP * rates["fp32"]
    why = f"bf16 {rates['bf16']:.2f} vs fp32 {rates['fp32']:.2f} steps/s"
    return {"precision": "bf16" if faster else "fp32", "why": why, "steps_per_s": rates}


def describe(cpu: Cpu) -> dict:
    return asdict(cpu) | {"line": cpu.line()}
