"""The compiled step's workspace paths (issue 23, seventh pass) against the allocating ones.

``kernel._active_set_solve_into`` answers the common case (a guess without impending slip whose
first solve verifies) in the caller's scratch and hands every other case to
``kernel.active_set_solve``; ``kernel._step`` takes its small arrays from a workspace. Each
must give the allocating path's numbers bit for bit — also with the scratch filled with NaN
beforehand (no entry read before it is written) — on random contact problems of 1–4 contacts,
sticking, sliding, impending slip and free guesses (verifying or not), and on the steps of a
rocking block. ``kernel._kinematics_into`` writes the candidates' lever arms, gaps and
velocities only (checked against NumPy).
"""

from __future__ import annotations

import numba
import numpy as np
import pytest

from pbr_xval import conformance as conf
from pbr_xval.reference import adapter, kernel
from pbr_xval.runner import run_scene
from pbr_xval.scene import compile_scene


def _problem(seed: int, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, float, np.ndarray]:
    """A random rock's contact problem of ``k`` contacts with a random status guess (0 free,
    1 stick, 2 slide on the sliding ones, 3 impending slip with a random direction): (A, b,
    status, tdir, cons_tol, slide (k,) bool)."""
    rng = np.random.default_rng(seed)
    q, _ = np.linalg.qr(rng.standard_normal((3, 3)))
    R = q * np.sign(np.linalg.det(q))
    inertia_inv = np.diag(1.0 / rng.uniform(50.0, 400.0, 3))
    nodes = np.column_stack([rng.uniform(-0.4, 0.4, (k, 2)), rng.uniform(-0.8, -0.5, k)])
    slide = rng.random(k) < 0.3
    sdir = np.zeros((k, 3))
    ang = rng.uniform(0.0, 2.0 * np.pi, k)
    sdir[:, 0], sdir[:, 1] = np.cos(ang), np.sin(ang)
    lm = 1e-2 * rng.standard_normal(3)
    a_rel = np.array([rng.normal(0.0, 3.0), rng.normal(0.0, 3.0), -9.81])
    A, b, _, cons = kernel.contact_problem(
        R, lm, inertia_inv, 1000.0, nodes, slide, sdir, np.zeros(3 * k), a_rel, 0.5
    )
    status = np.where(slide, rng.choice([0, 2], k), rng.choice([0, 1, 1, 1, 3], k)).astype(np.int64)
    tdir = np.zeros((k, 2))
    ang = rng.uniform(0.0, 2.0 * np.pi, k)
    tdir[:, 0], tdir[:, 1] = np.cos(ang), np.sin(ang)
    return A, b, status, tdir, 2.0 * cons, slide


def _same(x: np.ndarray, y: np.ndarray) -> bool:
    """Bit for bit (NaN included)."""
    return x.shape == y.shape and x.tobytes() == y.tobytes()


@pytest.mark.parametrize("k", [1, 2, 3, 4])
def test_active_set_solve_into_equals_active_set_solve(k: int) -> None:
    """300 problems per k, each from a random guess and from the answer's status (the guess
    the engine's memory makes next): the same (ok, f, a, status) bit for bit; the fast path
    answers a share of them and the fallback the others (both paths exercised)."""
    fast = 0
    for seed in range(300):
        A, b, status, tdir, cons, slide = _problem(1000 * k + seed, k)
        mu = np.full(k, 0.6)
        for _ in range(2):
            ok0, f0, a0, st0 = kernel.active_set_solve(
                A, b, status.copy(), mu, cons, k + 2, tdir.copy(), slide
            )
            ws = np.full(kernel._active_set_work(3 * k), np.nan)
            iws = np.full(6 * k, -7, dtype=np.int64)
            ok1, f1, a1, st1 = kernel._active_set_solve_into(
                A, b, status.copy(), mu, cons, k + 2, tdir.copy(), slide, ws, iws
            )
            assert ok0 == ok1
            assert _same(f0, f1) and _same(a0, a1) and np.array_equal(st0, st1)
            # the fast path: the answer is a view of the scratch
            fast += int(np.shares_memory(f1, ws))
            status = st0.copy()
    assert 60 <= fast <= 540


@pytest.mark.parametrize("k", [1, 2, 4])
def test_layout_a_copy_is_typed_a_and_solves_the_same(k: int) -> None:
    """``kernel.layout_a`` (the Python path's A and tdir, so that its calls use the compiled
    callers' compilation of the solve): numba types the copy with layout 'A' (a C-contiguous
    copy would compile the solve's call tree again), same shape and bytes, and the solve
    answers the same (ok, f, a, status) bit for bit from either layout."""
    for seed in range(40):
        A, b, status, tdir, cons, slide = _problem(7000 * k + seed, k)
        mu = np.full(k, 0.6)
        A_, tdir_ = kernel.layout_a(A), kernel.layout_a(tdir)
        for x, y in ((A, A_), (tdir, tdir_)):
            assert numba.typeof(y).layout == "A" and not y.flags.c_contiguous
            assert _same(x, y)
        ok0, f0, a0, st0 = kernel.active_set_solve(A, b, status.copy(), mu, cons, k + 2, tdir, slide)
        ok1, f1, a1, st1 = kernel.active_set_solve(A_, b, status.copy(), mu, cons, k + 2, tdir_, slide)
        assert ok0 == ok1
        assert _same(f0, f1) and _same(a0, a1) and np.array_equal(st0, st1)


