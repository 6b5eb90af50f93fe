"""Selection among the non-unique solutions of the impact LCP (eq. 3.5).

For e = 0 and redundant contacts (more than six contact points of one body, duplicated
points, a flat face landing) the LCP matrix of eq. 3.5 is singular and the impulse split is
not unique, although the post-impact velocity is (for symmetric PSD ``M`` every solution
has the same ``w`` and the same ``Jᵀ z``).  The seed paper does not say which solution its
Dantzig pivoting returns; a pivoting path depends on round-off, so the reference solver
selects a solution explicitly: the one closest to a reference (the previous step's
impulses, or zero: the minimum-norm split).
"""

from __future__ import annotations

import numpy as np

from pbr_xval.reference import dense
from pbr_xval.reference.pivoting import LCPResult, _as_problem, _scales, _verify_tol, solve_lcp

__all__ = ["solve_lcp_min_norm"]


def solve_lcp_min_norm(
    M: np.ndarray,
    q: np.ndarray,
    *,
    reference: np.ndarray | None = None,
    method: str = "dantzig",
    tol: float = 1e-12,
    max_pivots: int | None = None,
    warm_start: np.ndarray | None = None,
    support_rtol: float = 1e-9,
    rank_rtol: float = 1e-10,
) -> LCPResult:
    """Solution of the LCP closest (Euclidean) to ``reference``; default the min-norm one.

    For symmetric PSD ``M`` (impact matrices ``J M^-1 J^T``) ``w`` is the same for all
    solutions but ``z`` is not when ``M`` is singular (duplicate contacts, more than
    six contact points): any two solutions satisfy ``M (z1 - z2) = 0``.  Hence, with
    ``w*`` from any solution and ``S = {i : w*_i = 0}``, the solution set is the
    polyhedron

        ``Z = {z : z >= 0, z_i = 0 (i not in S), M[:, S] z_S = w* - q}``

    (every point of ``Z`` is a solution for *any* ``M``; for symmetric PSD ``M`` it is
    all of them).  We return the unique projection of ``reference`` onto ``Z``,
    i.e. the convex QP ``min ||z - z_ref||^2`` over ``Z``.  It is computed exactly by
    writing ``z_S = x0 + N y`` (``x0`` the solver's solution, ``N`` an orthonormal basis
    of ``null(M[:, S])`` from an SVD); the KKT system of ``min ||x0 + N y - r||^2,
    x0 + N y >= 0`` is the PSD LCP ``x = P lam + x0 + P (r - x0)`` with ``P = N N^T``,
    ``x >= 0, lam >= 0, x.lam = 0``, which is solved by :func:`solve_lcp` and whose
    ``x`` is the answer.  The result is re-checked for feasibility.

    Why: the choice must not depend on the pivoting path (which reorders with tiny
    perturbations and would make the rigid-body reference jittery).  With the previous
    step's impulses as reference the choice is the solution closest to the previous
    state (Veeraraghavan, Hall & Krishnan); with the zero reference it is the
    minimum-norm impulse, which spreads the load evenly over redundant contacts
    (two duplicates get half each) -- the natural symmetric choice.

    Parameters
    ----------
    M : array_like, shape (n, n)
        LCP matrix (intended: symmetric PSD).
    q : array_like, shape (n,)
        LCP vector.
    reference : array_like, shape (n,), optional
        Target ``z_ref``; default zeros (minimum-norm solution).
    method : {"dantzig", "lemke"}
        Method for the primary LCP (with fallback).
    tol, max_pivots, warm_start
        Passed to :func:`solve_lcp`.
    support_rtol : float
        ``i`` is in ``S`` when ``w*_i <= support_rtol * max(|q|, |M||z|)``.
    rank_rtol : float
        Singular values below ``rank_rtol * sigma_max`` span the null space.

    Returns
    -------
    LCPResult
        ``method`` is the primary method name + ``"+closest"``; ``pivots`` counts both
        LCP solves; ``pivots_by_method["closest"]`` the projection solve.  If the
        primary solve fails, its result is returned unchanged.
    """
    M, q = _as_problem(M, q)
    n = q.size
    base = solve_lcp(M, q, method=method, tol=tol, max_pivots=max_pivots, warm_start=warm_start)
    if not base.ok or n == 0:
        return base
    r = np.zeros(n) if reference is None else np.asarray(reference, dtype=float).reshape(-1)
    if r.size != n:
        raise ValueError("reference has the wrong size")
    m_scale, q_scale = _scales(M, q)
    z_scale = float(np.max(np.abs(base.z)))
    S = np.flatnonzero(base.w <= support_rtol * max(q_scale, m_scale * z_scale, 1e-300))
    out = LCPResult(
        z=base.z.copy(),
        w=base.w.copy(),
        pivots=base.pivots,
        status="ok",
        method=base.method + "+closest",
        pivots_by_method=dict(base.pivots_by_method),
        clamped=base.clamped,
    )
    out.pivots_by_method["closest"] = 0
    if S.size == 0:
        return out
    MS = M[:, S]
    N = dense.null_space(np.ascontiguousarray(MS), rank_rtol)  # (|S|, nullity)
    if N.shape[1] == 0:
        return out  # unique solution
    x0 = base.z[S]
    P = dense.matmul(N, np.ascontiguousarray(N.T))
    qq = x0 + dense.matvec(P, r[S] - x0)
    sub = solve_lcp(P, qq, method="dantzig", tol=tol)
    out.pivots_by_method["closest"] = sub.pivots
    out.pivots += sub.pivots
    if not sub.ok:
        out.message = f"projection LCP failed ({sub.status}); returning the pivoting solution"
        return out
    x = dense.matvec(P, sub.z) + qq
    # re-project onto x0 + range(N) to remove roundoff, then check feasibility
    x = x0 + dense.matvec(P, x - x0)
    z = np.zeros(n)
    z[S] = x
    vt = _verify_tol(M, q, z)
    w = dense.matvec(M, z) + q
    if np.min(x) < -vt or np.max(np.abs(w - base.w)) > 1e3 * vt:
        out.message = "closest solution failed the feasibility check; returning the pivoting solution"
        return out
    z[S] = np.maximum(x, 0.0)
    out.z = z
    out.w = dense.matvec(M, z) + q
    return out
