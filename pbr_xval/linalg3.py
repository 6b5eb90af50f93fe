"""3 × 3 linear algebra whose result is the same bit for bit on every x86-64 CPU.

Why our own code and not ``numpy.linalg``: ``eigh`` and ``det`` go through LAPACK, and ``@`` on
float arrays through BLAS; OpenBLAS picks its kernels by CPU at run time (SkylakeX on an AVX-512
machine, Haswell or Zen on an AVX2 one, Sandybridge on an AVX-only one), and the kernels round
differently in the last bit. The engine adapters hand every engine the rock's principal axes and
its vertices in that frame, so under two kernel families the same scenario started MuJoCo from
inputs a last bit apart, and a rocking rock near its toppling level is chaotic: MuJoCo's SP1
trajectories differed between ``OPENBLAS_CORETYPE=Haswell`` and ``SkylakeX`` on every test tried,
and outcomes flipped (docs/validation.md, "Machine dependence"). Here the same quantities come from
IEEE-754 additions, multiplications, divisions and square roots only, in a fixed order, in Python
floats (no fused multiply-add, no SIMD width, no run-time dispatch): cyclic Jacobi rotations for
the symmetric eigenproblem (Golub & Van Loan, *Matrix Computations*, §8.5), cofactors for the
determinant, explicit sums for the products. For a 3 × 3 matrix that costs microseconds.

``tests/test_linalg3.py`` checks the decomposition against ``numpy.linalg.eigh`` and runs
the engines' inputs under several OpenBLAS core types and NumPy SIMD targets in subprocesses,
requiring identical bytes.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["det3", "eigh3", "inv3", "mat3_mul", "mat3_vec", "norm3", "principal_axes", "rows_dot", "rows_mul"]

#: cyclic Jacobi sweeps at most (a symmetric 3 × 3 converges quadratically, in 3–6 sweeps)
_MAX_SWEEPS = 64


def _rows(a: ArrayLike) -> list[list[float]]:
    m = np.asarray(a, dtype=np.float64)
    if m.shape != (3, 3):
        raise ValueError(f"expected a 3 × 3 matrix, got shape {m.shape}")
    return [[float(x) for x in row] for row in m.tolist()]


def eigh3(a: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Eigenvalues (3,) ascending and eigenvectors (3, 3) (columns) of a symmetric 3 × 3 matrix.

    ``a`` is symmetrised as ½ (a + aᵀ). Cyclic Jacobi rotations until the off-diagonal part is
    exactly zero or stops decreasing (at round-off); each rotation uses the smaller root of
    t² + 2θt − 1 = 0 (θ = (a_qq − a_pp) / 2a_pq), the stable choice. Ties in the eigenvalues keep
    the order of the diagonal they came from. The columns are orthonormal to round-off; their
    signs are those the rotations give (a right-handed frame: :func:`principal_axes`).
    """
    m = _rows(a)
    for i in range(3):
        for j in range(i + 1, 3):
            s = 0.5 * (m[i][j] + m[j][i])
            m[i][j] = s
            m[j][i] = s
    v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
    prev = math.inf
    for _ in range(_MAX_SWEEPS):
        off = m[0][1] * m[0][1] + m[0][2] * m[0][2] + m[1][2] * m[1][2]
        if off == 0.0 or not off < prev:
            break
        prev = off
        for p, q in ((0, 1), (0, 2), (1, 2)):
            apq = m[p][q]
            if apq == 0.0:
                continue
            theta = (m[q][q] - m[p][p]) / (2.0 * apq)
            if abs(theta) > 1e150:  # θ² would overflow: t ≈ 1 / 2θ
                t = 0.5 / theta
            else:
                t = 1.0 / (abs(theta) + math.sqrt(theta * theta + 1.0))
                if theta < 0.0:
                    t = -t
            c = 1.0 / math.sqrt(t * t + 1.0)
            s = t * c
            for k in range(3):  # columns p, q of m J
                mkp, mkq = m[k][p], m[k][q]
                m[k][p] = c * mkp - s * mkq
                m[k][q] = s * mkp + c * mkq
            for k in range(3):  # rows p, q of Jᵀ (m J)
                mpk, mqk = m[p][k], m[q][k]
                m[p][k] = c * mpk - s * mqk
                m[q][k] = s * mpk + c * mqk
            m[p][q] = 0.0
            m[q][p] = 0.0
            for k in range(3):  # v J
                vkp, vkq = v[k][p], v[k][q]
                v[k][p] = c * vkp - s * vkq
                v[k][q] = s * vkp + c * vkq
    w = [m[0][0], m[1][1], m[2][2]]
    order = sorted(range(3), key=lambda i: (w[i], i))
    return (
        np.array([w[i] for i in order], dtype=np.float64),
        np.array([[v[r][i] for i in order] for r in range(3)], dtype=np.float64),
    )


