"""Machine facts recorded with every result (provenance): Python, platform, CPU model, BLAS kernels."""

from __future__ import annotations

import functools
import os
import platform

__all__ = ["blas_kernel_env", "cpu_has", "describe_machine", "machine_info"]


@functools.cache
def _cpuinfo() -> dict[str, str]:
    """The first processor's ``/proc/cpuinfo`` fields (empty where there is none)."""
    out: dict[str, str] = {}
    try:
        with open("/proc/cpuinfo", encoding="utf-8", errors="replace") as f:
            for line in f:
                if not line.strip():
                    break
                key, _, value = line.partition(":")
                out.setdefault(key.strip(), value.strip())
    except OSError:
        pass
    return out


def _cpu_model() -> str:
    return _cpuinfo().get("model name") or platform.processor() or ""


def _simd(flags: str) -> str:
    """The widest x86 vector extension among ``flags`` (``/proc/cpuinfo``'s flags line)."""
    have = set(flags.split())
    for name in ("avx512f", "avx2", "avx", "sse4_2"):
        if name in have:
            return name
    return "unknown" if not have else "none"


@functools.cache
def _blas_kernels() -> str:
    """The kernels numpy's OpenBLAS runs in this process (threadpoolctl's ``architecture``: set at
    load from the CPU, or from ``OPENBLAS_CORETYPE``), "" when not known."""
    try:
        import numpy  # noqa: F401  (loads the BLAS whose kernels are asked for)
        from threadpoolctl import threadpool_info  # type: ignore[import-untyped]
    except ImportError:
        return ""
    for lib in threadpool_info():
        if lib.get("internal_api") == "openblas":
            return str(lib.get("architecture") or "")
    return ""


def cpu_has(flag: str) -> bool:
    """Whether the CPU lists ``flag`` (e.g. ``"avx512f"``) among ``/proc/cpuinfo``'s flags."""
    return flag in _cpuinfo().get("flags", "").split()


def blas_kernel_env(coretype: str | None = None, npy_disable: str | None = None) -> dict[str, str]:
    """The environment for a child Python that computes as another CPU would: this process's
    environment with one OpenBLAS thread, ``OPENBLAS_CORETYPE`` = ``coretype`` (e.g. "Haswell",
    "SkylakeX", "Sandybridge"; None: the kernels this CPU picks) and ``NPY_DISABLE_CPU_FEATURES``
    = ``npy_disable`` (NumPy's own vector loops switched off; None: all on). Both variables are
    read when the child loads NumPy, so they cannot be changed in a running process."""
    env = {k: v for k, v in os.environ.items() if k not in ("OPENBLAS_CORETYPE", "NPY_DISABLE_CPU_FEATURES")}
    env["OPENBLAS_NUM_THREADS"] = "1"
    if coretype:
        env["OPENBLAS_CORETYPE"] = coretype
    if npy_disable:
        env["NPY_DISABLE_CPU_FEATURES"] = npy_disable
    return env


def machine_info() -> dict[str, str]:
    """Machine facts recorded with every result.

    ``cpu_model``, ``cpu_family`` / ``cpu_model_number`` (``/proc/cpuinfo``: a cloud VM often
    names only the vendor's line, "AMD EPYC", for CPUs of different generations — family 25 is
    Zen 3/4, 26 Zen 5), ``simd`` (the widest vector extension: avx512f, avx2, …),
    ``blas_coretype`` (``OPENBLAS_CORETYPE`` when set, else "auto": OpenBLAS picks its kernels by
    CPU) and ``blas_kernels`` (the kernels numpy's OpenBLAS actually runs) matter because results
    can move with the CPU: a chaotic rocking run can flip on a last-bit difference
    (docs/validation.md, "Machine dependence").
    """
    info = _cpuinfo()
    return {
        "python": platform.python_version(),
        "platform": platform.platform(),
        "machine": platform.machine(),
        "processor": platform.processor() or "",
        "cpu_model": _cpu_model(),
        "cpu_family": info.get("cpu family", ""),
        "cpu_model_number": info.get("model", ""),
        "simd": _simd(info.get("flags", "")) if info else "",
        "blas_coretype": os.environ.get("OPENBLAS_CORETYPE", "auto"),
        "blas_kernels": _blas_kernels(),
        "cpu_count": str(os.cpu_count()),
    }


def describe_machine(info: dict[str, str] | None = None) -> str:
    """One line naming the CPU beside a machine-dependent figure (a benchmark's header): model,
    family and model number, vector extension, the BLAS kernels in use and the logical CPUs, from
    :func:`machine_info` (or ``info``), e.g. "AMD EPYC (family 26, model 2; avx512f; OpenBLAS
    Haswell kernels, OPENBLAS_CORETYPE=Haswell), 2 logical CPUs"."""
    m = machine_info() if info is None else info
    gen = ", ".join(
        x for x in (m.get("cpu_family") and f"family {m['cpu_family']}",
                    m.get("cpu_model_number") and f"model {m['cpu_model_number']}") if x
    )  # fmt: skip
    blas = f"OpenBLAS {m['blas_kernels']} kernels" if m.get("blas_kernels") else "BLAS kernels unknown"
    if m.get("blas_coretype", "auto") != "auto":
        blas += f", OPENBLAS_CORETYPE={m['blas_coretype']}"
    parts = "; ".join(x for x in (gen, m.get("simd", ""), blas) if x)
    return f"{m.get('cpu_model') or 'unknown CPU'} ({parts}), {m.get('cpu_count', '?')} logical CPUs"
