"""Independent checks of the LCP and friction solvers in ``pbr_xval.reference.lcp``.

Reference answers come from brute-force enumeration of complementary bases, from
problems constructed with a known solution, from ``scipy.optimize.nnls`` (the symmetric PSD
LCP is the KKT system of a bound constrained least-squares problem), from the enumerated
active sets of a projection and from rigid-body statics worked by hand.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy.optimize import nnls

from pbr_xval.reference.lcp import (
    FrictionResult,
    LCPResult,
    dantzig,
    lemke,
    solve_friction_cone,
    solve_friction_pyramid,
    solve_lcp,
    solve_lcp_min_norm,
)

SOLVERS = [lemke, dantzig]
G = 9.81
MASS = 460.8  # 2400 kg/m^3 * 0.4 * 0.4 * 1.2 m^3
HALF = np.array([0.2, 0.2, 0.6])


# --------------------------------------------------------------------------------------
# helpers
# --------------------------------------------------------------------------------------
def brute_force(M: np.ndarray, q: np.ndarray, tol: float = 1e-10) -> list[np.ndarray]:
    """All solutions found by enumerating the 2^n complementary bases."""
    n = q.size
    sols = []
    for k in range(n + 1):
        for S in itertools.combinations(range(n), k):
            S = list(S)
            z = np.zeros(n)
            if S:
                z[S] = np.linalg.solve(M[np.ix_(S, S)], -q[S])
            w = M @ z + q
            if z.min() >= -tol and w.min() >= -tol:
                sols.append(z)
    return sols


def is_p_matrix(M: np.ndarray) -> bool:
    n = M.shape[0]
    return all(
        np.linalg.det(M[np.ix_(S, S)]) > 1e-6
        for k in range(1, n + 1)
        for S in itertools.combinations(range(n), k)
    )


def random_p_matrix(rng: np.random.Generator, n: int, kind: str) -> np.ndarray:
    if kind == "sym_pd":  # B^T B + delta I
        B = rng.standard_normal((n, n))
        return B.T @ B + rng.uniform(0.05, 1.0) * np.eye(n)
    if kind == "nonsym_pd":  # positive definite (x^T M x > 0) but not symmetric
        B = rng.standard_normal((n, n))
        K = rng.standard_normal((n, n))
        return B.T @ B + 0.2 * np.eye(n) + (K - K.T)
    while True:  # general P-matrix (not necessarily positive definite)
        M = rng.standard_normal((n, n)) + np.diag(rng.uniform(0.5, 3.0, n))
        if is_p_matrix(M):
            return M


def brute_force_w(M: np.ndarray, q: np.ndarray, tol: float = 1e-9) -> list[np.ndarray]:
    """w = M z + q of every solution found by enumerating the 2^n complementary bases, the
    clamped block solved in the least-squares sense (tolerates singular blocks)."""
    n = q.size
    scale = max(1.0, float(np.abs(q).max(initial=0.0)))
    out = []
    for k in range(n + 1):
        for S in itertools.combinations(range(n), k):
            S = list(S)
            z = np.zeros(n)
            if S:
                z[S] = np.linalg.lstsq(M[np.ix_(S, S)], -q[S], rcond=1e-12)[0]
            w = M @ z + q
            if (
                z.min() >= -tol * scale
                and w.min() >= -tol * scale
                and np.abs(w[S]).max(initial=0.0) <= tol * scale
            ):
                out.append(w)
    return out


def assert_lcp_solution(res: LCPResult, M: np.ndarray, q: np.ndarray, tol: float = 1e-9) -> None:
    """``res.z`` solves the LCP (conditions checked on w recomputed here, not on ``res.w``),
    and, for symmetric PSD problems small enough to enumerate, its w is the one every
    solution shares (brute force over the complementary bases: an independent solver)."""
    assert res.ok, (res.status, res.message)
    z = res.z
    w = M @ z + q
    scale = max(1.0, np.abs(q).max(initial=0.0), np.abs(M).max(initial=0.0) * np.abs(z).max(initial=0.0))
    assert z.min(initial=0.0) >= -tol * scale
    assert w.min(initial=0.0) >= -tol * scale
    assert np.abs(z * w).max(initial=0.0) <= tol * scale * max(1.0, np.abs(z).max(initial=0.0))
    sym = (
        M.size and np.allclose(M, M.T, atol=1e-12 * np.abs(M).max()) and np.linalg.eigvalsh(M).min() >= -1e-10
    )
    if sym and q.size <= 10:
        ref = brute_force_w(M, q)
        assert ref, "brute force found no solution"
        np.testing.assert_allclose(w, ref[0], atol=1e-7 * scale)


def skew(r: np.ndarray) -> np.ndarray:
    return np.array([[0, -r[2], r[1]], [r[2], 0, -r[0]], [-r[1], r[0], 0]])


def box_inverse_mass() -> np.ndarray:
    """Generalized inverse mass of the 0.4 x 0.4 x 1.2 m box (world-aligned), (6, 6)."""
    a, b, h = 2 * HALF
    inertia = MASS / 12.0 * np.array([b**2 + h**2, a**2 + h**2, a**2 + b**2])
    return np.diag(np.concatenate([np.full(3, 1.0 / MASS), 1.0 / inertia]))


def contact_rows(p: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Jacobian row of the velocity of body point ``p`` (rel. to COM) along ``d``, (6,)."""
    return np.concatenate([d, np.cross(p, d)])  # d.(v + w x p) = d.v + (p x d).w


