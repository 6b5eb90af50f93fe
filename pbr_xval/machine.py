"""Machine facts recorded with every result (provenance): Python, platform, CPU model, BLAS kernels."""

from __future__ import annotations

import functools
import os
import platform

__all__ = ["machine_info"]


@functools.cache
def _cpu_model() -> str:
    try:
        with open("/proc/cpuinfo", encoding="utf-8", errors="replace") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or ""


def machine_info() -> dict[str, str]:
    """Machine facts recorded with every result.

    ``cpu_model`` and ``blas_coretype`` (``OPENBLAS_CORETYPE`` when set, else "auto": OpenBLAS
    picks its kernels by CPU) matter because results can move with the CPU: a chaotic rocking
    run can flip on a last-bit difference (docs/validation.md, "Machine dependence").
    """
    return {
        "python": platform.python_version(),
        "platform": platform.platform(),
        "machine": platform.machine(),
        "processor": platform.processor() or "",
        "cpu_model": _cpu_model(),
        "blas_coretype": os.environ.get("OPENBLAS_CORETYPE", "auto"),
        "cpu_count": str(os.cpu_count()),
    }
