"""The resting solve's second try (``kernel.active_set_retry``; issue 23, ninth pass).

In the SP1 campaign most NumPy (general) steps were three-contact sticking / impending-slip
problems whose compiled active-set solve failed, for two reasons:

* a stale impending slip: contacts guessed at the cone's boundary (status 3, from the last
  solve) whose tangential acceleration is now zero are never released, and the rounds cycle
  between "stick" and "impending slip" on another contact;
* a velocity stabilisation no contact force can reach: ``stab``'s normal rows are
  min(v_n, 0)/dt and its components below 1e-8 m/s are zeroed, so on three sticking contacts
  (9 rows, rank 6) part of it is left in the least-squares residual of the clamped rows, above
  the solve's tolerance (which bounds only the centripetal term). The general solver's cone
  iteration then does not converge either, and its 16-facet pyramid (Lemke) answers.

``data/general_resting_problems.npz``: the 73 such problems of SP1 tests 160, 593, 595 and
632 (``benchmarks/reference_campaign.py``'s scene; recorded at commit 496ed66) that the retry
answers, of 80 failed solves in all: keys ``n`` and ``{i}_A`` (3k, 3k), ``{i}_b`` (3k,),
``{i}_status`` (k,) the engine's guess, ``{i}_slide`` (k,), ``{i}_tdir`` (k, 2), ``{i}_stab``
(3k,) m/s², ``{i}_cons`` (cons_tol, m/s²), ``{i}_mu`` (static friction), ``{i}_f`` (3k,) N the
general solver's answer, ``{i}_fallback`` (whether that answer is the pyramid's),
``{i}_test``.

References: the general solver's recorded answers — the cone solver (``cone.solve_friction_cone``,
a projected iteration on the exact cone) or, when it did not converge, Lemke's method on a
16-facet friction pyramid (``cone.solve_friction_pyramid``) — independent algorithms. Sticking
friction on three contacts is statically indeterminate (the forces' split is not unique), so the
answers are compared through the contact accelerations a = A f + b, which the body's
acceleration fixes: on the normal rows to 1e-8 of |b| (measured: 3e-10; 6e-9 on 474 problems
of eleven other SP1/SP2 tests), on all rows to 1e-10 where the cone solver converged (measured:
4e-13) and to 1e-5 where the pyramid answered (measured: 5e-7; 1.4e-6 on the other tests).
The conditions of eqs. 3.6–3.7 (f_n ≥ 0, the static cone, a_n ≥ 0 on free contacts, a_n = 0 on
loaded ones) are checked here on the answer itself.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pbr_xval.reference import kernel

DATA = Path(__file__).parent / "data" / "general_resting_problems.npz"
N_RECORDED = 73


def _recorded(i: int) -> dict[str, np.ndarray]:
    with np.load(DATA) as z:
        assert int(z["n"]) == N_RECORDED
        keys = ("A", "b", "status", "slide", "tdir", "stab", "cons", "mu", "f", "fallback", "test")
        return {key: z[f"{i}_{key}"] for key in keys}


def _args(p: dict[str, np.ndarray]) -> tuple:
    k = p["b"].size // 3
    mu = np.full(k, float(p["mu"]))
    return p["A"], p["b"], p["status"], mu, float(p["cons"]), k + 2, p["tdir"], p["slide"]


@pytest.mark.parametrize("i", range(N_RECORDED))
def test_recorded_problem_fails_the_first_try_and_the_retry_answers_it(i: int) -> None:
    """The first try (unchanged) fails from the engine's guess; the retry answers, and its
    answer meets eqs. 3.6–3.7 and has the general solver's accelerations."""
    p = _recorded(i)
    A, b = p["A"], p["b"]
    k = b.size // 3
    ok0, *_ = kernel.active_set_solve(*_args(p))
    assert not ok0
    ok, f, a, st = kernel.active_set_retry(*_args(p), p["stab"])
    assert ok
    np.testing.assert_allclose(a, A @ f + b, rtol=0.0, atol=1e-12 * np.abs(b).max())
    F = f.reshape(k, 3)
    fmax = np.abs(F[:, 0]).max()
    bmax = np.abs(b).max()
    mu = np.where(p["slide"], 0.0, float(p["mu"]))
    assert (F[:, 0] >= -1e-9 * fmax).all()
    assert (np.hypot(F[:, 1], F[:, 2]) <= mu * F[:, 0] * (1 + 1e-9) + 1e-9 * fmax).all()
    loaded = F[:, 0] > 0
    assert (a[0::3][~loaded] >= -1e-9 * bmax).all()
    np.testing.assert_array_less(np.abs(a[0::3][loaded]), 1e-8 * bmax)
    np.testing.assert_array_equal(st > 0, loaded)
    # the general solver's (independent) answer: the same accelerations
    a_gen = A @ p["f"] + b
    np.testing.assert_allclose(a[0::3], a_gen[0::3], rtol=0.0, atol=1e-8 * bmax)
    atol = 1e-5 if bool(p["fallback"]) else 1e-10
    np.testing.assert_allclose(a, a_gen, rtol=0.0, atol=atol * bmax)
    # impending slip: the tangential acceleration opposes the friction (maximum dissipation)
    for j in np.flatnonzero(st == 3):
        s_hat = F[j, 1:] / np.hypot(F[j, 1], F[j, 2])
        assert float(s_hat @ a[3 * j + 1 : 3 * j + 3]) <= 1e-9 * bmax + float(p["cons"])


def test_recorded_problems_cover_both_cases() -> None:
    """The data holds both cases: stale impending slip (the cone solver converged) and the
    unreachable stabilisation (its component outside A's range above the first try's tolerance,
    the pyramid's answer)."""
    stale = unreachable = 0
    for i in range(N_RECORDED):
        p = _recorded(i)
        A, b = p["A"], p["b"]
        u, s, _ = np.linalg.svd(A)
        un = u[:, int((s > 1e-10 * s[0]).sum()) :]
        outside = np.abs(un @ (un.T @ b)).max() if un.size else 0.0
        tol = 1e-9 * np.abs(b).max() + float(p["cons"])
        if outside > tol:
            unreachable += 1
            # what no force can reach is the stabilisation's, not the rigid terms'
            assert np.abs(un @ (un.T @ (b - p["stab"]))).max() <= tol
        elif (p["status"] == 3).any():
            stale += 1
    assert stale >= 15
    assert unreachable >= 40


def test_retry_without_a_cause_changes_nothing() -> None:
    """No impending slip in the guess and no stabilisation: the retry has nothing to try and
    fails as the first try did."""
    p = _recorded(0)
    A, b, status, mu, cons, rounds, tdir, slide = _args(p)
    status = np.where(status == 3, 1, status)
    ok0, *_ = kernel.active_set_solve(A, b, status, mu, cons, rounds, tdir, slide)
    if ok0:
        pytest.skip("the first try answers this guess")
    ok, _, _, st = kernel.active_set_retry(A, b, status, mu, cons, rounds, tdir, slide, np.zeros(b.size))
    assert not ok
    np.testing.assert_array_equal(st, status)