def bottom_points(kind: str) -> np.ndarray:
    hx, hy, hz = HALF
    corners = np.array([[sx * hx, sy * hy, -hz] for sx in (1, -1) for sy in (1, -1)])
    if kind == "corners":
        return corners
    mids = np.array([[hx, 0, -hz], [-hx, 0, -hz], [0, hy, -hz], [0, -hy, -hz]])
    return np.vstack([corners, mids])  # 8 points, normals +z -> rank 3


def normal_jacobian(points: np.ndarray) -> np.ndarray:
    n = np.array([0.0, 0.0, 1.0])
    return np.array([contact_rows(p, n) for p in points])


def frame_jacobian(points: np.ndarray) -> np.ndarray:
    """Rows (n, x, y) per contact for a horizontal ground plane, (3k, 6)."""
    dirs = np.eye(3)[[2, 0, 1]]
    return np.array([contact_rows(p, d) for p in points for d in dirs])


def impact_problem(points: np.ndarray, u_minus: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    J = normal_jacobian(points)
    W = box_inverse_mass()
    return J @ W @ J.T, J @ u_minus, J


def nnls_reference(J: np.ndarray, u_minus: np.ndarray) -> np.ndarray:
    """Impulses from scipy NNLS: min ||W^1/2 J^T z + W^-1/2 u||, z >= 0 (same KKT as the LCP)."""
    W = box_inverse_mass()
    Wh = np.sqrt(W)
    z, _ = nnls(Wh @ J.T, -(np.linalg.inv(Wh) @ u_minus), maxiter=1000)
    return z


U_IMPACT = np.array([0.1, -0.05, -1.0, 0.3, -0.2, 0.1])


# --------------------------------------------------------------------------------------
# unique solutions: brute force over the 2^n bases
# --------------------------------------------------------------------------------------
@pytest.mark.parametrize("seed", range(100))
def test_matches_brute_force_on_p_matrices(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 9)) if seed % 3 != 2 else int(rng.integers(1, 6))
    kind = ("sym_pd", "nonsym_pd", "general_p")[seed % 3]
    M = random_p_matrix(rng, n, kind)
    q = 3.0 * rng.standard_normal(n)
    sols = brute_force(M, q)
    assert len(sols) == 1  # P-matrix => unique
    for solver in SOLVERS:
        res = solver(M, q)
        assert_lcp_solution(res, M, q)
        np.testing.assert_allclose(res.z, sols[0], atol=1e-9, err_msg=solver.__name__)
        assert res.pivots <= 2 * n + 2, (solver.__name__, res.pivots, n)


@pytest.mark.parametrize("seed", range(40))
def test_known_solution_psd(seed: int) -> None:
    rng = np.random.default_rng(1000 + seed)
    n = int(rng.integers(2, 13))
    singular = seed % 2 == 0
    rank = int(rng.integers(1, n)) if singular else n
    B = rng.standard_normal((rank, n))
    M = B.T @ B + (0.0 if singular else 0.1) * np.eye(n)
    support = rng.random(n) < 0.5
    z_star = np.where(support, rng.uniform(0.1, 2.0, n), 0.0)
    w_star = np.where(support, 0.0, rng.uniform(0.0, 2.0, n))
    w_star[~support & (rng.random(n) < 0.2)] = 0.0  # some degenerate (w = z = 0) indices
    q = w_star - M @ z_star
    for method in ("dantzig", "lemke"):
        res = solve_lcp(M, q, method=method, fallback=False)
        assert_lcp_solution(res, M, q)
        np.testing.assert_allclose(res.w, w_star, atol=1e-9 * max(1.0, np.abs(q).max()))
        if not singular:
            np.testing.assert_allclose(res.z, z_star, atol=1e-9)
        assert res.pivots <= 2 * n + 2


