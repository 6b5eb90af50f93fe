"""pbr_xval.machine: the machine facts every result records."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from pbr_xval.machine import _simd, machine_info


def test_simd_names_the_widest_vector_extension() -> None:
    assert _simd("fpu sse4_2 avx avx2 avx512f avx512bw") == "avx512f"
    assert _simd("fpu sse4_2 avx avx2") == "avx2"
    assert _simd("fpu sse4_2 avx") == "avx"
    assert _simd("fpu sse2") == "none"
    assert _simd("") == "unknown"


@pytest.mark.skipif(not os.path.isfile("/proc/cpuinfo"), reason="needs /proc/cpuinfo")
def test_machine_info_records_the_cpu_generation_and_the_blas_kernels_in_use() -> None:
    """A VM may call Zen 4 and Zen 5 both "AMD EPYC": the family number tells them apart. The BLAS
    kernels recorded are those OpenBLAS runs, which OPENBLAS_CORETYPE overrides (a fresh process,
    since OpenBLAS reads it once, at load)."""
    info = machine_info()
    with open("/proc/cpuinfo", encoding="utf-8") as f:
        fam = next(ln.split(":", 1)[1].strip() for ln in f if ln.startswith("cpu family"))
    assert info["cpu_family"] == fam and info["cpu_model_number"].isdigit()
    code = "from pbr_xval.machine import machine_info as m; i = m(); print(i['blas_coretype'], i['blas_kernels'])"
    env = {**os.environ, "OPENBLAS_CORETYPE": "Sandybridge"}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    coretype, kernels = out.stdout.split()
    assert coretype == "Sandybridge"
    if kernels:  # numpy built on OpenBLAS (the wheels are): the override took effect
        assert kernels.lower() == "sandybridge"


def test_describe_machine_names_the_cpu_generation_and_kernels_in_one_line() -> None:
    """The benchmarks' header line: what tells two "AMD EPYC" machines and their BLAS apart."""
    from pbr_xval.machine import describe_machine

    info = {"cpu_model": "AMD EPYC", "cpu_family": "26", "cpu_model_number": "2", "simd": "avx512f",
            "blas_coretype": "Haswell", "blas_kernels": "Haswell", "cpu_count": "2"}  # fmt: skip
    assert describe_machine(info) == (
        "AMD EPYC (family 26, model 2; avx512f; OpenBLAS Haswell kernels, OPENBLAS_CORETYPE=Haswell), "
        "2 logical CPUs"
    )
    bare = {"cpu_model": "", "cpu_family": "", "cpu_model_number": "", "simd": "", "blas_coretype": "auto",
            "blas_kernels": "", "cpu_count": "4"}  # fmt: skip
    assert describe_machine(bare) == "unknown CPU (BLAS kernels unknown), 4 logical CPUs"
    assert "\n" not in describe_machine()


def test_cpu_has_reads_the_flags_line(monkeypatch) -> None:
    """``cpu_has``: a flag of ``/proc/cpuinfo``'s flags line, whole words only."""
    from pbr_xval import machine

    monkeypatch.setattr(machine, "_cpuinfo", lambda: {"flags": "sse4_2 avx avx2 avx512f"})
    assert machine.cpu_has("avx2") and machine.cpu_has("avx512f")
    assert not machine.cpu_has("avx512") and not machine.cpu_has("avx512bw")
    monkeypatch.setattr(machine, "_cpuinfo", lambda: {})
    assert not machine.cpu_has("avx2")  # no /proc/cpuinfo: nothing claimed


def test_blas_kernel_env_forces_or_clears_the_kernels(monkeypatch) -> None:
    """``blas_kernel_env``: one OpenBLAS thread; the kernel family and NumPy's switched-off loops
    as asked, and none inherited from this process when not asked."""
    from pbr_xval.machine import blas_kernel_env

    monkeypatch.setenv("OPENBLAS_CORETYPE", "Zen")
    monkeypatch.setenv("NPY_DISABLE_CPU_FEATURES", "AVX512F")
    plain = blas_kernel_env()
    assert plain["OPENBLAS_NUM_THREADS"] == "1"
    assert "OPENBLAS_CORETYPE" not in plain and "NPY_DISABLE_CPU_FEATURES" not in plain
    env = blas_kernel_env("Haswell", "X86_V4")
    assert env["OPENBLAS_CORETYPE"] == "Haswell" and env["NPY_DISABLE_CPU_FEATURES"] == "X86_V4"
    assert env["PATH"] == plain["PATH"]