def norm3(v: ArrayLike) -> float:
    """|v| of a (3,) vector, summed left to right (``numpy.linalg.norm`` of a vector is a BLAS dot
    product, whose rounding depends on the CPU)."""
    x, y, z = (float(c) for c in np.asarray(v, dtype=np.float64).reshape(3).tolist())
    return math.sqrt(x * x + y * y + z * z)


def det3(a: ArrayLike) -> float:
    """Determinant of a 3 × 3 matrix by cofactors along the first row (fixed order)."""
    m = _rows(a)
    return (
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    )


def inv3(a: ArrayLike) -> NDArray[np.float64]:
    """Inverse of a 3 × 3 matrix by cofactors (the adjugate over :func:`det3`, fixed order);
    ``ValueError`` when the determinant is zero or not finite. ``numpy.linalg.inv`` is LAPACK's
    LU, whose rounding depends on the CPU's kernels (an inertia tensor's inverse feeds every
    step of the reference solver)."""
    m = _rows(a)
    d = det3(a)
    if not (d != 0.0 and math.isfinite(d)):
        raise ValueError(f"matrix is singular (determinant {d})")
    cof = [
        [
            m[(j + 1) % 3][(i + 1) % 3] * m[(j + 2) % 3][(i + 2) % 3]
            - m[(j + 1) % 3][(i + 2) % 3] * m[(j + 2) % 3][(i + 1) % 3]
            for j in range(3)
        ]
        for i in range(3)
    ]
    return np.array([[cof[i][j] / d for j in range(3)] for i in range(3)], dtype=np.float64)


def principal_axes(inertia: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Principal moments (3,) kg·m², ascending, and the right-handed rotation (3, 3) whose
    columns are the principal axes in the tensor's frame (:func:`eigh3`; the third column
    flipped when the determinant is negative)."""
    w, v = eigh3(inertia)
    if det3(v) < 0.0:
        v[:, 2] = -v[:, 2]
    return w, v


def mat3_mul(a: ArrayLike, b: ArrayLike) -> NDArray[np.float64]:
    """a @ b for 3 × 3 matrices: each element a sum of three products, left to right."""
    x, y = _rows(a), _rows(b)
    return np.array(
        [[x[i][0] * y[0][j] + x[i][1] * y[1][j] + x[i][2] * y[2][j] for j in range(3)] for i in range(3)],
        dtype=np.float64,
    )


def mat3_vec(a: ArrayLike, x: ArrayLike) -> NDArray[np.float64]:
    """a @ x for a 3 × 3 matrix and a (3,) vector, each component summed left to right."""
    m = _rows(a)
    v = [float(c) for c in np.asarray(x, dtype=np.float64).reshape(3).tolist()]
    return np.array([m[i][0] * v[0] + m[i][1] * v[1] + m[i][2] * v[2] for i in range(3)], dtype=np.float64)


def _points(p: ArrayLike) -> NDArray[np.float64]:
    pts = np.asarray(p, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise ValueError(f"expected points of shape (n, 3), got {pts.shape}")
    return pts


def rows_dot(p: ArrayLike, v: ArrayLike) -> NDArray[np.float64]:
    """p @ v for points p (n, 3) and a (3,) vector, without BLAS: p[:, 0] v[0] + p[:, 1] v[1] +
    p[:, 2] v[2], element-wise IEEE operations (NumPy's multiply and add are exactly rounded per
    element whatever the SIMD width)."""
    pts = _points(p)
    x, y, z = (float(c) for c in np.asarray(v, dtype=np.float64).reshape(3).tolist())
    return pts[:, 0] * x + pts[:, 1] * y + pts[:, 2] * z


def rows_mul(p: ArrayLike, a: ArrayLike) -> NDArray[np.float64]:
    """p @ a for points p (n, 3) and a 3 × 3 matrix, without BLAS: column j is
    :func:`rows_dot` of p with a[:, j]."""
    pts = _points(p)
    m = np.asarray(a, dtype=np.float64)
    if m.shape != (3, 3):
        raise ValueError(f"expected a 3 × 3 matrix, got shape {m.shape}")
    out = np.empty_like(pts)
    for j in range(3):
        out[:, j] = rows_dot(pts, m[:, j])
    return out