# --------------------------------------------------------------------------------------
# small and degenerate problems
# --------------------------------------------------------------------------------------
@pytest.mark.parametrize("solver", SOLVERS)
def test_empty_and_scalar(solver) -> None:
    res = solver(np.zeros((0, 0)), np.zeros(0))
    assert res.ok and res.z.shape == (0,) and res.w.shape == (0,) and res.pivots == 0
    res = solver(np.array([[2.0]]), np.array([-4.0]))
    assert res.ok and res.z == pytest.approx([2.0]) and res.w == pytest.approx([0.0], abs=1e-14)
    assert 1 <= res.pivots <= 2
    res = solver(np.array([[2.0]]), np.array([3.0]))
    assert res.ok and res.pivots == 0 and res.z[0] == 0.0 and res.w[0] == 3.0
    res = solver(np.array([[0.0]]), np.array([-1.0]))
    assert not res.ok and res.status in ("ray", "infeasible")


@pytest.mark.parametrize("solver", SOLVERS)
def test_trivial_nonnegative_q(solver) -> None:
    rng = np.random.default_rng(5)
    B = rng.standard_normal((4, 6))
    q = rng.uniform(0.0, 1.0, 6)
    q[2] = 0.0
    res = solver(B.T @ B, q)
    assert res.ok and res.pivots == 0
    np.testing.assert_array_equal(res.z, 0.0)
    np.testing.assert_array_equal(res.w, q)


def _zero_row_problem(qi: float) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(7)
    B = rng.standard_normal((5, 5))
    M = B.T @ B + 0.1 * np.eye(5)
    M[2, :] = 0.0
    M[:, 2] = 0.0
    q = rng.standard_normal(5)
    q[2] = qi
    return M, q


@pytest.mark.parametrize("solver", SOLVERS)
@pytest.mark.parametrize("qi", [0.7, 0.0])
def test_zero_row_feasible(solver, qi: float) -> None:
    M, q = _zero_row_problem(qi)
    res = solver(M, q)
    assert_lcp_solution(res, M, q)
    keep = [0, 1, 3, 4]
    sol = brute_force(M[np.ix_(keep, keep)], q[keep])
    assert len(sol) == 1
    np.testing.assert_allclose(res.z[keep], sol[0], atol=1e-9)
    assert res.w[2] == pytest.approx(qi)


@pytest.mark.parametrize("method", ["dantzig", "lemke"])
def test_zero_row_infeasible_reports_failure(method: str) -> None:
    M, q = _zero_row_problem(-0.5)  # w_2 = -0.5 whatever z is
    res = solve_lcp(M, q, method=method, max_pivots=200)
    assert not res.ok
    assert res.status in ("ray", "infeasible")
    assert set(res.pivots_by_method) == {"dantzig", "lemke"}  # fallback was attempted
    assert all(p <= 200 for p in res.pivots_by_method.values())
    assert lemke(M, q).status == "ray"
    assert dantzig(M, q).status == "infeasible"


@pytest.mark.parametrize("solver", SOLVERS)
def test_duplicate_contacts(solver) -> None:
    pts = bottom_points("corners")
    pts = np.vstack([pts, pts[[0]]])  # contact 4 duplicates contact 0
    M, q, J = impact_problem(pts, U_IMPACT)
    assert np.linalg.matrix_rank(M) == 3
    res = solver(M, q)
    assert_lcp_solution(res, M, q)
    z_ref = nnls_reference(J, U_IMPACT)
    w_ref = M @ z_ref + q
    np.testing.assert_allclose(res.w, w_ref, atol=1e-9)
    # the duplicated impulse may be split any way; the post-impact velocity may not
    W = box_inverse_mass()
    np.testing.assert_allclose(W @ J.T @ res.z, W @ J.T @ z_ref, atol=1e-9)
    assert res.z[0] + res.z[4] == pytest.approx(z_ref[0] + z_ref[4], rel=1e-9, abs=1e-9)
    assert res.pivots <= 2 * 5 + 2


