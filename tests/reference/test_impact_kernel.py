"""The compiled eq. 3.5 impact path (``kernel.impact_impulses``, ``kernel.impact_finish``).

References: the NumPy/Python path it replaces on its fast stages — the iterative cone solver
(``cone.solve_friction_cone``) for the impact cone and Dantzig's pivoting
(``pivoting.dantzig``) for the normal LCP — and the rigid-body impulse law Δu̇ = ΣJ/m,
Δl = Σ r × J written with NumPy; a sliding landing worked by hand (Coulomb impulse on the cone,
opposing the post-impact tangential velocity). The cone solver's compiled first sweeps
(``cone.cone_first_sweeps``, which the blocks run on ``IMPACT_CONE`` impacts) against the
general solver (the same forces bit for bit and the same sweep count where they converge) and
its 2 × 2 eigen-decomposition against LAPACK's (``numpy.linalg.eigh``).
"""

from __future__ import annotations

import numpy as np
import pytest

from pbr_xval.reference import cone, kernel, pivoting

MASS = 460.8
HALF = np.array([0.2, 0.2, 0.6])
INERTIA_INV = np.linalg.inv(
    MASS
    / 3.0
    * np.diag([HALF[1] ** 2 + HALF[2] ** 2, HALF[0] ** 2 + HALF[2] ** 2, HALF[0] ** 2 + HALF[1] ** 2])
)
CORNERS = np.array([[sx * HALF[0], sy * HALF[1], -HALF[2]] for sx in (1, -1) for sy in (1, -1)])


def _rot(rng: np.random.Generator, size: float) -> np.ndarray:
    w = rng.normal(size=3) * size
    th = np.linalg.norm(w)
    K = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]]) / th
    return np.eye(3) + np.sin(th) * K + (1 - np.cos(th)) * K @ K


