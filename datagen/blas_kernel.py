"""One OpenBLAS kernel for every AVX-512 CPU, so a build draws the same bytes on all of them.

numpy's OpenBLAS picks its kernels by CPU model at load. The release numpy 1.26.4 bundles does
not know every AVX-512 model: on an Emerald Rapids (model 207) it fell back to other kernels and
the same commit and seed drew other metadata, IMU streams and flights than the AVX-512 machine
``tests/data/golden_parts.avx512.json`` was recorded on. With ``OPENBLAS_CORETYPE`` set to
SKYLAKEX, COOPERLAKE or SAPPHIRERAPIDS (each tried there) it drew the recorded bytes. So where
the CPU has AVX-512F and the user set no kernel, datagen sets SKYLAKEX, the oldest of them,
before numpy loads OpenBLAS: at ``import datagen``, which the command line, its workers (they inherit the environment) and the test
suite (``-p datagen.blas_kernel``) do first. AVX2 machines keep OpenBLAS's own choice; they
draw other bytes anyway (docs/configuration.md, "Reproducibility").

Imports nothing that loads OpenBLAS."""

from __future__ import annotations

import os
from pathlib import Path

AVX512_KERNEL = "SKYLAKEX"  # the kernel of the CPUs the AVX-512 digests were recorded on


def pinned_kernel(cpuinfo: str, environ: dict[str, str] | os._Environ[str]) -> dict[str, str]:
    """{"OPENBLAS_CORETYPE": ...} to set, from ``/proc/cpuinfo``'s text; empty where the CPU
    lacks AVX-512F or the user chose a kernel."""
    if "OPENBLAS_CORETYPE" in environ or " avx512f" not in cpuinfo:
        return {}
    return {"OPENBLAS_CORETYPE": AVX512_KERNEL}


def pin_kernel() -> None:
    """Sets the kernel in this process's environment (only numpy imported after it sees it)."""
    try:
        cpuinfo = Path("/proc/cpuinfo").read_text()
    except OSError:  # not Linux: OpenBLAS's own choice
        return
    os.environ.update(pinned_kernel(cpuinfo, os.environ))
