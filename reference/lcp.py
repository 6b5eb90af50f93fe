"""Linear complementarity solvers for the reference rigid-body contact solver.

The collision step of the reference solver (seed thesis, Section 3, eq. 3.5) asks
for contact impulses ``j`` with

.. math::

    v^+ = A j + b,\\quad j \\ge 0,\\quad v^+ + e v^- \\ge 0,\\quad
    j^\\top (v^+ + e v^-) = 0 .

Writing ``z = j``, ``w = v^+ + e v^-``, ``M = A`` and ``q = b + e v^-`` gives the
standard linear complementarity problem (LCP)

.. math::

    w = M z + q,\\quad z \\ge 0,\\quad w \\ge 0,\\quad z^\\top w = 0 .

For impacts ``M = J \\mathcal{M}^{-1} J^\\top`` is symmetric positive *semi*-definite and
frequently singular (more than six contacts, duplicated contact points), so the
solvers here are written to tolerate singular principal blocks.

Contents
--------
:class:`LCPResult`
    Solution container with complementarity diagnostics.
:func:`lemke`
    Lemke's complementary pivoting (covering vector ``d = 1``), tableau based, with
    lexicographic degeneracy resolution.
:func:`dantzig`
    Dantzig–Cottle principal pivoting in the form given by Baraff (1994).
:func:`solve_lcp`
    Dispatcher with warm start and fallback to the other method.
:func:`solve_lcp_min_norm`
    Among the (possibly many) solutions of a PSD LCP, the one closest to a reference.
:class:`FrictionResult`, :func:`solve_friction_cone`
    Resting contact with an exact circular Coulomb cone per contact (eqs. 3.6–3.7),
    solved by block projected Gauss–Seidel.
:func:`solve_friction_pyramid`
    Polyhedral (pyramid) approximation of the same problem cast as one LCP and solved
    by :func:`lemke`; used for cross-checking.

References
----------
D. Baraff, "Fast contact force computation for nonpenetrating rigid bodies",
SIGGRAPH 1994.  R. W. Cottle, J.-S. Pang, R. E. Stone, *The Linear Complementarity
Problem*, Academic Press 1992 (Lemke: Sec. 4.4; principal pivoting: Sec. 4.2).
D. E. Stewart, J. C. Trinkle, "An implicit time-stepping scheme for rigid body
dynamics with inelastic collisions and Coulomb friction", IJNME 1996 (pyramid LCP).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = [
    "FrictionResult",
    "LCPResult",
    "dantzig",
    "friction_residuals",
    "lemke",
    "solve_friction_cone",
    "solve_friction_pyramid",
    "solve_lcp",
    "solve_lcp_min_norm",
]

#: Relative tolerance of the final a-posteriori check of every LCP answer.
VERIFY_RTOL = 1e-9


# --------------------------------------------------------------------------------------
# result container
# --------------------------------------------------------------------------------------
@dataclass
class LCPResult:
    """Answer of an LCP solver for ``w = M z + q, z >= 0, w >= 0, z.w = 0``.

    Attributes
    ----------
    z : ndarray, shape (n,)
        Complementary variable (impulses / forces).
    w : ndarray, shape (n,)
        ``M z + q`` evaluated from ``z`` (not taken from a tableau).
    pivots : int
        Number of pivots performed by the method that produced this answer.
    status : str
        ``"ok"``; ``"max_pivots"`` (pivot cap reached); ``"singular"`` (a clamped
        subsystem could not be solved consistently, or the final a-posteriori check
        failed); ``"ray"`` (Lemke secondary-ray termination); ``"infeasible"``
        (Dantzig/Baraff found an unbounded driving direction, which for PSD ``M``
        proves infeasibility).
    method : str
        Name of the method that produced ``z`` (``"lemke"``, ``"dantzig"``,
        ``"trivial"``, ``"warm_start+dantzig"``, ... ; ``"+closest"`` is appended by
        :func:`solve_lcp_min_norm`).
    message : str
        Human readable detail for non-``ok`` answers.
    pivots_by_method : dict of str to int
        Pivots spent by every method tried (the dispatcher may try two).
    clamped : ndarray of int, shape (m,)
        Indices ``C`` treated as clamped (``w_C = 0``, ``z_C`` free) at termination.
    """

    z: np.ndarray
    w: np.ndarray
    pivots: int
    status: str
    method: str
    message: str = ""
    pivots_by_method: dict[str, int] = field(default_factory=dict)
    clamped: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))

    def residuals(self) -> dict[str, float]:
        """Complementarity diagnostics.

        Returns
        -------
        dict of str to float
            ``complementarity`` = max_i |z_i w_i|, ``z_negativity`` = max(0, -min z),
            ``w_negativity`` = max(0, -min w). All zero for an empty problem.
        """
        if self.z.size == 0:
            return {"complementarity": 0.0, "z_negativity": 0.0, "w_negativity": 0.0}
        return {
            "complementarity": float(np.max(np.abs(self.z * self.w))),
            "z_negativity": float(max(0.0, -np.min(self.z))),
            "w_negativity": float(max(0.0, -np.min(self.w))),
        }

    @property
    def ok(self) -> bool:
        """True when the solver terminated with a verified solution."""
        return self.status == "ok"


# --------------------------------------------------------------------------------------
# helpers
# --------------------------------------------------------------------------------------
def _as_problem(M: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    q = np.asarray(q, dtype=float).reshape(-1)
    n = q.size
    M = np.asarray(M, dtype=float)
    if M.size == 0 and n == 0:
        return np.zeros((0, 0)), q
    if M.shape != (n, n):
        raise ValueError(f"M must have shape ({n}, {n}), got {M.shape}")
    if not (np.all(np.isfinite(M)) and np.all(np.isfinite(q))):
        raise ValueError("M and q must be finite")
    return M, q


def _lstsq(A: np.ndarray, rhs: np.ndarray, rcond: float) -> np.ndarray:
    """Minimum-norm least-squares solve of ``A x = rhs`` (tolerates singular ``A``)."""
    if A.size == 0:
        return np.zeros(A.shape[1:] + rhs.shape[1:])
    return np.linalg.lstsq(A, rhs, rcond=rcond)[0]


def _scales(M: np.ndarray, q: np.ndarray) -> tuple[float, float]:
    m_scale = float(np.max(np.abs(M))) if M.size else 0.0
    q_scale = float(np.max(np.abs(q))) if q.size else 0.0
    return m_scale, q_scale


def _verify_tol(M: np.ndarray, q: np.ndarray, z: np.ndarray) -> float:
    """Absolute tolerance for the a-posteriori check: ``VERIFY_RTOL`` times the size of
    the terms in ``w = M z + q``."""
    m_scale, q_scale = _scales(M, q)
    z_scale = float(np.max(np.abs(z))) if z.size else 0.0
    return VERIFY_RTOL * max(1e-300, q_scale, m_scale * z_scale)


def _finish(
    M: np.ndarray,
    q: np.ndarray,
    z: np.ndarray,
    clamped: np.ndarray,
    *,
    pivots: int,
    status: str,
    method: str,
    message: str = "",
    rcond: float = 1e-12,
) -> LCPResult:
    """Polish and verify a candidate solution.

    One Newton correction on the clamped block (``z_C += lstsq(M_CC, -w_C)``) removes
    the drift accumulated by incremental pivot updates; it is accepted only if it
    keeps ``z_C`` non-negative and reduces ``|w_C|``.  Roundoff-level negatives are
    clipped, ``w`` is recomputed from ``z``, and an ``"ok"`` status is downgraded to
    ``"singular"`` if the result fails the check at :data:`VERIFY_RTOL`.
    """
    z = z.copy()
    if status == "ok":
        outside = np.ones(z.size, dtype=bool)
        outside[clamped] = False
        z[outside] = 0.0
        w = M @ z + q
        if clamped.size:
            C = clamped
            corr = _lstsq(M[np.ix_(C, C)], -w[C], rcond)
            z_try = z.copy()
            z_try[C] += corr
            w_try = M @ z_try + q
            vt = _verify_tol(M, q, z)
            if np.min(z_try[C]) >= -vt and np.max(np.abs(w_try[C])) <= np.max(np.abs(w[C])):
                z = z_try
    vt = _verify_tol(M, q, z)
    z = np.where((z < 0) & (z >= -vt), 0.0, z)
    w = M @ z + q
    res = LCPResult(
        z=z,
        w=w,
        pivots=pivots,
        status=status,
        method=method,
        message=message,
        pivots_by_method={method: pivots},
        clamped=np.asarray(clamped, dtype=int),
    )
    if status == "ok":
        vt = _verify_tol(M, q, z)
        r = res.residuals()
        # complementarity is a product; compare against the product scale
        w_scale = float(np.max(np.abs(w))) if w.size else 0.0
        z_scale = float(np.max(np.abs(z))) if z.size else 0.0
        c_tol = VERIFY_RTOL * max(1e-300, z_scale * max(w_scale, _scales(M, q)[1], 1e-300))
        if r["z_negativity"] > vt or r["w_negativity"] > vt or r["complementarity"] > c_tol:
            res.status = "singular"
            res.message = f"a-posteriori check failed: {r}"
    return res


def _trivial(M: np.ndarray, q: np.ndarray, method: str) -> LCPResult:
    return LCPResult(
        z=np.zeros(q.size),
        w=q.copy(),
        pivots=0,
        status="ok",
        method=method,
        pivots_by_method={method: 0},
    )


# --------------------------------------------------------------------------------------
# Lemke
# --------------------------------------------------------------------------------------
def lemke(M: np.ndarray, q: np.ndarray, *, max_pivots: int | None = None, tol: float = 1e-12) -> LCPResult:
    """Lemke's complementary pivoting algorithm with covering vector ``d = 1``.

    Solves ``w = M z + q, z >= 0, w >= 0, z.w = 0`` by pivoting in the augmented system
    ``w - M z - d z0 = q``.  The tableau is ``[I | -M | -d | q]`` with basic variables
    initially ``w``; the columns of the initial identity always hold the current basis
    inverse, which is used for the lexicographic minimum-ratio test (this makes every
    basis lexicographically non-degenerate, so the method cannot cycle).

    Steps: (1) if ``q >= 0`` return ``z = 0``; (2) ``z0`` enters, the row of the most
    negative ``q_i`` leaves (largest index among ties, which keeps the rows
    lexicographically positive); (3) the complement of the variable that just left
    enters; the leaving row is chosen by the lexicographic ratio test, preferring
    ``z0`` whenever it ties at the first level; (4) stop when ``z0`` leaves (solution)
    or when the entering column has no positive entry (secondary ray).  Lemke processes
    P-matrices and PSD (more generally copositive-plus) matrices: for those a ray
    proves the LCP infeasible.

    Parameters
    ----------
    M : array_like, shape (n, n)
        LCP matrix.
    q : array_like, shape (n,)
        LCP vector.
    max_pivots : int, optional
        Pivot cap; default ``50 (n + 1)``.
    tol : float
        Relative pivot / tie tolerance.

    Returns
    -------
    LCPResult
        ``method == "lemke"`` (``"trivial"`` when ``q >= 0``); status ``"ok"``,
        ``"ray"``, ``"max_pivots"`` or ``"singular"``.
    """
    M, q = _as_problem(M, q)
    n = q.size
    if n == 0 or np.all(q >= 0):
        res = _trivial(M, q, "lemke")
        res.method = "lemke" if n == 0 else "trivial"
        res.pivots_by_method = {"lemke": 0}
        return res
    if max_pivots is None:
        max_pivots = 50 * (n + 1)
    _, q_scale = _scales(M, q)
    z0 = 2 * n
    rhs = 2 * n + 1
    T = np.hstack([np.eye(n), -M, -np.ones((n, 1)), q[:, None]])
    basis = np.arange(n)  # variable ids: w_i -> i, z_i -> n + i, z0 -> 2n

    def pivot(r: int, c: int) -> None:
        T[r] /= T[r, c]
        col = T[:, c].copy()
        col[r] = 0.0
        T[...] -= np.outer(col, T[r])
        T[:, c] = 0.0
        T[r, c] = 1.0
        basis[r] = c

    # initial pivot: z0 enters, the most negative q leaves (largest index on ties)
    qmin = float(q.min())
    ties = np.flatnonzero(q <= qmin + tol * q_scale)
    r = int(ties.max())
    leaving = int(basis[r])
    pivot(r, z0)
    pivots = 1
    status, message = "max_pivots", f"no solution within {max_pivots} pivots"
    while pivots < max_pivots:
        entering = leaving + n if leaving < n else leaving - n
        col = T[:, entering]
        cand = np.flatnonzero(col > tol * max(1.0, float(np.max(np.abs(col)))))
        if cand.size == 0:
            status, message = "ray", f"secondary ray on entering variable {entering}"
            break
        r = _lex_min_ratio(T, col, cand, basis, n, rhs, z0, tol)
        leaving = int(basis[r])
        pivot(r, entering)
        pivots += 1
        if leaving == z0:
            status, message = "ok", ""
            break
    x = np.zeros(2 * n + 1)
    x[basis] = T[:, rhs]
    z = x[n : 2 * n]
    clamped = np.sort(basis[(basis >= n) & (basis < 2 * n)] - n)
    if status != "ok":
        # report the current (infeasible / incomplete) point without polishing
        return _finish(M, q, z, clamped, pivots=pivots, status=status, method="lemke", message=message)
    return _finish(M, q, z, clamped, pivots=pivots, status="ok", method="lemke")


def _lex_min_ratio(
    T: np.ndarray,
    col: np.ndarray,
    cand: np.ndarray,
    basis: np.ndarray,
    n: int,
    rhs: int,
    z0: int,
    tol: float,
) -> int:
    """Lexicographic minimum-ratio test over rows ``cand`` of the Lemke tableau.

    Row ``i`` ties with the minimum ratio ``r*`` when ``T[i, k] - r* col_i`` is within
    ``tol * max|T[:, k]|`` (roundoff of that tableau column), so near-degenerate
    right-hand sides produced by cancellation are treated as ties and resolved
    lexicographically instead of by noise.  Ties at the first level go to ``z0`` if
    it is among them; then the columns of the basis inverse (``T[:, :n]``) decide;
    the lowest row index breaks any remaining tie.
    """
    tie = cand
    for level, k in enumerate([rhs, *range(n)]):
        vals = T[tie, k]
        if k == rhs:
            vals = np.maximum(vals, 0.0)
        ratios = vals / col[tie]
        rmin = float(ratios.min())
        noise = tol * max(float(np.max(np.abs(T[:, k]))), 1e-300)
        tie = tie[vals - rmin * col[tie] <= noise]
        if level == 0 and tie.size > 1:
            z0_rows = tie[basis[tie] == z0]
            if z0_rows.size:
                return int(z0_rows[0])
        if tie.size == 1:
            break
    return int(tie.min())


# --------------------------------------------------------------------------------------
# Dantzig / Baraff principal pivoting
# --------------------------------------------------------------------------------------
def dantzig(
    M: np.ndarray,
    q: np.ndarray,
    *,
    max_pivots: int | None = None,
    tol: float = 1e-12,
    active_set: np.ndarray | None = None,
) -> LCPResult:
    """Dantzig–Cottle principal pivoting in the form of Baraff (1994).

    Every index is in one of three states: *clamped* ``C`` (``w_i = 0``, ``z_i >= 0``
    free), *unclamped* ``NC`` (``z_i = 0``, ``w_i >= 0``) or *not yet processed*
    (``z_i = 0``, ``w_i`` of any sign).  The algorithm, step by step:

    1. Start from ``z = 0``, ``w = q``, ``C = NC = {}`` (or from a warm ``active_set``,
       see below).  If ``w >= 0`` stop: ``z = 0`` is the solution.
    2. Pick the violated index ``d`` with the most negative ``w_d`` (lowest index on
       ties) and *drive it to zero*:

       a. Direction: ``dz_d = 1``; ``dz_C = -M_CC^+ M_Cd`` so that ``dw_C = 0`` (the
          clamped contacts stay at zero relative velocity); ``dz_i = 0`` elsewhere;
          ``dw = M dz``.  ``M_CC^+`` is applied by ``numpy.linalg.lstsq`` so a
          singular clamped block is tolerated.
       b. Largest step ``s >= 0`` such that nothing becomes infeasible:
          ``w_d`` reaches 0 (if ``dw_d > 0``), some clamped ``z_i`` reaches 0 (if
          ``dz_i < 0``), or some unclamped ``w_i`` reaches 0 (if ``dw_i < 0``).
          Ties prefer ``d`` itself (finishes the drive), then the lowest index
          (Bland-like rule against cycling).
       c. ``z += s dz``, ``w = M z + q``.  The blocking index changes state: a clamped
          one moves to ``NC``, an unclamped one to ``C``; if it is ``d``, ``d`` joins
          ``C`` and the drive ends.  Otherwise go back to (a) with the new sets.
       d. If no constraint blocks (``dw_d <= 0`` and nothing else limits ``s``), ``z``
          can grow without bound along a direction that never raises ``w_d``; for PSD
          ``M`` this proves the LCP infeasible -> status ``"infeasible"``.
    3. Repeat step 2 until no unclamped/unprocessed index has ``w_i < 0``.

    Each drive adds one index permanently to ``C ∪ NC`` while preserving the
    conditions of the indices already there, so at most ``n`` drives are needed;
    the number of pivots inside a drive is finite for P-matrices and PSD matrices
    (Cottle–Dantzig).  Baraff's observation for PSD ``M`` is that ``dw_d`` is the
    Schur complement of ``M_CC`` in ``M_{C+d, C+d}``, hence ``>= 0``; when it is zero
    (``d`` redundant with the clamped contacts, e.g. more than six contact points of one
    body) the step is limited by a clamped index leaving, i.e. the load is transferred
    between redundant contacts, exactly as in his paper.

    Parameters
    ----------
    M : array_like, shape (n, n)
        LCP matrix (P-matrix or positive semidefinite).
    q : array_like, shape (n,)
        LCP vector.
    max_pivots : int, optional
        Cap on the number of steps (2b); default ``50 (n + 1)``.
    tol : float
        Relative tolerance for sign tests, ties and ``lstsq`` truncation.
    active_set : array_like of int, optional
        Warm-start guess of ``C``.  ``z_C`` is solved from ``M_CC z_C = -q_C``;
        indices with negative ``z`` are dropped until ``z_C >= 0``; if the resulting
        clamped system is inconsistent the guess is discarded (cold start).

    Returns
    -------
    LCPResult
        ``method == "dantzig"`` (``"trivial"`` when ``q >= 0``, ``"warm_start+dantzig"``
        when an active set was used); status ``"ok"``, ``"infeasible"``,
        ``"max_pivots"`` or ``"singular"``.
    """
    M, q = _as_problem(M, q)
    n = q.size
    method = "dantzig"
    if n == 0:
        return _trivial(M, q, "dantzig")
    if max_pivots is None:
        max_pivots = 50 * (n + 1)
    m_scale, q_scale = _scales(M, q)
    rcond = max(tol, 10.0 * n * np.finfo(float).eps)
    eps_w = tol * max(m_scale, 1e-300)  # threshold on dw (per unit dz_d)
    UNPROC, CLAMP, UNCLAMP = 0, 1, 2
    state = np.zeros(n, dtype=np.int8)
    z = np.zeros(n)

    if active_set is not None:
        C = np.unique(np.asarray(active_set, dtype=int).reshape(-1))
        if C.size and (C.min() < 0 or C.max() >= n):
            raise ValueError("active_set indices out of range")
        for _ in range(n + 1):
            if C.size == 0:
                break
            zc = _lstsq(M[np.ix_(C, C)], -q[C], rcond)
            if np.all(zc >= 0):
                break
            C = C[zc >= 0]
        if C.size:
            z_try = np.zeros(n)
            z_try[C] = zc
            w_try = M @ z_try + q
            if np.max(np.abs(w_try[C])) <= 1e-9 * max(q_scale, m_scale * float(np.max(zc)), 1e-300):
                z = z_try
                state[C] = CLAMP
                method = "warm_start+dantzig"
    w = M @ z + q

    def w_tol() -> float:
        zs = float(np.max(np.abs(z))) if n else 0.0
        return tol * max(q_scale, m_scale * zs, 1e-300)

    if np.all(w >= -w_tol()) and not np.any(state == CLAMP):
        res = _trivial(M, q, "dantzig")
        res.method = "trivial"
        res.pivots_by_method = {"dantzig": 0}
        return res

    pivots = 0
    status, message = "ok", ""
    while status == "ok":
        viol = np.flatnonzero((state != CLAMP) & (w < -w_tol()))
        if viol.size == 0:
            break
        d = int(viol[np.argmin(w[viol])])
        state[d] = UNPROC
        while True:  # drive d to zero
            if pivots >= max_pivots:
                status, message = "max_pivots", f"no solution within {max_pivots} pivots"
                break
            C = np.flatnonzero(state == CLAMP)
            NC = np.flatnonzero(state == UNCLAMP)
            dz = np.zeros(n)
            dz[d] = 1.0
            if C.size:
                MCC = M[np.ix_(C, C)]
                dz[C] = -_lstsq(MCC, M[C, d], rcond)
                resid = MCC @ dz[C] + M[C, d]
                if np.max(np.abs(resid)) > 1e-8 * max(m_scale * float(np.max(np.abs(dz))), 1e-300):
                    status = "singular"
                    message = "clamped subsystem is singular and inconsistent"
                    break
            dw = M @ dz
            eps_z = tol * max(1.0, float(np.max(np.abs(dz))))
            idx: list[np.ndarray] = []
            steps: list[np.ndarray] = []
            if dw[d] > eps_w:
                idx.append(np.array([d]))
                steps.append(np.array([-w[d] / dw[d]]))
            if C.size:
                m = dz[C] < -eps_z
                idx.append(C[m])
                steps.append(-z[C[m]] / dz[C[m]])
            if NC.size:
                m = dw[NC] < -eps_w
                idx.append(NC[m])
                steps.append(-w[NC[m]] / dw[NC[m]])
            all_idx = np.concatenate(idx) if idx else np.zeros(0, dtype=int)
            all_s = np.maximum(np.concatenate(steps), 0.0) if steps else np.zeros(0)
            if all_idx.size == 0:
                status = "infeasible"
                message = (
                    f"unbounded driving direction for index {d}: no solution "
                    "(conclusive for PSD / P-matrices only)"
                )
                break
            smin = float(all_s.min())
            tie = all_idx[all_s <= smin + tol * max(1.0, smin)]
            j = d if d in tie else int(tie.min())
            s = smin if j != d else float(all_s[all_idx == d][0])
            s = max(s, 0.0)
            z += s * dz
            pivots += 1
            if state[j] == CLAMP and j != d:
                state[j] = UNCLAMP
                z[j] = 0.0
            elif state[j] == UNCLAMP:
                state[j] = CLAMP
            else:  # j == d
                state[d] = CLAMP
            # indices outside C and d carry z = 0 exactly
            z[(state != CLAMP) & (np.arange(n) != d)] = 0.0
            np.maximum(z, 0.0, out=z)
            w = M @ z + q
            if j == d:
                break
    clamped = np.flatnonzero(state == CLAMP)
    return _finish(
        M, q, z, clamped, pivots=pivots, status=status, method=method, message=message, rcond=rcond
    )


# --------------------------------------------------------------------------------------
# dispatcher
# --------------------------------------------------------------------------------------
_METHODS = {"dantzig": dantzig, "lemke": lemke}


def solve_lcp(
    M: np.ndarray,
    q: np.ndarray,
    *,
    method: str = "dantzig",
    warm_start: np.ndarray | None = None,
    max_pivots: int | None = None,
    tol: float = 1e-12,
    fallback: bool = True,
    reference: np.ndarray | None = None,
    select: str | None = None,
) -> LCPResult:
    """Solve an LCP with one method and fall back to the other on failure.

    Parameters
    ----------
    M : array_like, shape (n, n)
        LCP matrix.
    q : array_like, shape (n,)
        LCP vector.
    method : {"dantzig", "lemke"}
        Primary method.
    warm_start : array_like, shape (n,), optional
        Previous solution ``z``; its support ``{i : z_i > 0}`` is used as the initial
        clamped set of :func:`dantzig` (ignored by Lemke, which has no warm start).
    max_pivots, tol
        Passed to the methods.
    fallback : bool
        Try the other method when the primary one does not return ``"ok"``.
    reference : array_like, shape (n,), optional
        Reference for ``select="closest"``.
    select : {None, "closest", "min_norm"}
        ``None`` returns whatever vertex the pivoting produced; ``"closest"`` /
        ``"min_norm"`` post-process with :func:`solve_lcp_min_norm` (``min_norm`` uses
        reference zero).

    Returns
    -------
    LCPResult
        ``method`` names the answering method; ``pivots_by_method`` lists the pivots of
        every method tried.  If both fail, the primary answer is returned.
    """
    if method not in _METHODS:
        raise ValueError(f"unknown method {method!r}; use 'dantzig' or 'lemke'")
    M, q = _as_problem(M, q)
    if select is not None:
        if select not in ("closest", "min_norm"):
            raise ValueError(f"unknown select {select!r}")
        ref = None if select == "min_norm" else reference
        return solve_lcp_min_norm(
            M, q, reference=ref, method=method, tol=tol, max_pivots=max_pivots, warm_start=warm_start
        )
    kwargs: dict = {"max_pivots": max_pivots, "tol": tol}
    if method == "dantzig" and warm_start is not None:
        ws = np.asarray(warm_start, dtype=float).reshape(-1)
        if ws.size != q.size:
            raise ValueError("warm_start has the wrong size")
        kwargs["active_set"] = np.flatnonzero(ws > 0)
    primary = _METHODS[method](M, q, **kwargs)
    tried = {method: primary.pivots}
    if primary.ok or not fallback:
        primary.pivots_by_method = tried
        return primary
    other = "lemke" if method == "dantzig" else "dantzig"
    secondary = _METHODS[other](M, q, max_pivots=max_pivots, tol=tol)
    tried[other] = secondary.pivots
    best = secondary if secondary.ok else primary
    best.pivots_by_method = tried
    if secondary.ok:
        best.message = f"fallback after {method}: {primary.status} ({primary.message})"
    return best


# --------------------------------------------------------------------------------------
# selection among non-unique solutions
# --------------------------------------------------------------------------------------
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
    _, sv, Vt = np.linalg.svd(MS, full_matrices=True)
    rank = int(np.sum(sv > rank_rtol * (sv[0] if sv.size else 0.0))) if sv.size else 0
    N = Vt[rank:].T  # (|S|, nullity)
    if N.shape[1] == 0:
        return out  # unique solution
    x0 = base.z[S]
    P = N @ N.T
    qq = x0 + P @ (r[S] - x0)
    sub = solve_lcp(P, qq, method="dantzig", tol=tol)
    out.pivots_by_method["closest"] = sub.pivots
    out.pivots += sub.pivots
    if not sub.ok:
        out.message = f"projection LCP failed ({sub.status}); returning the pivoting solution"
        return out
    x = P @ sub.z + qq
    # re-project onto x0 + range(N) to remove roundoff, then check feasibility
    x = x0 + P @ (x - x0)
    z = np.zeros(n)
    z[S] = x
    vt = _verify_tol(M, q, z)
    w = M @ z + q
    if np.min(x) < -vt or np.max(np.abs(w - base.w)) > 1e3 * vt:
        out.message = "closest solution failed the feasibility check; returning the pivoting solution"
        return out
    z[S] = np.maximum(x, 0.0)
    out.z = z
    out.w = M @ z + q
    return out


# --------------------------------------------------------------------------------------
# friction
# --------------------------------------------------------------------------------------
@dataclass
class FrictionResult:
    """Resting-contact forces with Coulomb friction (eqs. 3.6–3.7).

    Attributes
    ----------
    f : ndarray, shape (3k,)
        Contact forces, per contact ``(f_n, f_x, f_y)``.
    a : ndarray, shape (3k,)
        Relative accelerations ``A f + b``, per contact ``(a_n, a_x, a_y)``.
    iterations : int
        Gauss–Seidel sweeps (or Lemke pivots for the pyramid variant).
    converged : bool
        Stopping criterion met within the iteration cap.
    residuals : dict of str to float
        See :func:`friction_residuals`.
    mu : ndarray, shape (k,)
        Friction coefficients used.
    method : str
        ``"pgs_cone"`` or ``"lemke_pyramid"``.
    status : str
        ``"ok"`` when converged, otherwise ``"max_iter"`` / an LCP status.
    """

    f: np.ndarray
    a: np.ndarray
    iterations: int
    converged: bool
    residuals: dict[str, float]
    mu: np.ndarray
    method: str
    status: str = "ok"

    @property
    def normal(self) -> np.ndarray:
        """Normal forces, shape (k,)."""
        return self.f[0::3].copy()

    @property
    def tangential(self) -> np.ndarray:
        """Tangential forces, shape (k, 2)."""
        return self.f.reshape(-1, 3)[:, 1:].copy()

    @property
    def ok(self) -> bool:
        """True when the solve converged."""
        return self.converged


def _mu_vector(mu: float | np.ndarray, k: int) -> np.ndarray:
    mu_arr = np.asarray(mu, dtype=float).reshape(-1)
    if mu_arr.size == 1:
        mu_arr = np.full(k, float(mu_arr[0]))
    if mu_arr.size != k or np.any(mu_arr < 0):
        raise ValueError(f"mu must be a non-negative scalar or have {k} entries")
    return mu_arr


def friction_residuals(f: np.ndarray, a: np.ndarray, mu: np.ndarray) -> dict[str, float]:
    """Violation of eqs. 3.6–3.7 (all zero at an exact solution).

    Parameters
    ----------
    f, a : ndarray, shape (3k,)
        Forces and accelerations, per contact ``(n, x, y)``.
    mu : ndarray, shape (k,)
        Friction coefficients.

    Returns
    -------
    dict of str to float
        ``signorini_f`` = max(0, -min f_n); ``signorini_a`` = max(0, -min a_n);
        ``complementarity`` = max |f_n a_n|; ``cone`` = max(0, |f_t| - mu f_n);
        ``friction_complementarity`` = max |a_t| (mu f_n - |f_t|) (sliding => maximal);
        ``dissipation`` = max (f_t.a_t + |f_t||a_t|) (zero iff f_t opposes a_t).
    """
    F = f.reshape(-1, 3)
    Acc = a.reshape(-1, 3)
    if F.shape[0] == 0:
        keys = (
            "signorini_f",
            "signorini_a",
            "complementarity",
            "cone",
            "friction_complementarity",
            "dissipation",
        )
        return dict.fromkeys(keys, 0.0)
    fn, ft = F[:, 0], F[:, 1:]
    an, at = Acc[:, 0], Acc[:, 1:]
    ft_norm = np.linalg.norm(ft, axis=1)
    at_norm = np.linalg.norm(at, axis=1)
    return {
        "signorini_f": float(max(0.0, -fn.min())),
        "signorini_a": float(max(0.0, -an.min())),
        "complementarity": float(np.max(np.abs(fn * an))),
        "cone": float(max(0.0, np.max(ft_norm - mu * fn))),
        "friction_complementarity": float(np.max(np.abs(at_norm * (mu * fn - ft_norm)))),
        "dissipation": float(max(0.0, np.max(np.sum(ft * at, axis=1) + ft_norm * at_norm))),
    }


def _disc_local_solve(lam: np.ndarray, Q: np.ndarray, c: np.ndarray, radius: float) -> np.ndarray:
    """Exact solution of the single-contact tangential problem.

    Find ``f_t`` with ``a_t = Att f_t + c``, ``|f_t| <= radius`` and either ``a_t = 0``
    (stick) or ``f_t = -radius a_t/|a_t|`` (slide), where ``Att = Q diag(lam) Q^T``.
    Sticking is tried first; if it leaves the disc, ``f_t(g) = -(Att + g I)^-1 c``
    with the unique ``g > 0`` such that ``|f_t(g)| = radius`` (the trust-region secular
    equation), solved by safeguarded Newton on ``1/|f(g)| - 1/radius``
    (Moré–Sorensen); then ``a_t = -g f_t`` opposes ``f_t``.

    Parameters
    ----------
    lam : ndarray, shape (2,)
        Eigenvalues of ``Att`` (clipped at 0), ascending.
    Q : ndarray, shape (2, 2)
        Eigenvectors of ``Att``.
    c : ndarray, shape (2,)
        Tangential acceleration at ``f_t = 0``.
    radius : float
        ``mu f_n``.

    Returns
    -------
    ndarray, shape (2,)
        Tangential force.
    """
    if radius <= 0.0:
        return np.zeros(2)
    ct = Q.T @ c
    c_norm = float(np.hypot(ct[0], ct[1]))
    if c_norm == 0.0:
        return np.zeros(2)
    lam_max = max(float(lam[1]), 1e-300)
    if lam[0] > 1e-14 * lam_max:
        ft = -(ct / lam)
        if np.hypot(ft[0], ft[1]) <= radius:
            return Q @ ft
    lo, hi = 0.0, c_norm / radius  # |f(hi)| <= |c| / hi = radius
    g = 0.0 if lam[0] > 1e-14 * lam_max else 0.5 * hi
    for _ in range(100):
        d = lam + g
        fk = ct / d
        nf = float(np.hypot(fk[0], fk[1]))
        phi = 1.0 / nf - 1.0 / radius
        if phi < 0.0:
            lo = g
        else:
            hi = g
        if abs(phi) <= 1e-15 / radius or hi - lo <= 1e-15 * hi:
            break
        dphi = float(np.sum(ct * ct / d**3)) / nf**3
        g_new = g - phi / dphi if dphi > 0 else 0.5 * (lo + hi)
        if not (lo < g_new < hi):
            g_new = 0.5 * (lo + hi)
        g = g_new
    ft = -(ct / (lam + g))
    ft *= radius / float(np.hypot(ft[0], ft[1]))
    return Q @ ft


def _friction_merit(f: np.ndarray, a: np.ndarray, mu: np.ndarray, fs: float, acs: float) -> float:
    """Largest residual of :func:`friction_residuals`, made dimensionless."""
    r = friction_residuals(f, a, mu)
    return max(
        r["signorini_f"] / fs,
        r["cone"] / fs,
        r["signorini_a"] / acs,
        r["complementarity"] / (fs * acs),
        r["friction_complementarity"] / (fs * acs),
        r["dissipation"] / (fs * acs),
    )


def _mode_polish(A: np.ndarray, b: np.ndarray, f: np.ndarray, mu: np.ndarray) -> np.ndarray:
    """Least-change correction that enforces the current contact modes exactly.

    From the iterate, each contact is *open* (``f_n == 0``: no unknowns),
    *sticking* (``|f_t| < mu f_n``: unknowns ``f``, equations ``a = 0``) or
    *sliding* (``|f_t| = mu f_n``: unknown ``f_n`` with ``f_t = mu f_n s``, ``s`` the
    current direction frozen; equation ``a_n = 0``).  The linear equations are solved
    for the minimum-norm change of the unknowns (``lstsq``); contacts whose normal
    force would become negative are opened and the solve repeated.  This removes the slow
    drift of Gauss–Seidel along null-space directions of a singular ``A``.  The caller
    accepts the candidate only if it lowers the residual merit.

    Parameters
    ----------
    A : ndarray, shape (3k, 3k)
    b : ndarray, shape (3k,)
    f : ndarray, shape (3k,)
        Current forces.
    mu : ndarray, shape (k,)

    Returns
    -------
    ndarray, shape (3k,)
        Candidate forces.
    """
    k = f.size // 3
    is_open = f.reshape(-1, 3)[:, 0] <= 0.0
    cand = f.copy()
    for _ in range(k):
        cand = _mode_polish_once(A, b, f, mu, is_open)
        fn = cand.reshape(-1, 3)[:, 0]
        neg = (fn < 0.0) & ~is_open
        if not np.any(neg):
            break
        is_open |= neg  # contacts pulled into tension open; re-solve without them
    return cand


def _mode_polish_once(
    A: np.ndarray, b: np.ndarray, f: np.ndarray, mu: np.ndarray, is_open: np.ndarray
) -> np.ndarray:
    """One least-change solve of :func:`_mode_polish` with the open set fixed."""
    k = f.size // 3
    F = f.reshape(-1, 3)
    cols: list[np.ndarray] = []
    rows: list[int] = []
    base = f.copy()
    for i in range(k):
        fn = F[i, 0]
        if is_open[i]:
            base[3 * i : 3 * i + 3] = 0.0
            continue
        ft = F[i, 1:]
        nt = float(np.hypot(ft[0], ft[1]))
        if nt < mu[i] * fn * (1.0 - 1e-9):
            for j in range(3):
                g = np.zeros(3 * k)
                g[3 * i + j] = 1.0
                cols.append(g)
            rows.extend([3 * i, 3 * i + 1, 3 * i + 2])
        else:
            g = np.zeros(3 * k)
            g[3 * i] = 1.0
            if nt > 0.0:
                g[3 * i + 1 : 3 * i + 3] = ft / nt * mu[i]
            cols.append(g)
            rows.append(3 * i)
    if not cols:
        return base
    Gm = np.array(cols).T  # (3k, m) maps unknown changes to force changes
    a = A @ base + b
    E = (A @ Gm)[rows]
    dx = np.linalg.lstsq(E, -a[rows], rcond=1e-12)[0]
    return base + Gm @ dx


def solve_friction_cone(
    A: np.ndarray,
    b: np.ndarray,
    mu: float | np.ndarray,
    *,
    tol: float = 1e-12,
    max_iter: int = 10000,
    warm_start: np.ndarray | None = None,
    restart_after: int | None = 500,
) -> FrictionResult:
    """Resting contact forces with an exact circular friction cone (eqs. 3.6–3.7).

    Finds ``f`` with ``a = A f + b`` and, per contact ``i``:
    ``f_n >= 0, a_n >= 0, f_n a_n = 0``; ``|f_t| <= mu f_n``; ``f_t . a_t <= 0`` and
    ``|a_t| (mu f_n - |f_t|) = 0`` (static friction; sliding friction is maximal and
    opposes the tangential acceleration).

    Method: block (per-contact) nonlinear Gauss–Seidel.  For each contact in turn,
    with the other contacts' forces frozen:

    1. normal: ``f_n <- max(0, f_n - a_n / A_nn)`` (exact 1-D Signorini solve);
    2. tangential: with radius ``mu f_n`` (new ``f_n``), solve the 2-D problem exactly
       (:func:`_disc_local_solve`): stick if the sticking force lies in the disc,
       otherwise the disc-boundary force whose resulting ``a_t`` is anti-parallel.

    Every 25 sweeps a contact-mode polish (:func:`_mode_polish`) is tried and kept
    only if it lowers the residual merit; it removes the slow drift of load between
    redundant contacts (singular ``A``) that plain Gauss–Seidel suffers from.
    If the iteration has not converged after ``restart_after`` sweeps it is restarted
    once from the solution of the 16-facet pyramid LCP (:func:`solve_friction_pyramid`,
    Lemke), which is usually within the facet error of the cone solution; the sweep
    count keeps running, so ``max_iter`` caps the total.
    ``a`` is updated incrementally.  A sweep's fixed point satisfies all the
    conditions above; the iteration stops when the largest force change of a sweep is
    ``<= tol * max(|f|_inf, |b| / |A|)`` (relative), after which ``a`` is recomputed and
    the residuals are evaluated.  Contacts with ``A_nn == 0`` receive no force.
    Convergence of Gauss–Seidel for the (non-associated) Coulomb problem is not
    guaranteed in general but is robust for the single-body resting contacts used
    here; check ``converged`` and ``residuals``.

    Parameters
    ----------
    A : array_like, shape (3k, 3k)
        PSD Delassus matrix, per contact order ``(n, x, y)``.
    b : array_like, shape (3k,)
        Free accelerations.
    mu : float or array_like, shape (k,)
        Friction coefficients.
    tol : float
        Relative stopping tolerance on the sweep-to-sweep change of ``f``.
    max_iter : int
        Maximum number of sweeps.
    warm_start : array_like, shape (3k,), optional
        Initial forces (projected onto the cones first).
    restart_after : int or None
        Sweeps before the one-time restart from the pyramid-LCP solution; ``None``
        disables it.

    Returns
    -------
    FrictionResult
        ``method == "pgs_cone"``, or ``"pgs_cone+pyramid_restart"`` when the restart
        was used.
    """
    A = np.asarray(A, dtype=float)
    b = np.asarray(b, dtype=float).reshape(-1)
    if b.size % 3 or A.shape != (b.size, b.size):
        raise ValueError("A must be (3k, 3k) and b (3k,)")
    k = b.size // 3
    mu_arr = _mu_vector(mu, k)
    f = np.zeros(3 * k)
    if warm_start is not None:
        f = np.asarray(warm_start, dtype=float).reshape(-1).copy()
        if f.size != 3 * k:
            raise ValueError("warm_start has the wrong size")
        F = f.reshape(-1, 3)
        F[:, 0] = np.maximum(F[:, 0], 0.0)
        nt = np.linalg.norm(F[:, 1:], axis=1)
        over = nt > mu_arr * F[:, 0]
        F[over, 1:] *= (mu_arr[over] * F[over, 0] / nt[over])[:, None]
    if k == 0:
        return FrictionResult(
            f=f,
            a=b.copy(),
            iterations=0,
            converged=True,
            residuals=friction_residuals(f, b, mu_arr),
            mu=mu_arr,
            method="pgs_cone",
        )
    a = A @ f + b
    a_scale = float(np.max(np.abs(A))) if A.size else 0.0
    force_scale = float(np.max(np.abs(b))) / a_scale if a_scale > 0 else 0.0
    diag_n = np.array([A[3 * i, 3 * i] for i in range(k)])
    active = diag_n > 1e-14 * max(a_scale, 1e-300)
    Att = [A[3 * i + 1 : 3 * i + 3, 3 * i + 1 : 3 * i + 3] for i in range(k)]
    eig_lam, eig_Q = [], []
    for i in range(k):
        lam_i, Q_i = np.linalg.eigh(0.5 * (Att[i] + Att[i].T))
        eig_lam.append(np.maximum(lam_i, 0.0))
        eig_Q.append(Q_i)
    acc_scale = max(float(np.max(np.abs(b))), 1e-300)
    polish_every = 25
    converged = False
    it = 0
    method = "pgs_cone"
    for it in range(1, max_iter + 1):
        if restart_after is not None and it == restart_after + 1:
            pyr = solve_friction_pyramid(A, b, mu_arr, n_facets=16)
            if pyr.converged:
                f = pyr.f.copy()
                a = A @ f + b
                method = "pgs_cone+pyramid_restart"
        if it % polish_every == 0:
            fs = max(float(np.max(np.abs(f))), force_scale, 1e-300)
            cand = _mode_polish(A, b, f, mu_arr)
            a_c = A @ cand + b
            a = A @ f + b
            if _friction_merit(cand, a_c, mu_arr, fs, acc_scale) < _friction_merit(
                f, a, mu_arr, fs, acc_scale
            ):
                f, a = cand, a_c
        max_change = 0.0
        for i in range(k):
            rn = 3 * i
            if not active[i]:
                if np.any(f[rn : rn + 3] != 0.0):
                    a -= A[:, rn : rn + 3] @ f[rn : rn + 3]
                    f[rn : rn + 3] = 0.0
                continue
            fn_new = max(0.0, f[rn] - a[rn] / diag_n[i])
            dfn = fn_new - f[rn]
            if dfn != 0.0:
                a += A[:, rn] * dfn
                f[rn] = fn_new
            ft_old = f[rn + 1 : rn + 3].copy()
            c = a[rn + 1 : rn + 3] - Att[i] @ ft_old
            ft_new = _disc_local_solve(eig_lam[i], eig_Q[i], c, mu_arr[i] * fn_new)
            dft = ft_new - ft_old
            if np.any(dft != 0.0):
                a += A[:, rn + 1 : rn + 3] @ dft
                f[rn + 1 : rn + 3] = ft_new
            max_change = max(max_change, abs(dfn), float(np.max(np.abs(dft))))
        f_scale = max(float(np.max(np.abs(f))), force_scale, 1e-300)
        if max_change <= tol * f_scale:
            converged = True
            break
    a = A @ f + b
    return FrictionResult(
        f=f,
        a=a,
        iterations=it,
        converged=converged,
        residuals=friction_residuals(f, a, mu_arr),
        mu=mu_arr,
        method=method,
        status="ok" if converged else "max_iter",
    )


def solve_friction_pyramid(
    A: np.ndarray,
    b: np.ndarray,
    mu: float | np.ndarray,
    *,
    n_facets: int = 8,
    max_pivots: int | None = None,
    tol: float = 1e-12,
) -> FrictionResult:
    """Friction-pyramid LCP (Stewart–Trinkle form) solved with :func:`lemke`.

    The disc ``|f_t| <= mu f_n`` is replaced by the polygon spanned by ``n_facets``
    unit directions ``d_j = (cos 2 pi j/m, sin 2 pi j/m)``: ``f_t = D beta``,
    ``beta >= 0``.  With a slack ``lam`` per contact (the magnitude of the sliding
    acceleration) the conditions become the LCP

    * ``a_n = (A f + b)_n >= 0``  ⟂ ``f_n >= 0``,
    * ``D^T a_t + lam e >= 0``    ⟂ ``beta >= 0``,
    * ``mu f_n - e^T beta >= 0``  ⟂ ``lam >= 0``,

    whose matrix is not symmetric (copositive-plus only in special cases), so Lemke
    is used.  With ``n_facets`` a multiple of 4 the pyramid contains the ``x`` and
    ``y`` directions exactly; use it to cross-check :func:`solve_friction_cone`.

    Parameters
    ----------
    A : array_like, shape (3k, 3k)
        Delassus matrix, per contact ``(n, x, y)``.
    b : array_like, shape (3k,)
        Free accelerations.
    mu : float or array_like, shape (k,)
        Friction coefficients.
    n_facets : int
        Number of pyramid directions ``m >= 3``.
    max_pivots, tol
        Passed to :func:`lemke`.

    Returns
    -------
    FrictionResult
        ``f`` and ``a`` in the ``(n, x, y)`` layout; ``iterations`` = Lemke pivots;
        residuals measured against the *circular* cone (so ``friction_complementarity``
        and ``dissipation`` reflect the facet approximation).
    """
    A = np.asarray(A, dtype=float)
    b = np.asarray(b, dtype=float).reshape(-1)
    if b.size % 3 or A.shape != (b.size, b.size):
        raise ValueError("A must be (3k, 3k) and b (3k,)")
    if n_facets < 3:
        raise ValueError("n_facets must be >= 3")
    k = b.size // 3
    mu_arr = _mu_vector(mu, k)
    m = n_facets
    ang = 2.0 * np.pi * np.arange(m) / m
    D = np.vstack([np.cos(ang), np.sin(ang)])  # (2, m)
    nv = k * (1 + m)  # (f_n, beta) per contact
    H = np.zeros((3 * k, nv))  # f = H x
    for i in range(k):
        H[3 * i, i * (1 + m)] = 1.0
        H[3 * i + 1 : 3 * i + 3, i * (1 + m) + 1 : (i + 1) * (1 + m)] = D
    L = np.zeros((nv + k, nv + k))
    L[:nv, :nv] = H.T @ A @ H
    for i in range(k):
        beta = slice(i * (1 + m) + 1, (i + 1) * (1 + m))
        L[beta, nv + i] = 1.0
        L[nv + i, i * (1 + m)] = mu_arr[i]
        L[nv + i, beta] = -1.0
    qq = np.concatenate([H.T @ b, np.zeros(k)])
    res = lemke(L, qq, max_pivots=max_pivots, tol=tol)
    f = H @ res.z[:nv]
    a = A @ f + b
    return FrictionResult(
        f=f,
        a=a,
        iterations=res.pivots,
        converged=res.ok,
        residuals=friction_residuals(f, a, mu_arr),
        mu=mu_arr,
        method="lemke_pyramid",
        status=res.status,
    )
