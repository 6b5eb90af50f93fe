"""Small dense linear algebra for the reference solver, the same bit for bit on every x86-64 CPU.

Why our own code and not NumPy's ``@``, ``numpy.linalg.lstsq`` / ``svd`` / ``norm``: those go
through BLAS and LAPACK, and OpenBLAS picks its kernels by CPU at run time (Haswell or Zen on an
AVX2 machine, SkylakeX on an AVX-512 one, Sandybridge on an AVX-only one); the kernels round
differently in the last bit (fused multiply-adds, the SIMD width's summation order). A rocking
rock near its toppling level is chaotic, so a last bit in the reference solver's Python paths
(the general step, the friction-cone polish and Newton solves, the pivoting LCP solvers and the
minimum-norm selection) moved its trajectories between ``OPENBLAS_CORETYPE=Haswell`` and
``SkylakeX`` and flipped outcomes of the SP1 and SP2 shake-table campaigns (docs/validation.md,
"Machine dependence"). Here every result comes from IEEE-754 additions, multiplications,
divisions and square roots in a fixed order, compiled by numba without ``fastmath`` (no
contraction into fused multiply-adds, no reassociation): the same bits whatever the CPU's
vector units. The systems are small (at most three unknowns per contact node, tens in all), so
plain loops cost microseconds.

The least-squares solve is the minimum-norm one of ``numpy.linalg.lstsq`` (singular values at
most ``rcond`` × the largest treated as zero), from a one-sided Jacobi singular value
decomposition (Hestenes 1958; Demmel & Veselić 1992: it is accurate to round-off relative to
each singular value, which the rank decision needs). ``tests/reference/test_dense.py`` checks
every function against NumPy's and runs the reference solver under several OpenBLAS core types
in subprocesses, requiring identical bytes.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = ["lstsq", "matmul", "matvec", "norm2", "null_space", "svd_jacobi"]

#: one-sided Jacobi sweeps at most (convergence is quadratic; a few sweeps at these sizes)
MAX_SWEEPS = 60


@njit(cache=True)
def matvec(a, x):
    """a @ x for a (m, n) matrix and an (n,) vector: each component summed over j ascending."""
    m, n = a.shape
    out = np.zeros(m)
    for i in range(m):
        s = 0.0
        for j in range(n):
            s += a[i, j] * x[j]
        out[i] = s
    return out


@njit(cache=True)
def matmul(a, b):
    """a @ b for (m, p) and (p, n) matrices: each element summed over k ascending."""
    m, p = a.shape
    n = b.shape[1]
    out = np.zeros((m, n))
    for i in range(m):
        for j in range(n):
            s = 0.0
            for k in range(p):
                s += a[i, k] * b[k, j]
            out[i, j] = s
    return out


@njit(cache=True)
def norm2(x):
    """|x| of an (n,) vector, the squares summed left to right."""
    s = 0.0
    for i in range(x.size):
        s += x[i] * x[i]
    return math.sqrt(s)


@njit(cache=True)
def svd_jacobi(a):
    """One-sided Jacobi SVD of a (m, n) matrix: (w (m, n), s (n,), v (n, n)) with a v = w,
    the columns of w orthogonal with norms s (descending), v orthogonal (columns). Columns of w
    whose s is zero span nothing; their columns of v span a's null space."""
    m, n = a.shape
    w = a.copy()
    v = np.zeros((n, n))
    for i in range(n):
        v[i, i] = 1.0
    for _ in range(MAX_SWEEPS):
        rotated = False
        for p in range(n - 1):
            for q in range(p + 1, n):
                alpha = 0.0
                beta = 0.0
                gamma = 0.0
                for i in range(m):
                    alpha += w[i, p] * w[i, p]
                    beta += w[i, q] * w[i, q]
                    gamma += w[i, p] * w[i, q]
                if gamma == 0.0 or abs(gamma) <= 1e-15 * math.sqrt(alpha * beta):
                    continue
                rotated = True
                zeta = (beta - alpha) / (2.0 * gamma)
                t = 1.0 / (abs(zeta) + math.sqrt(1.0 + zeta * zeta))
                if zeta < 0.0:
                    t = -t
                c = 1.0 / math.sqrt(1.0 + t * t)
                s = c * t
                for i in range(m):
                    wp = w[i, p]
                    wq = w[i, q]
                    w[i, p] = c * wp - s * wq
                    w[i, q] = s * wp + c * wq
                for i in range(n):
                    vp = v[i, p]
                    vq = v[i, q]
                    v[i, p] = c * vp - s * vq
                    v[i, q] = s * vp + c * vq
        if not rotated:
            break
    sv = np.zeros(n)
    for j in range(n):
        sv[j] = norm2(np.ascontiguousarray(w[:, j]))
    order = np.argsort(-sv, kind="mergesort")  # descending, ties in column order
    return w[:, order].copy(), sv[order].copy(), v[:, order].copy()


@njit(cache=True)
def lstsq(a, b, rcond):
    """The minimum-norm least-squares solution x (n,) of a x = b (a (m, n), b (m,)), singular
    values at most ``rcond`` × the largest treated as zero (``numpy.linalg.lstsq``'s rule)."""
    m, n = a.shape
    if m == 0 or n == 0:
        return np.zeros(n)
    w, sv, v = svd_jacobi(a)
    if sv[0] == 0.0:
        return np.zeros(n)
    cut = rcond * sv[0]
    y = np.zeros(n)
    for k in range(n):
        if sv[k] > cut:
            s = 0.0
            for i in range(m):
                s += w[i, k] * b[i]
            y[k] = s / (sv[k] * sv[k])  # (w_k · b) / s_k²: w_k = s_k u_k
    return matvec(v, y)


@njit(cache=True)
def null_space(a, rtol):
    """An orthonormal basis (n, r) of the null space of a (m, n): the right singular vectors
    whose singular value is at most ``rtol`` × the largest (all of them when a is zero)."""
    m, n = a.shape
    if n == 0:
        return np.zeros((0, 0))
    _, sv, v = svd_jacobi(a)
    rank = 0
    for k in range(n):
        if m > 0 and sv[k] > rtol * sv[0]:
            rank += 1
    return v[:, rank:].copy()
