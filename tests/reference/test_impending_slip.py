"""Impending slip (status 3) in the compiled active-set solve (``kernel.active_set_solve``).

References: a box pushed on a plane (Newton's law with Coulomb friction, worked by hand); the
iterative cone solver (``cone.solve_friction_cone``, the NumPy fallback that answered these
problems before the status existed) on resting problems recorded from shake-table runs (SP2
test 507 and SP1 test 399, every one a step that left the compiled path before; file
``data/impending_slip_problems.npz``, keys ``{i}_A, {i}_b, {i}_slide, {i}_status, {i}_f, {i}_mu``:
the Delassus matrix (3k, 3k), the free acceleration (3k,), the sliding flags (k,), the statuses
the step guessed (k,), the fallback's forces (3k,) and μ_s).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from pbr_xval.reference import cone, dynamics, kernel
from pbr_xval.runner import run_scene

sys.path.insert(0, str(Path(__file__).resolve().parent))
from test_lcp import MASS, G, _box_friction_problem, box_inverse_mass

from .test_engine import _slab

DATA = Path(__file__).resolve().parent / "data" / "impending_slip_problems.npz"


@pytest.mark.parametrize("ratio", [0.13, 0.25])
def test_box_push_from_a_sticking_guess(ratio: float) -> None:
    """μ = 0.2: a push of 0.13 m g sticks; 0.25 m g puts all four corners on the cone's boundary
    (impending slip), friction −μ m g, u̇ = (0.25 − 0.2) g along the push, no rotation."""
    mu = 0.2
    A, b, J, F_ext = _box_friction_problem(ratio * MASS * G)
    ok, f, a, st = kernel.active_set_solve(
        A, b, np.ones(4, dtype=np.int64), np.full(4, mu), 0.0, 6, np.zeros((4, 2)), np.zeros(4, bool)
    )
    assert ok
    u_dot = box_inverse_mass() @ (J.T @ f + F_ext)
    F = f.reshape(4, 3)
    if ratio < mu:
        np.testing.assert_array_equal(st, 1)
        np.testing.assert_allclose(u_dot, 0.0, atol=1e-9)
    else:
        np.testing.assert_array_equal(st, 3)
        np.testing.assert_allclose(u_dot, [(ratio - mu) * G, 0, 0, 0, 0, 0], atol=1e-9)
        assert F[:, 1].sum() == pytest.approx(-mu * MASS * G, rel=1e-12)
        np.testing.assert_allclose(np.hypot(F[:, 1], F[:, 2]), mu * F[:, 0], rtol=1e-12)
        # the tangential accelerations oppose the friction (eq. 3.7, maximum dissipation)
        at = a.reshape(4, 3)[:, 1:]
        np.testing.assert_allclose(
            at / np.linalg.norm(at, axis=1)[:, None], -F[:, 1:] / (mu * F[:, :1]), atol=1e-9
        )


def test_wrong_direction_is_corrected_or_refused() -> None:
    """A guessed friction direction off by 0.4 rad is corrected by the Newton iteration; one
    pointing along the acceleration (friction pushing) is refused by the verification."""
    mu = 0.2
    A, b, _, _ = _box_friction_problem(0.25 * MASS * G)
    th = np.pi + 0.4
    td = np.tile([np.cos(th), np.sin(th)], (4, 1))
    ok, f, _, _ = kernel.active_set_solve(
        A, b, np.full(4, 3, dtype=np.int64), np.full(4, mu), 0.0, 1, td, np.zeros(4, bool)
    )
    assert ok
    np.testing.assert_allclose(f.reshape(4, 3)[:, 2], 0.0, atol=1e-9 * MASS * G)
    td = np.tile([1.0, 0.0], (4, 1))  # friction along +x, with the push
    ok, _, _, _ = kernel.active_set_solve(
        A, b, np.full(4, 3, dtype=np.int64), np.full(4, mu), 0.0, 1, td, np.zeros(4, bool)
    )
    assert not ok


def _recorded() -> list[dict[str, np.ndarray]]:
    with np.load(DATA) as z:
        n = int(z["count"])
        return [{key: z[f"{i}_{key}"] for key in ("A", "b", "slide", "status", "f", "mu")} for i in range(n)]


@pytest.mark.parametrize("i", range(32))
def test_recorded_problems_agree_with_the_cone_solver(i: int) -> None:
    """Every recorded problem is solved by the compiled path from the guess the engine makes
    after a general solve (status 3 where the fallback's friction is within
    ``SLIP_GUESS_RTOL`` of the cone), its answer satisfies eqs. 3.6–3.7 with maximum
    dissipation, and its contact accelerations (the motion: with a rank-6 A the forces may
    differ by internal forces) and normal forces are the cone solver's: run to convergence
    (up to 20,000 sweeps) to 1e-9 |b|, or — where it does not converge (the recorded answers
    then came from its pyramid restart) — the recorded answer to 1e-6 |b|."""
    p = _recorded()[i]
    A, b, frec, slide = p["A"], p["b"], p["f"], p["slide"]
    k = b.size // 3
    mu_s = float(p["mu"])
    mu = np.full(k, mu_s)
    mu_cone = np.where(slide, 0.0, mu_s)  # the friction of sliding contacts is folded into A
    F = frec.reshape(k, 3)
    ft = np.hypot(F[:, 1], F[:, 2])
    at_cone = ft >= mu_s * F[:, 0] * (1 - dynamics.SLIP_GUESS_RTOL)
    guess = np.where(F[:, 0] > 0, np.where(slide, 2, np.where(at_cone, 3, 1)), 0).astype(np.int64)
    td = np.divide(F[:, 1:], ft[:, None], out=np.zeros((k, 2)), where=ft[:, None] > 0)
    ok, f, a, st = kernel.active_set_solve(A, b, guess, mu, 0.0, k + 2, td, slide)
    assert ok
    bmax = np.abs(b).max()
    ref = cone.solve_friction_cone(A, b, mu_cone, tol=1e-13, max_iter=20000, restart_after=None)
    fref, rtol = (ref.f, 1e-9) if ref.converged else (frec, 1e-6)
    np.testing.assert_allclose(a, A @ fref + b, rtol=0, atol=rtol * bmax)
    np.testing.assert_allclose(f[0::3], fref[0::3], rtol=0, atol=10 * rtol * np.abs(fref).max())
    r = cone.friction_residuals(f, a, mu_cone)
    fs = np.abs(f).max()
    assert r["signorini_f"] <= 1e-9 * fs and r["signorini_a"] <= 1e-9 * bmax
    assert r["cone"] <= 1e-9 * fs and r["complementarity"] <= 1e-8 * fs * bmax
    slip = np.flatnonzero(st == 3)
    if slip.size:
        at = a.reshape(k, 3)[slip, 1:]
        ftv = f.reshape(k, 3)[slip, 1:]
        nf = np.hypot(ftv[:, 0], ftv[:, 1])
        np.testing.assert_allclose(nf, mu_s * f[3 * slip], rtol=1e-12)
        # a_t opposes the friction: nothing across its direction, nothing along it
        assert (np.abs(ftv[:, 0] * at[:, 1] - ftv[:, 1] * at[:, 0]) <= 1e-9 * bmax * nf).all()
        assert (np.sum(ftv * at, axis=1) <= 1e-9 * bmax * nf).all()


@pytest.mark.parametrize(
    "args, kw",
    [
        ((6.0, 0.5, 0.4), {}),
        (
            (0.0, 0.2, 0.2),
            {
                "half_extents": (0.3, 0.3, 0.2),
                "duration": 1.0,
                "excitation": {"type": "half_sine", "amplitude": 6.0, "frequency": 1.0, "phase": 0.0},
            },
        ),
    ],
)
def test_onset_of_sliding_stays_compiled(args, kw) -> None:
    """A slab that starts to slide passes through impending slip (|v_t| below the slip velocity,
    friction on the static cone): those steps stay on the compiled path (before the status
    existed, 1 and 3 of them went to the NumPy step)."""
    traj = run_scene(_slab(*args, **kw), "reference")
    assert traj.ok, traj.message
    d = traj.diagnostics
    assert d["general_steps"] == 0
    assert d["lcp_fast_path"] == d["lcp_solves"]