@pytest.mark.parametrize("solver", SOLVERS)
@pytest.mark.parametrize(
    "u_minus", [U_IMPACT, np.array([0, 0, -1.0, 0, 0, 0]), np.array([0.5, 0, -0.2, 0, 2.0, 0])]
)
def test_singular_box_eight_contacts(solver, u_minus: np.ndarray) -> None:
    pts = bottom_points("eight")
    M, q, J = impact_problem(pts, u_minus)
    assert M.shape == (8, 8) and np.linalg.matrix_rank(M) == 3
    res = solver(M, q)
    assert_lcp_solution(res, M, q)
    z_ref = nnls_reference(J, u_minus)
    np.testing.assert_allclose(res.w, M @ z_ref + q, atol=1e-9)
    u_plus = u_minus + box_inverse_mass() @ J.T @ res.z
    assert np.all(J @ u_plus >= -1e-9)  # no contact keeps approaching (e = 0)
    assert res.pivots <= 2 * 8 + 2


def test_restitution_shift() -> None:
    """e > 0: w = v+ + e v-, q = b + e v-; a flat drop with e = 0.5 bounces at 0.5 m/s."""
    pts = bottom_points("corners")
    u = np.array([0, 0, -1.0, 0, 0, 0])
    M, v_minus, J = impact_problem(pts, u)
    e = 0.5
    res = solve_lcp(M, v_minus + e * v_minus)
    assert res.ok
    u_plus = u + box_inverse_mass() @ J.T @ res.z
    np.testing.assert_allclose(u_plus, [0, 0, 0.5, 0, 0, 0], atol=1e-12)
    assert res.z.sum() == pytest.approx(1.5 * MASS)


# --------------------------------------------------------------------------------------
# dispatcher, warm start, fallback
# --------------------------------------------------------------------------------------
def test_dispatcher_records_method_and_warm_start() -> None:
    rng = np.random.default_rng(11)
    B = rng.standard_normal((7, 7))
    M = B.T @ B + 0.1 * np.eye(7)
    q = rng.standard_normal(7)
    cold = solve_lcp(M, q)
    assert cold.ok and cold.method == "dantzig" and cold.pivots_by_method == {"dantzig": cold.pivots}
    warm = solve_lcp(M, q, warm_start=cold.z)
    assert warm.ok and warm.pivots == 0 and warm.method == "warm_start+dantzig"
    np.testing.assert_allclose(warm.z, cold.z, atol=1e-12)
    # a wrong guess must still end at the unique solution
    bad = solve_lcp(M, q, warm_start=np.ones(7))
    assert bad.ok
    np.testing.assert_allclose(bad.z, cold.z, atol=1e-10)
    lem = solve_lcp(M, q, method="lemke", warm_start=cold.z)
    assert lem.ok and lem.method == "lemke"
    np.testing.assert_allclose(lem.z, cold.z, atol=1e-10)
    with pytest.raises(ValueError):
        solve_lcp(M, q, method="pgs")


def test_fallback_is_used_when_primary_fails() -> None:
    """A nonnegative (copositive) non-PSD matrix: Baraff/Dantzig stalls, Lemke solves it."""
    M = np.array([[0.0, 1.0, 0.6], [0.1, 0.1, 1.0], [0.1, 0.9, 0.1]])
    q = np.array([-0.4, -0.4, -0.3])
    primary = solve_lcp(M, q, method="dantzig", fallback=False)
    assert not primary.ok and primary.method == "dantzig"
    res = solve_lcp(M, q, method="dantzig")
    assert_lcp_solution(res, M, q)
    assert res.method == "lemke"
    assert set(res.pivots_by_method) == {"dantzig", "lemke"}
    assert res.pivots == res.pivots_by_method["lemke"] >= 1
    assert "fallback" in res.message
    direct = solve_lcp(M, q, method="lemke")
    assert direct.ok and direct.pivots_by_method == {"lemke": direct.pivots}
    np.testing.assert_allclose(direct.z, res.z)


# --------------------------------------------------------------------------------------
# non-unique solutions: closest to a reference / minimum norm
# --------------------------------------------------------------------------------------
def _duplicate_problem() -> tuple[np.ndarray, np.ndarray]:
    """Three corners plus a duplicate of corner 0: the only non-uniqueness is the split."""
    pts = bottom_points("corners")[:3]
    pts = np.vstack([pts, pts[[0]]])
    M, q, _ = impact_problem(pts, np.array([0.1, 0.0, -1.0, -0.5, 0.5, 0.0]))
    return M, q


