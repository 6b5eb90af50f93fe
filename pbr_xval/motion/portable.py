"""Signal processing whose result is the same bit for bit on every x86-64 CPU.

Why our own code and not scipy's: :func:`scipy.signal.detrend` (a least-squares solve) and
:func:`scipy.signal.sosfiltfilt` (its initial conditions come from ``sosfilt_zi``, a
``numpy.linalg.solve``) go through LAPACK/BLAS, and OpenBLAS picks its kernels by CPU at run
time (``OPENBLAS_CORETYPE``: SkylakeX on an AVX-512 machine, Haswell or Zen on an AVX2 one,
Sandybridge on older ones). The kernels round differently in the last bit, so the same shake-table
record, corrected on an AMD and on an Intel machine, differed in the last bits of some samples
(measured: ``OPENBLAS_CORETYPE=Haswell`` vs ``SkylakeX`` changed the corrected record of every
SP1 test tried; ``Sandybridge`` also changed the detrend). A rocking rock near its toppling level
is chaotic, so last-bit input differences flipped 8 of 196 PyBullet outcomes between two CPUs
(issue 21). Here the same operations are written without BLAS: sums are exactly rounded
(:func:`math.fsum`, independent of summation order and SIMD width), the second-order sections'
initial conditions are solved in closed form, and the filtering itself is scipy's
:func:`scipy.signal.sosfilt` (a scalar C loop, no BLAS, no run-time CPU dispatch).

``tests/motion/test_portable.py`` runs the record pipeline under every OpenBLAS core type in
subprocesses and requires identical bytes.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["detrend", "linear_fit", "sosfilt_zi", "sosfiltfilt"]


def linear_fit(a: ArrayLike) -> tuple[float, float]:
    """Least-squares line through the samples ``a[k]`` at k = 0 … n−1: (offset, slope per sample).

    Closed form with exactly rounded sums (:func:`math.fsum`), so independent of the CPU.
    """
    x = np.asarray(a, dtype=np.float64)
    n = x.size
    if n == 0:
        return 0.0, 0.0
    mean = math.fsum(x.tolist()) / n
    if n == 1:
        return mean, 0.0
    kbar = (n - 1) / 2.0
    k = np.arange(n, dtype=np.float64) - kbar  # exact: integers and half-integers
    sxy = math.fsum((k * (x - mean)).tolist())
    sxx = n * (n * n - 1) / 12.0  # Σ (k − k̄)² in closed form
    slope = sxy / sxx
    return mean - slope * kbar, slope


def detrend(a: ArrayLike, kind: str = "linear") -> NDArray[np.float64]:
    """``a`` minus its mean (``"constant"``) or its least-squares line (``"linear"``), over the sample index.

    The same operation as :func:`scipy.signal.detrend` with its default breakpoints, equal to it
    within rounding (a few ulp), and the same on every CPU.
    """
    x = np.asarray(a, dtype=np.float64)
    if kind == "constant":
        return x - math.fsum(x.tolist()) / max(x.size, 1)
    if kind == "linear":
        c, s = linear_fit(x)
        return x - (c + s * np.arange(x.size, dtype=np.float64))
    raise ValueError(f"detrend kind {kind!r}: expected 'constant' or 'linear'")


def sosfilt_zi(sos: ArrayLike) -> NDArray[np.float64]:
    """Initial conditions of :func:`scipy.signal.sosfilt` for a step response's steady state.

    Same definition as :func:`scipy.signal.sosfilt_zi` (each section's ``lfilter_zi`` scaled by
    the DC gain of the sections before it), with each section's 2 × 2 system
    ((I − Aᵀ) z = b[1:] − a[1:]·b[0], A the companion matrix of a) solved in closed form:
    z₀ = (B₀ + B₁)/(1 + a₁ + a₂), z₁ = B₁ − a₂·z₀.

    Parameters
    ----------
    sos : (n_sections, 6) float, rows [b0, b1, b2, a0, a1, a2]

    Returns
    -------
    (n_sections, 2) float
    """
    s = np.asarray(sos, dtype=np.float64)
    if s.ndim != 2 or s.shape[1] != 6:
        raise ValueError(f"sos must have shape (n_sections, 6), got {s.shape}")
    zi = np.empty((s.shape[0], 2))
    scale = 1.0
    for i, (b0, b1, b2, a0, a1, a2) in enumerate(s.tolist()):
        if a0 != 1.0:
            b0, b1, b2, a1, a2 = b0 / a0, b1 / a0, b2 / a0, a1 / a0, a2 / a0
            a0 = 1.0
        big0 = b1 - a1 * b0
        big1 = b2 - a2 * b0
        z0 = (big0 + big1) / (1.0 + a1 + a2)
        zi[i, 0] = scale * z0
        zi[i, 1] = scale * (big1 - a2 * z0)
        scale *= (b0 + b1 + b2) / (a0 + a1 + a2)
    return zi


def sosfiltfilt(sos: ArrayLike, x: ArrayLike) -> NDArray[np.float64]:
    """Zero-phase forward–backward filtering, as :func:`scipy.signal.sosfiltfilt` with its defaults.

    Odd extension of ``3·ntaps`` samples at each end (``ntaps = 2·n_sections + 1``, less the
    sections of first order), initial conditions from :func:`sosfilt_zi`, forward pass, backward
    pass, extension removed: scipy's algorithm step for step, without its LAPACK solve.

    Parameters
    ----------
    sos : (n_sections, 6) float
    x : (n,) float, n > 3·ntaps

    Returns
    -------
    (n,) float
    """
    from scipy.signal import sosfilt

    s = np.asarray(sos, dtype=np.float64)
    a = np.asarray(x, dtype=np.float64)
    if a.ndim != 1:
        raise ValueError(f"x must be one-dimensional, got shape {a.shape}")
    ntaps = 2 * s.shape[0] + 1 - min(int((s[:, 2] == 0).sum()), int((s[:, 5] == 0).sum()))
    edge = 3 * ntaps
    if a.size <= edge:
        raise ValueError(f"the record has {a.size} samples; zero-phase filtering needs more than {edge}")
    left = 2.0 * a[0] - a[edge:0:-1]
    right = 2.0 * a[-1] - a[-2 : -(edge + 2) : -1]
    ext = np.concatenate([left, a, right])
    zi = sosfilt_zi(s)
    y, _ = sosfilt(s, ext, zi=zi * ext[0])
    y, _ = sosfilt(s, y[::-1], zi=zi * y[-1])
    return np.ascontiguousarray(y[::-1][edge:-edge], dtype=np.float64)
