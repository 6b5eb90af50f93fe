"""A free sliding contact that would penetrate is clamped as sliding (issue 23, eighth pass).

``kernel.active_set_solve`` corrects its guess when a free contact would penetrate: it clamps
it. Before the eighth pass it clamped it as *sticking* (status 1) unless the guess had it
sliding, so a sliding contact the last solve left free (its guess is status 0) came back with
three unknowns — static friction on a contact whose dynamic friction is already folded into A's
normal column — and the solve failed: on SP1's one-sine run (``benchmarks/reference.py``) 22 of
its 25 NumPy steps were such two-contact problems, answered by Dantzig's method on the normal
rows. Now ``slide`` tells the solve which contacts slide, and such a contact is clamped as
sliding (status 2).

References: Dantzig–Cottle principal pivoting (:func:`pivoting.solve_lcp`, the general solver
that answered these problems) on the normal rows of the same A and b — an independent
algorithm; for all-sliding contacts eqs. 3.6–3.7 are that LCP, whose answer is unique when its
matrix is a P-matrix (checked here through its principal minors).
``data/sliding_reclamp_problems.npz``: the 22 problems recorded on that run at commit 6023dbf
(keys ``n`` and ``{i}_A, {i}_b, {i}_slide, {i}_status, {i}_tdir, {i}_cons``: A (3k, 3k), b
(3k,), the sliding mask, the guess, the friction directions, the tolerance cons_tol, m/s²).
"""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import pytest

from pbr_xval.reference import kernel, pivoting

DATA = Path(__file__).parent / "data" / "sliding_reclamp_problems.npz"


def _recorded() -> list[dict[str, np.ndarray]]:
    with np.load(DATA) as z:
        n = int(z["n"])
        keys = ("A", "b", "slide", "status", "tdir", "cons")
        return [{key: z[f"{i}_{key}"] for key in keys} for i in range(n)]


def _is_p_matrix(M: np.ndarray) -> bool:
    n = M.shape[0]
    return all(
        np.linalg.det(M[np.ix_(s, s)]) > 0
        for r in range(1, n + 1)
        for s in itertools.combinations(range(n), r)
    )


def _check_against_dantzig(A: np.ndarray, b: np.ndarray, f: np.ndarray, st: np.ndarray) -> None:
    """Normal forces and accelerations equal Dantzig's answer of the normal-row LCP (to
    1e-12 of their scale), no tangential force, every loaded contact clamped as sliding."""
    An, bn = A[0::3, 0::3], b[0::3]
    assert _is_p_matrix(An)  # the LCP's answer is unique
    ref = pivoting.solve_lcp(An, bn, method="dantzig")
    assert ref.ok
    fscale = np.abs(ref.z).max()
    np.testing.assert_allclose(f[0::3], ref.z, rtol=0.0, atol=1e-12 * fscale)
    np.testing.assert_array_equal(f[1::3], 0.0)
    np.testing.assert_array_equal(f[2::3], 0.0)
    a = A @ f + b
    np.testing.assert_allclose(a[0::3], ref.w, rtol=0.0, atol=1e-12 * np.abs(bn).max())
    np.testing.assert_array_equal(st, np.where(ref.z > 0, 2, 0))


@pytest.mark.parametrize("i", range(22))
def test_recorded_free_sliding_contact_is_clamped_as_sliding(i: int) -> None:
    """Each recorded problem (two sliding contacts, one guessed free, both loaded in the
    answer) is answered by the compiled solve from the guess the engine made, and its answer
    is Dantzig's. Before the eighth pass every one of them failed (status 1, then 3, on the
    sliding contact)."""
    p = _recorded()[i]
    A, b, slide = p["A"], p["b"], p["slide"]
    k = b.size // 3
    assert slide.all() and (p["status"] == 0).any()
    ok, f, _, st = kernel.active_set_solve(
        A, b, p["status"], np.full(k, 0.6), float(p["cons"]), k + 2, p["tdir"], slide
    )
    assert ok
    _check_against_dantzig(A, b, f, st)


def test_sliding_box_from_every_guess() -> None:
    """A box (0.4 × 0.4 × 1.2 m, 1,000 kg) sliding along +x on two of its bottom edges'
    midpoints (μ_d = 0.2: the friction's overturning moment μ_d h = 0.12 m × W is below the
    restoring 0.2 m × W, so both stay loaded): from every guess (each contact free or sliding)
    the solve answers with both contacts loaded and sliding, Dantzig's normal forces."""
    mass = 1000.0
    inertia_inv = np.linalg.inv(np.diag([mass / 12 * (0.4**2 + 1.2**2)] * 2 + [mass / 12 * 0.32]))
    nodes = np.array([[0.2, 0.0, -0.6], [-0.2, 0.0, -0.6]])
    slide = np.ones(2, dtype=bool)
    sdir = np.array([[1.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    a_rel = np.array([3.0, 0.0, -9.81])
    A, b, _, cons = kernel.contact_problem(
        np.eye(3), np.zeros(3), inertia_inv, mass, nodes, slide, sdir, np.zeros(6), a_rel, 0.2
    )
    for guess in ((0, 0), (2, 0), (0, 2), (2, 2)):
        ok, f, _, st = kernel.active_set_solve(
            A, b, np.array(guess, dtype=np.int64), np.full(2, 0.6), 2.0 * cons, 4, np.zeros((2, 2)), slide
        )
        assert ok, guess
        assert np.all(f[0::3] > 0)
        _check_against_dantzig(A, b, f, st)