def _problem(seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A box landing on 1–3 of its base corners: R, lever arms r (k, 3), body velocity v, l,
    and the contact velocities (3k,) in the (n, x, y) basis."""
    rng = np.random.default_rng(seed)
    R = _rot(rng, 0.05)
    k = 1 + seed % 3
    r = CORNERS[rng.permutation(4)[:k]] @ R.T
    v = rng.normal(size=3) * 0.05
    v[2] = -abs(v[2]) - 0.02
    lm = rng.normal(size=3) * 5.0
    w = R @ INERTIA_INV @ R.T @ lm
    vel = v + np.cross(w, r)  # (k, 3) world
    bvel = np.column_stack([vel[:, 2], vel[:, 0], vel[:, 1]]).reshape(-1)
    return R, r, v, lm, bvel


@pytest.mark.parametrize("seed", range(24))
@pytest.mark.parametrize("mu", [0.0, 0.2, 0.6])
def test_impact_impulses_agree_with_cone_solver_and_dantzig(seed: int, mu: float) -> None:
    R, r, _, _, bvel = _problem(seed)
    k = r.shape[0]
    stage, A, q, j = kernel.impact_impulses(R, INERTIA_INV, MASS, r, bvel, 0.0, mu, np.zeros(r.shape[0]))
    # A = G M⁻¹ Gᵀ written with NumPy
    G = np.zeros((3 * k, 6))
    for i in range(k):
        for c, d in enumerate((np.array([0, 0, 1.0]), np.array([1.0, 0, 0]), np.array([0, 1.0, 0]))):
            G[3 * i + c, :3] = d
            G[3 * i + c, 3:] = np.cross(r[i], d)
    Minv = np.zeros((6, 6))
    Minv[:3, :3] = np.eye(3) / MASS
    Minv[3:, 3:] = R @ INERTIA_INV @ R.T
    np.testing.assert_allclose(A, G @ Minv @ G.T, rtol=1e-12, atol=1e-15)
    np.testing.assert_array_equal(q, bvel)  # e = 0
    if stage not in (kernel.IMPACT_DONE, kernel.IMPACT_REVERTED):
        pytest.skip(f"stage {stage}: the Python path answers (not compiled)")
    ref = np.zeros(3 * k)
    if mu > 0:
        res = cone.solve_friction_cone(A, q, mu, tol=1e-14, max_iter=20000)
        assert res.converged
        ref = res.f.copy()
        np.testing.assert_allclose(j[1::3], ref[1::3], rtol=0, atol=1e-8 * np.abs(ref).max())
        np.testing.assert_allclose(j[2::3], ref[2::3], rtol=0, atol=1e-8 * np.abs(ref).max())
    if stage == kernel.IMPACT_DONE:
        qn = q[0::3] + sum(
            A[0::3, 3 * c + 1] * j[3 * c + 1] + A[0::3, 3 * c + 2] * j[3 * c + 2] for c in range(k)
        )
        dz = pivoting.dantzig(A[0::3, 0::3], qn)
        assert dz.ok
        np.testing.assert_allclose(j[0::3], dz.z, rtol=1e-9, atol=1e-12 * max(1.0, np.abs(dz.z).max()))
    w = A @ j + q
    r6 = cone.friction_residuals(j, w, np.full(k, mu))
    assert r6["signorini_f"] <= 1e-10 and r6["signorini_a"] <= 1e-10
    assert r6["cone"] <= 1e-10 * max(1.0, np.abs(j).max())


def test_sliding_landing_takes_the_compiled_path() -> None:
    """One corner lands with v_t = 1 m/s, v_n = −0.1 m/s, μ = 0.2: sticking would need a
    tangential impulse far outside the cone, so the impulse is on the cone's boundary (the
    active set's impending slip) and opposes the post-impact tangential velocity."""
    R = np.eye(3)
    r = CORNERS[:1].copy()
    bvel = np.array([-0.1, 1.0, 0.0])
    stage, A, q, j = kernel.impact_impulses(R, INERTIA_INV, MASS, r, bvel, 0.0, 0.2, np.zeros(1))
    assert stage == kernel.IMPACT_DONE
    assert np.hypot(j[1], j[2]) == pytest.approx(0.2 * j[0], rel=1e-12)
    vpost = A @ j + bvel
    assert vpost[0] == pytest.approx(0.0, abs=1e-12)  # e = 0: the corner stops in the normal
    assert vpost[1] > 0.0 and j[1] < 0.0  # still sliding, friction against it
    # the tangential impulse is anti-parallel to the post-impact tangential velocity
    vt, jt = vpost[1:], j[1:]
    assert abs(vt[0] * jt[1] - vt[1] * jt[0]) <= 1e-9 * np.linalg.norm(vt) * np.linalg.norm(jt)
    assert vt @ jt < 0
    res = cone.solve_friction_cone(A, q, 0.2, tol=1e-14, max_iter=20000)
    np.testing.assert_allclose(j, res.f, rtol=1e-9)


@pytest.mark.parametrize("seed", range(6))
def test_impact_finish_is_the_impulse_law(seed: int) -> None:
    R, r, v, lm, bvel = _problem(seed)
    k = r.shape[0]
    rng = np.random.default_rng(100 + seed)
    j = rng.uniform(0, 5, 3 * k)
    A = rng.normal(size=(3 * k, 3 * k))
    q = rng.normal(size=3 * k)
    v2, l2, nw2, vn_min, w = kernel.impact_finish(R, INERTIA_INV, MASS, r, A, q, bvel, j, v, lm)
    Jw = j.reshape(k, 3)[:, [1, 2, 0]]  # world (x, y, z) = (j_x, j_y, j_n)
    np.testing.assert_allclose(v2, v + Jw.sum(axis=0) / MASS, rtol=1e-14)
    np.testing.assert_allclose(l2, lm + np.cross(r, Jw).sum(axis=0), rtol=1e-13, atol=1e-15)
    assert nw2 == pytest.approx(np.linalg.norm(R @ INERTIA_INV @ R.T @ l2), rel=1e-13)
    assert vn_min == pytest.approx((A @ j + bvel)[0::3].min(), rel=1e-13)
    np.testing.assert_allclose(w, A @ j + q, rtol=1e-13, atol=1e-14)


@pytest.mark.parametrize("seed", range(30))
def test_lcp_select_is_the_closest_solution(seed: int) -> None:
    """A flat landing on four coplanar corners (A_nn of rank 3: the solutions form a segment):
    ``kernel.lcp_select`` returns ``selection.solve_lcp_min_norm``'s answer — the solution
    closest to the reference (random, or zero: the minimum-norm one), found there by pivoting,
    an SVD null space and a projection LCP."""
    from pbr_xval.reference import selection

    rng = np.random.default_rng(seed)
    R = _rot(rng, 0.02)
    r = CORNERS @ R.T
    v = np.array([0.0, 0.0, -0.1]) + rng.normal(size=3) * 0.02
    w = rng.normal(size=3) * 0.05
    vel = v + np.cross(w, r)
    G = np.zeros((4, 6))
    for i in range(4):
        G[i, 2] = 1.0
        G[i, 3:] = np.cross(r[i], [0.0, 0.0, 1.0])
    Minv = np.zeros((6, 6))
    Minv[:3, :3] = np.eye(3) / MASS
    Minv[3:, 3:] = R @ INERTIA_INV @ R.T
    M = G @ Minv @ G.T
    q = vel[:, 2].copy()
    ref = np.zeros(4) if seed % 3 == 0 else rng.uniform(0, 30, 4)
    ok, z = kernel.lcp_select(M, q, ref)
    want = selection.solve_lcp_min_norm(M, q, reference=None if seed % 3 == 0 else ref)
    assert want.ok
    assert ok
    np.testing.assert_allclose(z, want.z, rtol=0, atol=1e-9 * np.abs(want.z).max())
    wz = M @ z + q
    assert z.min() >= 0 and wz.min() >= -1e-9 * np.abs(q).max()
    assert abs(z @ wz) <= 1e-9 * np.abs(q).max() * np.abs(z).max()


# ----------------------------------------------------------------------------- the cone's first sweeps
@pytest.mark.parametrize("seed", range(200))
def test_eig_sym2_is_lapacks_decomposition(seed: int) -> None:
    """λ ascending (clipped at 0) and orthonormal eigenvectors with Q diag(λ) Qᵀ = the matrix,
    as numpy.linalg.eigh gives them (eigenvectors up to sign); diagonal, repeated and
    indefinite matrices included."""
    rng = np.random.default_rng(seed)
    p, r, s = rng.normal(size=3) * 10.0 ** rng.integers(-6, 3)
    if seed % 10 == 0:
        r = 0.0
    elif seed % 10 == 1:
        s = p
    M = np.array([[p, r], [r, s]])
    lam, Q = cone._eig_sym2(p, r, s)
    want, V = np.linalg.eigh(M)
    scale = max(np.abs(want).max(), 1e-300)
    np.testing.assert_allclose(lam, np.maximum(want, 0.0), rtol=0, atol=4e-16 * scale)
    np.testing.assert_allclose(Q.T @ Q, np.eye(2), rtol=0, atol=1e-15)
    np.testing.assert_allclose(Q @ np.diag(want) @ Q.T, M, rtol=0, atol=8e-16 * scale)
    if abs(want[1] - want[0]) > 1e-6 * scale:  # distinct eigenvalues: the same vectors up to sign
        for c in range(2):
            assert abs(abs(Q[:, c] @ V[:, c]) - 1.0) <= 1e-9


def _cone_problems() -> list[tuple[np.ndarray, np.ndarray, float, np.ndarray]]:
    """Landings of a box on 2–3 corners whose impact cone the active-set guess cannot answer
    (``IMPACT_CONE``), with a warm start (the impulses of a similar landing)."""
    out = []
    for seed in range(400):
        R, r, _, _, bvel = _problem(seed)
        if r.shape[0] < 2:
            continue
        for mu in (0.2, 0.6):
            stage, A, q, _ = kernel.impact_impulses(
                R, INERTIA_INV, MASS, r, bvel, 0.0, mu, np.zeros(r.shape[0])
            )
            if stage == kernel.IMPACT_CONE:
                warm = np.random.default_rng(seed).uniform(0.0, 1.0, q.size) * np.abs(q).max() * MASS
                out.append((A, q, mu, warm))
    return out


CONE_PROBLEMS = _cone_problems()


def test_there_are_cone_problems() -> None:
    assert len(CONE_PROBLEMS) >= 20


@pytest.mark.parametrize("i", range(20))
def test_first_sweeps_are_the_cone_solvers(i: int) -> None:
    """Converged within the first sweeps: the general solver's forces bit for bit and its sweep
    count; not converged: the general solver needed more (it polishes from sweep 25 on)."""
    A, q, mu, warm = CONE_PROBLEMS[i]
    k = q.size // 3
    conv, sweeps, f = cone.cone_first_sweeps(A, q, np.full(k, mu), warm, 1e-13)
    res = cone.solve_friction_cone(A, q, mu, tol=1e-13, max_iter=20000, warm_start=warm)
    assert res.converged
    if conv:
        assert sweeps == res.iterations < cone.POLISH_EVERY
        np.testing.assert_array_equal(f, res.f)
        r6 = cone.friction_residuals(f, A @ f + q, np.full(k, mu))
        fs = np.abs(f).max()
        assert r6["signorini_f"] <= 1e-12 * fs and r6["cone"] <= 1e-12 * fs
    else:
        assert res.iterations >= cone.POLISH_EVERY


def test_some_first_sweeps_converge_and_some_do_not() -> None:
    """The set above exercises both branches."""
    done = [
        bool(cone.cone_first_sweeps(A, q, np.full(q.size // 3, mu), warm, 1e-13)[0])
        for A, q, mu, warm in CONE_PROBLEMS[:20]
    ]
    assert any(done) and not all(done)


@pytest.mark.parametrize(("jt", "reverted"), [(0.01, False), (5.0, True)])
def test_impact_normals_selection_keeps_or_reverts_by_the_cone(jt: float, reverted: bool) -> None:
    """A flat landing on four corners (A_nn singular: no unique normal LCP, so the Python
    selection answers): the selected normal impulses replace the cone's when every tangential
    impulse stays in its cone (here a small one on corner 0) and are put back — counted as
    reverted — when one leaves it (a tangential impulse of 5 N s against μ_s = 0.6 times the
    ~4 N s a corner gets)."""
    from types import SimpleNamespace

    from pbr_xval.reference import dynamics

    r = CORNERS.copy()
    bvel = np.tile([-0.1, 0.0, 0.0], 4)  # every corner lands at 0.1 m/s, no slip
    _, A, q, _ = kernel.impact_impulses(np.eye(3), INERTIA_INV, MASS, r, bvel, 0.0, 0.6, np.zeros(4))
    j = np.zeros(12)
    j[1] = jt
    jn_cone = np.array([10.0, 3.0, 3.0, 3.0])  # the cone solver's normal impulses (any)
    j[0::3] = jn_cone
    solver = SimpleNamespace(mu_s=0.6, selection="min_norm", method="dantzig", stats=dynamics.ContactStats())
    dynamics.RigidBodySolver._impact_normals(solver, A, q, j, np.zeros(12))
    assert solver.stats.selection_reverted == int(reverted)
    assert j[1] == jt and not j[2::3].any()  # the tangential impulses are held fixed
    if reverted:
        np.testing.assert_array_equal(j[0::3], jn_cone)
    else:
        zn = j[0::3]
        assert (zn >= 0).all() and not np.allclose(zn, jn_cone)
        assert np.hypot(j[1], j[2]) <= 0.6 * zn[0]
        # the selected normal impulses stop the landing: every corner's normal velocity ≥ 0
        assert ((A @ j + q)[0::3] >= -1e-12).all()
