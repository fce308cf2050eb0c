"""OpenBLAS's kernel is pinned on AVX-512 CPUs before numpy loads it (datagen/blas_kernel.py):
an Emerald Rapids, whose model numpy's OpenBLAS does not know, drew other bytes with the kernels
it fell back to, and the recorded ones with this."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from datagen.blas_kernel import pinned_kernel

AVX512 = "flags\t\t: fpu sse2 avx2 avx512f avx512dq amx_tile avx512_fp16\n"
AVX2 = "flags\t\t: fpu sse2 avx2 fma\n"


def test_an_avx512_cpu_gets_the_skylakex_kernel_unless_the_user_chose_one():
    assert pinned_kernel(AVX512, {}) == {"OPENBLAS_CORETYPE": "SKYLAKEX"}
    assert pinned_kernel(AVX512, {"OPENBLAS_CORETYPE": "SAPPHIRERAPIDS"}) == {}
    assert pinned_kernel(AVX2, {}) == {}


def test_importing_datagen_sets_it_before_numpy_loads_openblas():
    code = (
        "import os, sys, datagen, numpy; "
        "print(os.environ.get('OPENBLAS_CORETYPE'), 'numpy' in sys.modules)"
    )
    done = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        check=True,
        env={"PATH": "/usr/bin:/bin"},
    )
    expected = pinned_kernel(Path("/proc/cpuinfo").read_text(), {}).get("OPENBLAS_CORETYPE")
    assert done.stdout.split() == [str(expected), "True"]


def test_the_manifest_records_the_kernel(monkeypatch):
    """Two machines' bytes differ where their kernels do: the manifest says which it was."""
    from datagen.pipeline.manifest import _versions

    monkeypatch.setenv("OPENBLAS_CORETYPE", "Haswell")
    assert _versions()["OPENBLAS_CORETYPE"] == "Haswell"
    monkeypatch.delenv("OPENBLAS_CORETYPE")
    assert _versions()["OPENBLAS_CORETYPE"] == "unset"