@pytest.mark.parametrize("method", ["dantzig", "lemke"])
def test_min_norm_splits_duplicates_equally(method: str) -> None:
    M, q = _duplicate_problem()
    base = solve_lcp(M, q, method=method)
    res = solve_lcp_min_norm(M, q, method=method)
    assert_lcp_solution(res, M, q)
    np.testing.assert_allclose(res.w, base.w, atol=1e-9)
    assert np.linalg.matrix_rank(M) == 3
    total = base.z[0] + base.z[3]
    assert total > 1.0
    assert res.z[0] == pytest.approx(total / 2, rel=1e-9)
    assert res.z[3] == pytest.approx(total / 2, rel=1e-9)
    np.testing.assert_allclose(res.z[1:3], base.z[1:3], rtol=1e-9, atol=1e-9)
    assert res.method.endswith("+closest")
    assert np.linalg.norm(res.z) <= np.linalg.norm(base.z) + 1e-9
    assert solve_lcp(M, q, select="min_norm").z == pytest.approx(res.z, rel=1e-12)


def test_closest_to_reference_moves_toward_it() -> None:
    M, q = _duplicate_problem()
    mn = solve_lcp_min_norm(M, q)
    total = mn.z[0] + mn.z[3]
    ref = mn.z.copy()
    ref[0], ref[3] = 0.8 * total, 0.2 * total  # feasible reference: reproduced exactly
    res = solve_lcp_min_norm(M, q, reference=ref)
    assert_lcp_solution(res, M, q)
    np.testing.assert_allclose(res.z, ref, rtol=1e-9, atol=1e-9)
    ref2 = mn.z.copy()
    ref2[0], ref2[3] = 2.0 * total, -0.5 * total  # infeasible: clipped to the segment end
    res2 = solve_lcp(M, q, select="closest", reference=ref2)
    assert res2.z[0] == pytest.approx(total, rel=1e-9)
    assert res2.z[3] == pytest.approx(0.0, abs=1e-9 * total)
    assert np.linalg.norm(res2.z - ref2) < np.linalg.norm(mn.z - ref2)


def test_min_norm_on_eight_contact_box() -> None:
    """Vertical flat drop: the minimum-norm impulse is m v / 8 at every point."""
    pts = bottom_points("eight")
    M, q, _ = impact_problem(pts, np.array([0, 0, -1.0, 0, 0, 0]))
    for method in ("dantzig", "lemke"):
        res = solve_lcp_min_norm(M, q, method=method)
        assert_lcp_solution(res, M, q)
        np.testing.assert_allclose(res.z, MASS / 8, rtol=1e-9)


def test_closest_matches_the_enumerated_projection() -> None:
    """The solution closest to ``reference`` is the Euclidean projection of the reference onto the
    solution set {z ≥ 0, z_i = 0 where w_i > 0, M z = w − q}: found here by enumerating which
    of the free impulses are zero (a convex QP's optimum is the equality-constrained optimum of
    its active set; 2⁸ pseudo-inverse projections) — independent of the pivoting under test.
    (It used SLSQP, whose line search failed from z = 0 with OpenBLAS on one thread,
    OPENBLAS_NUM_THREADS=1, on an AMD Zen 5.)"""
    pts = bottom_points("eight")
    M, q, _ = impact_problem(pts, U_IMPACT)
    rng = np.random.default_rng(3)
    ref = rng.uniform(0, 300, 8)
    res = solve_lcp_min_norm(M, q, reference=ref)
    assert_lcp_solution(res, M, q)
    S = np.flatnonzero(res.w <= 1e-9)
    c = res.w - q
    scale = np.abs(c).max()
    best, best_z = np.inf, None
    for mask in range(1 << S.size):
        free = np.array([i for b, i in enumerate(S) if not mask >> b & 1], dtype=int)
        z = np.zeros(8)
        if free.size:
            A = M[:, free]
            z[free] = ref[free] - np.linalg.pinv(A, rcond=1e-10) @ (A @ ref[free] - c)
        if np.abs(M @ z - c).max() > 1e-9 * scale or z.min() < -1e-9 * np.abs(z).max():
            continue  # this active set has no feasible point
        obj = float(np.sum((z - ref) ** 2))
        if obj < best:
            best, best_z = obj, z
    assert best_z is not None
    np.testing.assert_allclose(res.z, best_z, atol=1e-8 * np.abs(best_z).max())