def test_kinematics_into_against_numpy_on_the_candidates_only() -> None:
    """Lever arms r = R p, gaps, and the velocities v + ω × r − v_p in the (n, x, y) basis
    against NumPy (to 1e-14 of their scale), on a plane and a box pedestal (gap +inf off
    the box); the other nodes' entries are left as they were."""
    rng = np.random.default_rng(5)
    n = 40
    nodes = rng.uniform(-0.5, 0.5, (n, 3))
    q, _ = np.linalg.qr(rng.standard_normal((3, 3)))
    R = q * np.sign(np.linalg.det(q))
    x, v, lm = rng.standard_normal(3), rng.standard_normal(3), rng.standard_normal(3)
    inertia_inv = np.diag(1.0 / rng.uniform(1.0, 4.0, 3))
    d, vp = 0.01 * rng.standard_normal(3), 0.1 * rng.standard_normal(3)
    cand = np.sort(rng.choice(n, 13, replace=False)).astype(np.int64)
    w_ref = R @ inertia_inv @ R.T @ lm
    r_ref = nodes @ R.T
    p_ref = x + r_ref - d
    vel_ref = (v + np.cross(w_ref, r_ref) - vp)[:, [2, 0, 1]]
    for ped_kind, half in ((0, 0.0), (1, 0.6)):
        r = np.full((n, 3), np.nan)
        gaps = np.full(n, np.nan)
        vel = np.full((n, 3), np.nan)
        w = kernel._kinematics_into(
            x, v, R, lm, inertia_inv, nodes, cand, d, vp, ped_kind, half, half, r, gaps, vel
        )
        np.testing.assert_allclose(np.array(w), w_ref, rtol=0.0, atol=1e-14 * np.abs(w_ref).max())
        np.testing.assert_allclose(r[cand], r_ref[cand], rtol=0.0, atol=1e-14)
        np.testing.assert_allclose(vel[cand], vel_ref[cand], rtol=0.0, atol=1e-13)
        off = (
            (np.abs(p_ref[:, 0]) > half) | (np.abs(p_ref[:, 1]) > half)
            if ped_kind == 1
            else np.zeros(n, bool)
        )
        g_ref = np.where(off, np.inf, p_ref[:, 2])
        np.testing.assert_allclose(gaps[cand], g_ref[cand], rtol=0.0, atol=1e-14)
        assert ped_kind == 0 or (np.isinf(gaps[cand]).any() and np.isfinite(gaps[cand]).any())
        rest = np.setdiff1d(np.arange(n), cand)
        assert np.isnan(gaps[rest]).all() and np.isnan(r[rest]).all() and np.isnan(vel[rest]).all()


def test_step_with_a_dirty_workspace_equals_step(monkeypatch: pytest.MonkeyPatch) -> None:
    """Every kernel step of a rocking Housner run made step by step (``adapter.BLOCK_STEPS =
    0``; its arguments recorded around ``kernel.step``) repeated by ``kernel._step`` with a
    NaN-filled workspace: the same exit code, end state, gaps, info and solver memory bit for
    bit."""
    calls: list[tuple[tuple[object, ...], int, tuple[object, ...]]] = []
    orig = kernel.step

    def spy(*args: object) -> int:
        before = tuple(a.copy() if isinstance(a, np.ndarray) else a for a in args)
        code = int(orig(*args))
        calls.append((before, code, tuple(a.copy() if isinstance(a, np.ndarray) else a for a in args)))
        return code

    scene = compile_scene(
        conf.housner_scenario(
            duration=1.2,
            excitation={"type": "half_sine", "amplitude": 5.0, "frequency": 1.0, "phase": "housner_uplift"},
        )
    )
    monkeypatch.setattr(adapter, "BLOCK_STEPS", 0)
    monkeypatch.setattr(kernel, "step", spy)
    traj = run_scene(scene, "reference")
    assert traj.ok and traj.diagnostics["impacts"] > 0
    assert len(calls) > 500
    codes = {code for _, code, _ in calls}
    assert kernel.STEP_OK in codes and kernel.STEP_IMPACT in codes
    for before, code, after in calls:
        args = [a.copy() if isinstance(a, np.ndarray) else a for a in before]
        nodes = args[4]
        assert isinstance(nodes, np.ndarray)
        swf, swi = kernel._step_work(nodes.shape[0], 4)
        swf[:] = np.nan
        swi[:] = -7
        assert kernel._step(*args, swf, swi) == code
        for a, b in zip(args, after, strict=True):
            if isinstance(a, np.ndarray):
                assert isinstance(b, np.ndarray) and _same(a, b)
