"""The minimum-norm clamped solve of the compiled resting solver (``kernel._clamped_solve``).

Reference: the Moore–Penrose pseudo-inverse (NumPy's SVD ``pinv``) of the clamped block — the
minimum-norm least-squares solution the solve is documented to return — on the contact
problems of random rocks (``kernel.contact_problem``): sticking contacts (a symmetric block,
A = G M⁻¹ Gᵀ, of rank ≤ 6) and sliding ones (dynamic friction folded into the normal's column:
the column and row spaces differ).
"""

from __future__ import annotations

import numpy as np
import pytest

from pbr_xval.reference import kernel


def _problem(seed: int, k: int, sliding: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A random rock's contact problem of ``k`` contacts, the first ``sliding`` of them sliding;
    returns (A, b, status): status 1 (stick) or 2 (slide)."""
    rng = np.random.default_rng(seed)
    q, _ = np.linalg.qr(rng.standard_normal((3, 3)))
    R = q * np.sign(np.linalg.det(q))
    inertia_inv = np.diag(1.0 / rng.uniform(50.0, 400.0, 3))
    nodes = np.column_stack([rng.uniform(-0.4, 0.4, (k, 2)), rng.uniform(-0.8, -0.5, k)])
    slide = np.arange(k) < sliding
    sdir = np.zeros((k, 3))
    ang = rng.uniform(0.0, 2.0 * np.pi, k)
    sdir[:, 0], sdir[:, 1] = np.cos(ang), np.sin(ang)
    lm = 1e-3 * rng.standard_normal(3)
    a_rel = np.array([rng.normal(0.0, 2.0), rng.normal(0.0, 2.0), -9.81])
    A, b, _, _ = kernel.contact_problem(
        R, lm, inertia_inv, 1000.0, nodes, slide, sdir, np.zeros(3 * k), a_rel, 0.5
    )
    status = np.where(slide, 2, 1).astype(np.int64)
    return A, b, status


def _rows(status: np.ndarray) -> np.ndarray:
    rows = []
    for i, s in enumerate(status):
        if s > 0:
            rows.append(3 * i)
        if s == 1:
            rows += [3 * i + 1, 3 * i + 2]
    return np.array(rows, dtype=np.int64)


def _pinv_forces(A: np.ndarray, b: np.ndarray, status: np.ndarray, scale: np.ndarray) -> np.ndarray:
    rows = _rows(status)
    S = np.diag(scale[rows])
    sub = S @ A[np.ix_(rows, rows)] @ S
    f = np.zeros(b.size)
    f[rows] = S @ (np.linalg.pinv(sub, rcond=1e-10) @ (-(S @ b[rows])))
    return f


@pytest.mark.parametrize("seed", range(12))
@pytest.mark.parametrize(("k", "sliding"), [(1, 0), (2, 0), (3, 0), (4, 0), (3, 1), (4, 2), (2, 2)])
def test_clamped_solve_is_the_minimum_norm_least_squares_solution(seed: int, k: int, sliding: int) -> None:
    """Rank-deficient blocks (three or more sticking contacts: 3k rows of rank 6), weighted
    (a friction scale as the active-set rounds set it) or not: the pseudo-inverse solution to
    1e-9 of the force scale."""
    A, b, status = _problem(seed, k, sliding)
    for scale in (np.ones(3 * k), np.random.default_rng(seed).uniform(0.3, 2.0, 3 * k)):
        f, ok = kernel._clamped_solve(A, b, status, scale)
        assert ok
        ref = _pinv_forces(A, b, status, scale)
        np.testing.assert_allclose(f, ref, rtol=0.0, atol=1e-9 * np.abs(ref).max())