# --------------------------------------------------------------------------------------
# friction cone
# --------------------------------------------------------------------------------------
def _assert_friction_ok(res: FrictionResult, f_scale: float, a_scale: float) -> None:
    assert res.converged and res.ok, res.residuals
    r = res.residuals
    assert r["signorini_f"] <= 1e-9 * f_scale
    assert r["signorini_a"] <= 1e-8 * a_scale
    assert r["complementarity"] <= 1e-8 * f_scale * a_scale
    assert r["cone"] <= 1e-9 * f_scale
    assert r["friction_complementarity"] <= 1e-8 * f_scale * a_scale
    assert r["dissipation"] <= 1e-8 * f_scale * a_scale


@pytest.mark.parametrize("anisotropic", [False, True])
def test_single_contact_stick_and_slide(anisotropic: bool) -> None:
    m, mu = 2.0, 0.4
    A = np.eye(3) / m
    if anisotropic:
        A = A + np.array([[0.1, 0.05, 0.0], [0.05, 0.3, 0.1], [0.0, 0.1, 0.2]])
    # stick: push of 0.7 mu m g in the x-y plane
    F = 0.7 * mu * m * G * np.array([0.6, 0.8])
    b = np.array([-G, *(F / m)])
    res = solve_friction_cone(A, b, mu)
    _assert_friction_ok(res, m * G, G)
    np.testing.assert_allclose(res.a[1:], 0.0, atol=1e-9)
    assert np.linalg.norm(res.f[1:]) < mu * res.f[0]
    if not anisotropic:
        np.testing.assert_allclose(res.f, [m * G, -F[0], -F[1]], rtol=1e-9)
    # slide: push of 2 mu m g
    b = np.array([-G, *(2.0 / 0.7 * F / m)])
    res = solve_friction_cone(A, b, mu)
    _assert_friction_ok(res, m * G, G)
    ft, at = res.f[1:], res.a[1:]
    assert np.linalg.norm(at) > 0.1
    assert np.linalg.norm(ft) == pytest.approx(mu * res.f[0], rel=1e-9)
    np.testing.assert_allclose(ft / np.linalg.norm(ft), -at / np.linalg.norm(at), atol=1e-8)
    if not anisotropic:
        assert res.f[0] == pytest.approx(m * G, rel=1e-12)
        np.testing.assert_allclose(at, (2.0 - 1.0) * mu * G * np.array([0.6, 0.8]), rtol=1e-9)


def test_separating_contact_gets_no_force() -> None:
    A = np.eye(3)
    res = solve_friction_cone(A, np.array([1.0, 3.0, 0.0]), 0.5)
    assert res.converged and res.iterations <= 2
    np.testing.assert_array_equal(res.f, 0.0)


