"""The cone solver's Newton stage on the contact modes (``cone._mode_newton``, issue 23).

The problems in ``data/cone_hard_impacts.npz`` are impacts of SP2's scanned rock on its pedestal
(three contacts, a Delassus matrix of rank 6 of 9), recorded from the reference's runs of shake-table
tests 608, 642, 596 and 563 with the Gauss–Seidel solver alone (the name ends in its sweep count:
20000 = the cap, not converged), plus six that converged in under 100 sweeps. Every answer is checked
against the conditions themselves (eqs. 3.6–3.7, :func:`cone.friction_residuals`) and, where Gauss–
Seidel alone converged, against its accelerations — an independent solution of the same problem.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pbr_xval.reference import cone

DATA = np.load(Path(__file__).parent / "data" / "cone_hard_impacts.npz")
NAMES = sorted({k.rsplit("_", 1)[0] for k in DATA.files})
HARD = [n for n in NAMES if not n.startswith("easy")]
EASY = [n for n in NAMES if n.startswith("easy")]


def _problem(name: str) -> tuple[np.ndarray, np.ndarray, float, np.ndarray]:
    return DATA[f"{name}_A"], DATA[f"{name}_b"], float(DATA[f"{name}_mu"][0]), DATA[f"{name}_warm"]


def _solve(name: str, **kw):
    A, b, mu, warm = _problem(name)
    # the arguments of the impact solve in ``RigidBodySolver.resolve_impacts``
    return cone.solve_friction_cone(A, b, mu, tol=1e-13, max_iter=20000, warm_start=warm, **kw)


def _merit(res, b: np.ndarray) -> float:
    fs = max(float(np.max(np.abs(res.f))), 1e-300)
    return cone._friction_merit(res.f, res.a, res.mu, fs, float(np.max(np.abs(b))))


def test_the_recorded_problems_are_the_hard_ones() -> None:
    assert len(HARD) == 9 and len(EASY) == 6
    for name in HARD:
        A = _problem(name)[0]
        eig = np.linalg.eigvalsh(0.5 * (A + A.T))
        assert A.shape == (9, 9) and np.sum(eig < 1e-12 * eig.max()) == 3  # rank 6 of 9


@pytest.mark.parametrize("name", HARD)
def test_newton_solves_what_gauss_seidel_alone_does_not_or_slowly(name: str) -> None:
    gs = _solve(name, newton_every=None)
    nw = _solve(name)
    assert gs.iterations == int(name.rsplit("_", 1)[1])  # as recorded
    assert nw.converged and nw.method.endswith("+newton")
    assert nw.iterations == 99 < 500 < gs.iterations  # first tried before sweep 100
    r = nw.residuals
    f_scale = float(np.max(np.abs(nw.f)))
    a_scale = float(np.max(np.abs(_problem(name)[1])))
    assert r["signorini_f"] == 0.0 and r["cone"] <= 1e-13 * f_scale
    assert r["signorini_a"] <= 1e-12 * a_scale
    assert r["complementarity"] <= 1e-12 * f_scale * a_scale
    assert r["friction_complementarity"] <= 1e-12 * f_scale * a_scale
    assert r["dissipation"] <= 1e-12 * f_scale * a_scale
    if gs.converged:
        # the same motion as Gauss–Seidel's own converged answer (the forces may differ along
        # the null space of A; the accelerations may not)
        np.testing.assert_allclose(nw.a, gs.a, rtol=0, atol=1e-12 * a_scale)
    else:
        # Gauss–Seidel stopped at its cap with conditions violated by far more
        assert _merit(gs, _problem(name)[1]) > 1e-7 > 1e-12 >= _merit(nw, _problem(name)[1])


@pytest.mark.parametrize("name", EASY)
def test_a_problem_converging_before_the_first_newton_solve_is_unchanged(name: str) -> None:
    gs = _solve(name, newton_every=None)
    nw = _solve(name)
    assert gs.converged and gs.iterations < 100
    assert nw.method == gs.method and nw.iterations == gs.iterations
    assert np.array_equal(nw.f, gs.f)  # bit for bit


def test_newton_candidates_are_verified_not_trusted(monkeypatch) -> None:
    # a Newton stage that returns nonsense must not be accepted: Gauss–Seidel goes on
    name = "sp2_608_3621"
    monkeypatch.setattr(cone, "_mode_newton", lambda A, b, f, mu: f + 1.0)
    res = _solve(name)
    assert "newton" not in res.method and res.iterations == 3621


def test_newton_every_must_be_a_multiple_of_the_polish_period() -> None:
    A, b, mu, _ = _problem(HARD[0])
    for bad in (0, 30, -25):
        with pytest.raises(ValueError, match="newton_every"):
            cone.solve_friction_cone(A, b, mu, newton_every=bad)


@pytest.mark.parametrize("mu", [0.0, 0.3])
def test_newton_from_a_rough_iterate_of_the_right_modes(mu: float) -> None:
    """``_mode_newton`` on its own: from Gauss–Seidel's answer with every loaded force moved by 5 %
    (the modes kept), it returns forces that meet eqs. 3.6–3.7 and give Gauss–Seidel's accelerations;
    μ = 0: a loaded frictionless contact is a sliding one with f_t = 0 whose angle θ follows a_t
    (no force depends on it), so the same equations hold."""
    A, b, _, _ = _problem("sp2_608_20000")
    gs = cone.solve_friction_cone(A, b, mu, tol=1e-13, max_iter=20000, newton_every=None)
    assert gs.converged
    k = gs.f.size // 3
    rough = (gs.f.reshape(k, 3) * (1.0 + 0.05 * np.cos(np.arange(k)))[:, None]).reshape(-1)  # per contact
    cand = cone._mode_newton(A, b, rough, gs.mu)
    assert cand is not None
    a = A @ cand + b
    fs = max(float(np.max(np.abs(cand))), 1e-300)
    assert cone._friction_merit(cand, a, gs.mu, fs, float(np.max(np.abs(b)))) <= cone.NEWTON_MERIT_TOL
    np.testing.assert_allclose(a, gs.a, rtol=0, atol=1e-12 * float(np.max(np.abs(b))))
    if mu == 0.0:
        assert np.all(cand[1::3] == 0.0) and np.all(cand[2::3] == 0.0)