def _box_friction_problem(push: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    pts = bottom_points("corners")
    J = frame_jacobian(pts)
    W = box_inverse_mass()
    F_ext = np.array([push, 0.0, -MASS * G, 0.0, 0.0, 0.0])  # applied at the COM
    return J @ W @ J.T, J @ W @ F_ext, J, F_ext


@pytest.mark.parametrize("ratio", [0.13, 0.25])
def test_box_on_plane_stick_or_slide(ratio: float) -> None:
    """mu = 0.2 (< tipping threshold b/h = 1/3): push 0.13 m g sticks, 0.25 m g slides."""
    mu = 0.2
    push = ratio * MASS * G
    A, b, J, F_ext = _box_friction_problem(push)
    assert np.linalg.matrix_rank(A) == 6  # 12 unknowns, singular
    res = solve_friction_cone(A, b, mu)
    _assert_friction_ok(res, MASS * G, G)
    assert res.iterations < 10000
    F = res.f.reshape(4, 3)
    assert F[:, 0].sum() == pytest.approx(MASS * G, rel=1e-9)
    assert F[:, 2].sum() == pytest.approx(0.0, abs=1e-7 * MASS * G)
    u_dot = box_inverse_mass() @ (J.T @ res.f + F_ext)
    if ratio * 1.0 < mu:  # sticking: friction balances the push, box at rest
        assert F[:, 1].sum() == pytest.approx(-push, rel=1e-9)
        np.testing.assert_allclose(u_dot, 0.0, atol=1e-9)
        np.testing.assert_allclose(res.a, 0.0, atol=1e-9)
    else:  # sliding: friction saturates at mu m g, box accelerates in x without rotating
        assert F[:, 1].sum() == pytest.approx(-mu * MASS * G, rel=1e-9)
        np.testing.assert_allclose(np.linalg.norm(F[:, 1:], axis=1), mu * F[:, 0], rtol=1e-9)
        np.testing.assert_allclose(u_dot, [(ratio - mu) * G, 0, 0, 0, 0, 0], atol=1e-9)
    # warm start from the solution converges immediately
    again = solve_friction_cone(A, b, mu, warm_start=res.f)
    assert again.converged and again.iterations <= 2


@pytest.mark.parametrize("ratio", [0.13, 0.25])
def test_pyramid_lcp_agrees_with_cone(ratio: float) -> None:
    mu = 0.2
    A, b, J, F_ext = _box_friction_problem(ratio * MASS * G)
    cone = solve_friction_cone(A, b, mu)
    pyr = solve_friction_pyramid(A, b, mu, n_facets=8)
    assert pyr.converged, pyr.status
    assert pyr.iterations <= 4 * (4 * 10)  # Lemke pivots on a 40-variable LCP
    W = box_inverse_mass()
    np.testing.assert_allclose(W @ (J.T @ pyr.f + F_ext), W @ (J.T @ cone.f + F_ext), atol=1e-8)
    np.testing.assert_allclose(
        pyr.f.reshape(4, 3).sum(axis=0), cone.f.reshape(4, 3).sum(axis=0), rtol=1e-8, atol=1e-6
    )


def test_friction_input_validation() -> None:
    with pytest.raises(ValueError):
        solve_friction_cone(np.eye(4), np.zeros(4), 0.5)
    with pytest.raises(ValueError):
        solve_friction_cone(np.eye(6), np.zeros(6), [0.5, 0.5, 0.5])
    res = solve_friction_cone(np.zeros((0, 0)), np.zeros(0), 0.5)
    assert res.converged and res.f.shape == (0,)


@pytest.mark.parametrize("n", [2, 5, 8])
def test_fully_degenerate_rank_one(n: int) -> None:
    """M = 1 1^T, q = -1: every z >= 0 with sum(z) = 1 solves it; all ratios tie."""
    M = np.ones((n, n))
    q = -np.ones(n)
    for method in ("dantzig", "lemke"):
        res = solve_lcp(M, q, method=method, fallback=False)
        assert_lcp_solution(res, M, q)
        assert res.z.sum() == pytest.approx(1.0, rel=1e-12)
        np.testing.assert_allclose(res.w, 0.0, atol=1e-12)
        assert res.pivots <= 2 * n + 2
        mn = solve_lcp_min_norm(M, q, method=method)
        np.testing.assert_allclose(mn.z, 1.0 / n, rtol=1e-9)


def test_friction_random_box_configurations() -> None:
    """Random contact sets under gravity, horizontal push and torque: every solve must
    converge with all eq. 3.6-3.7 residuals at round-off level. Where an independent solver —
    the 64-facet friction-pyramid LCP solved by Lemke's pivoting — finds every loaded contact
    sticking, the body's acceleration must be the same (sticking is where the pyramid is
    exact; measured agreement to 1e-12 g). With sliding or tipping the Coulomb problem of
    several contacts can have several solutions (measured: the pyramid's answer does not
    converge to the cone's as the facets are refined for 4 of the 25 sets), so those are
    checked by the residuals only."""
    rng = np.random.default_rng(7)
    W = box_inverse_mass()
    methods = set()
    checked = 0
    for _ in range(25):
        k = int(rng.integers(1, 9))
        pts = np.column_stack([rng.uniform(-0.2, 0.2, k), rng.uniform(-0.2, 0.2, k), np.full(k, -0.6)])
        J = frame_jacobian(pts)
        push = rng.uniform(-0.4, 0.4, 2) * MASS * G
        F_ext = np.array([push[0], push[1], -MASS * G, *(50.0 * rng.standard_normal(3))])
        A, b, mu = J @ W @ J.T, J @ W @ F_ext, rng.uniform(0.1, 0.8)
        res = solve_friction_cone(A, b, mu, max_iter=3000)
        methods.add(res.method)
        _assert_friction_ok(res, MASS * G, G)
        pyr = solve_friction_pyramid(A, b, mu, n_facets=64)
        assert pyr.converged, pyr.status
        P = pyr.a.reshape(k, 3)
        loaded = pyr.f.reshape(k, 3)[:, 0] > 1e-9 * MASS * G
        if np.all(np.abs(P[loaded, 1:]) <= 1e-9 * G):
            checked += 1
            u_cone = W @ (J.T @ res.f + F_ext)
            u_pyr = W @ (J.T @ pyr.f + F_ext)
            np.testing.assert_allclose(u_cone, u_pyr, atol=1e-9 * G)
    assert checked >= 10, checked  # measured: 15 of the 25 sets stick
    assert "pgs_cone" in methods


# ----------------------------------------------------------------------------- compiled Lemke (issue 23)
def _lemke_numpy(M: np.ndarray, q: np.ndarray, max_pivots: int, tol: float = 1e-12):
    """The NumPy pivoting loop that ``pivoting._lemke_loop`` replaced (reference for the
    bit-for-bit test): (z, pivots, status)."""
    n = q.size
    q_scale = float(np.max(np.abs(q)))
    z0, rhs = 2 * n, 2 * n + 1
    T = np.hstack([np.eye(n), -M, -np.ones((n, 1)), q[:, None]])
    basis = np.arange(n)

    def pivot(r: int, c: int) -> None:
        T[r] /= T[r, c]
        col = T[:, c].copy()
        col[r] = 0.0
        T[...] -= np.outer(col, T[r])
        T[:, c] = 0.0
        T[r, c] = 1.0
        basis[r] = c

    def lex_min_ratio(col: np.ndarray, cand: np.ndarray) -> int:
        tie = cand
        for level, k in enumerate([rhs, *range(n)]):
            vals = T[tie, k]
            if k == rhs:
                vals = np.maximum(vals, 0.0)
            rmin = float((vals / col[tie]).min())
            noise = tol * max(float(np.max(np.abs(T[:, k]))), 1e-300)
            tie = tie[vals - rmin * col[tie] <= noise]
            if level == 0 and tie.size > 1:
                z0_rows = tie[basis[tie] == z0]
                if z0_rows.size:
                    return int(z0_rows[0])
            if tie.size == 1:
                break
        return int(tie.min())

    r = int(np.flatnonzero(q <= float(q.min()) + tol * q_scale).max())
    leaving = int(basis[r])
    pivot(r, z0)
    pivots, status = 1, "max_pivots"
    while pivots < max_pivots:
        entering = leaving + n if leaving < n else leaving - n
        col = T[:, entering]
        cand = np.flatnonzero(col > tol * max(1.0, float(np.max(np.abs(col)))))
        if cand.size == 0:
            status = "ray"
            break
        r = lex_min_ratio(col, cand)
        leaving = int(basis[r])
        pivot(r, entering)
        pivots += 1
        if leaving == z0:
            status = "ok"
            break
    x = np.zeros(2 * n + 1)
    x[basis] = T[:, rhs]
    return x[n : 2 * n], pivots, status


@pytest.mark.parametrize("kind", ["psd", "singular", "general", "degenerate"])
def test_compiled_lemke_pivots_as_the_numpy_loop(kind: str) -> None:
    """pivoting.lemke's compiled loop takes the NumPy loop's pivots: same count, same status,
    the same z before the final polish, bit for bit."""
    from pbr_xval.reference import pivoting

    rng = np.random.default_rng(7)
    for _ in range(40):
        n = int(rng.integers(1, 13))
        g = rng.standard_normal((n, n))
        if kind == "psd":
            M = g @ g.T
        elif kind == "singular":
            h = g[:, : max(1, n // 2)]
            M = h @ h.T
        elif kind == "general":
            M = g + n * np.eye(n) * rng.uniform(0, 1)
        else:
            M = np.round(g @ g.T)
        q = rng.standard_normal(n) if kind != "degenerate" else np.round(rng.standard_normal(n))
        if np.all(q >= 0):
            q[0] = -1.0
        want_z, want_piv, want_status = _lemke_numpy(M, q, 50 * (n + 1))
        T = np.hstack([np.eye(n), -M, -np.ones((n, 1)), q[:, None]])
        basis = np.arange(n)
        code, piv, _ = pivoting._lemke_loop(T, basis, q, float(np.max(np.abs(q))), 50 * (n + 1), 1e-12)
        x = np.zeros(2 * n + 1)
        x[basis] = T[:, 2 * n + 1]
        assert piv == want_piv
        assert {1: "ok", 2: "ray", 0: "max_pivots"}[code] == want_status
        np.testing.assert_array_equal(x[n : 2 * n], want_z)
