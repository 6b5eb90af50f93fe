"""Pivoting LCP solvers: Lemke and Dantzig–Cottle/Baraff (seed paper, eq. 3.5).

The collision step of the reference solver (Section 3, eq. 3.5) asks for contact impulses
``j`` with

.. math::

    v^+ = A j + b,\\quad j \\ge 0,\\quad v^+ + e v^- \\ge 0,\\quad
    j^\\top (v^+ + e v^-) = 0 .

Writing ``z = j``, ``w = v^+ + e v^-``, ``M = A`` and ``q = b + e v^-`` gives the standard
linear complementarity problem (LCP)

.. math::

    w = M z + q,\\quad z \\ge 0,\\quad w \\ge 0,\\quad z^\\top w = 0 ,

which the paper solves "using the Dantzig's algorithm (Cottle et al., 1968)":
:func:`dantzig` below, in Baraff's (1994) form.  :func:`lemke` is the other classical
pivoting method (used as fallback and for the non-symmetric LCPs of the friction pyramid).
For impacts ``M = J M⁻¹ Jᵀ`` is symmetric positive *semi*-definite and frequently singular
(more than six contacts, duplicated contact points), so both tolerate singular principal
blocks.

Contents: :class:`LCPResult`, :func:`lemke`, :func:`dantzig`, :func:`solve_lcp`
(dispatcher with warm start and fallback to the other method).

References
----------
D. Baraff, "Fast contact force computation for nonpenetrating rigid bodies", SIGGRAPH 1994.
R. W. Cottle, J.-S. Pang, R. E. Stone, *The Linear Complementarity Problem*, Academic Press
1992 (Lemke: Sec. 4.4; principal pivoting: Sec. 4.2).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numba import njit

from pbr_xval.reference import dense

__all__ = ["VERIFY_RTOL", "LCPResult", "dantzig", "lemke", "solve_lcp"]

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
    return dense.lstsq(np.ascontiguousarray(A, dtype=float), np.ascontiguousarray(rhs, dtype=float), rcond)


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
        w = dense.matvec(M, z) + q
        if clamped.size:
            C = clamped
            corr = _lstsq(M[np.ix_(C, C)], -w[C], rcond)
            z_try = z.copy()
            z_try[C] += corr
            w_try = dense.matvec(M, z_try) + q
            vt = _verify_tol(M, q, z)
            if np.min(z_try[C]) >= -vt and np.max(np.abs(w_try[C])) <= np.max(np.abs(w[C])):
                z = z_try
    vt = _verify_tol(M, q, z)
    z = np.where((z < 0) & (z >= -vt), 0.0, z)
    w = dense.matvec(M, z) + q
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
    rhs = 2 * n + 1
    T = np.hstack([np.eye(n), -M, -np.ones((n, 1)), q[:, None]])
    basis = np.arange(n)  # variable ids: w_i -> i, z_i -> n + i, z0 -> 2n
    # the pivoting loop, compiled (:func:`_lemke_loop`: the same arithmetic as the NumPy
    # version it replaced, bit for bit)
    code, pivots, entering = _lemke_loop(T, basis, q, float(q_scale), int(max_pivots), float(tol))
    status, message = "max_pivots", f"no solution within {max_pivots} pivots"
    if code == 1:
        status, message = "ok", ""
    elif code == 2:
        status, message = "ray", f"secondary ray on entering variable {entering}"
    x = np.zeros(2 * n + 1)
    x[basis] = T[:, rhs]
    z = x[n : 2 * n]
    clamped = np.sort(basis[(basis >= n) & (basis < 2 * n)] - n)
    if status != "ok":
        # report the current (infeasible / incomplete) point without polishing
        return _finish(M, q, z, clamped, pivots=pivots, status=status, method="lemke", message=message)
    return _finish(M, q, z, clamped, pivots=pivots, status="ok", method="lemke")


@njit(cache=True)
def _lemke_loop(T, basis, q, q_scale, max_pivots, tol):  # pragma: no cover - compiled
    """Lemke's pivots on the tableau ``T`` (n, 2n + 2) and ``basis`` (n,), in place: the
    initial pivot (z0 enters, the most negative q leaves, largest index on ties), then
    complementary pivots with the lexicographic ratio test of :func:`_lex_min_ratio_c`.
    Returns (code: 1 z0 left (solution), 2 secondary ray, 0 pivot cap; pivots; the last
    entering variable)."""
    n = basis.size
    z0 = 2 * n
    rhs = 2 * n + 1
    qmin = np.inf
    for i in range(n):
        qmin = min(qmin, q[i])
    r = -1
    for i in range(n):
        if q[i] <= qmin + tol * q_scale:
            r = i
    leaving = basis[r]
    _lemke_pivot(T, basis, r, z0)
    pivots = 1
    entering = -1
    cand = np.empty(n, dtype=np.int64)
    while pivots < max_pivots:
        entering = leaving + n if leaving < n else leaving - n
        cmax = 0.0
        for i in range(n):
            cmax = max(cmax, abs(T[i, entering]))
        thr = tol * max(1.0, cmax)
        m = 0
        for i in range(n):
            if T[i, entering] > thr:
                cand[m] = i
                m += 1
        if m == 0:
            return 2, pivots, entering
        r = _lex_min_ratio_c(T, entering, cand[:m].copy(), basis, n, rhs, z0, tol)
        leaving = basis[r]
        _lemke_pivot(T, basis, r, entering)
        pivots += 1
        if leaving == z0:
            return 1, pivots, entering
    return 0, pivots, entering


@njit(cache=True)
def _lemke_pivot(T, basis, r, c):  # pragma: no cover - compiled
    """T[r] /= T[r, c]; T -= outer(column c with row r zeroed, T[r]); column c := e_r."""
    rows, cols = T.shape
    piv = T[r, c]
    for j in range(cols):
        T[r, j] /= piv
    col = T[:, c].copy()
    col[r] = 0.0
    for i in range(rows):
        ci = col[i]
        for j in range(cols):
            T[i, j] -= ci * T[r, j]
    for i in range(rows):
        T[i, c] = 0.0
    T[r, c] = 1.0
    basis[r] = c


@njit(cache=True)
def _lex_min_ratio_c(T, c, cand, basis, n, rhs, z0, tol):  # pragma: no cover - compiled
    """Lexicographic minimum-ratio test over rows ``cand`` of the Lemke tableau, entering
    column ``c``.

    Row ``i`` ties with the minimum ratio ``r*`` when ``T[i, k] - r* T[i, c]`` is within
    ``tol * max|T[:, k]|`` (roundoff of that tableau column), so near-degenerate
    right-hand sides produced by cancellation are treated as ties and resolved
    lexicographically instead of by noise.  Ties at the first level go to ``z0`` if
    it is among them; then the columns of the basis inverse (``T[:, :n]``) decide;
    the lowest row index breaks any remaining tie.
    """
    tie = cand
    for level in range(n + 1):
        k = rhs if level == 0 else level - 1
        m = tie.size
        vals = np.empty(m)
        rmin = np.inf
        for a in range(m):
            v = T[tie[a], k]
            if k == rhs:
                v = max(v, 0.0)
            vals[a] = v
            rmin = min(rmin, v / T[tie[a], c])
        tmax = 0.0
        for i in range(T.shape[0]):
            tmax = max(tmax, abs(T[i, k]))
        noise = tol * max(tmax, 1e-300)
        keep = np.empty(m, dtype=np.int64)
        mk = 0
        for a in range(m):
            if vals[a] - rmin * T[tie[a], c] <= noise:
                keep[mk] = tie[a]
                mk += 1
        tie = keep[:mk].copy()
        if level == 0 and tie.size > 1:
            for a in range(tie.size):
                if basis[tie[a]] == z0:
                    return tie[a]
        if tie.size == 1:
            break
    best = tie[0]
    for a in range(tie.size):
        best = min(best, tie[a])
    return best


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
            w_try = dense.matvec(M, z_try) + q
            if np.max(np.abs(w_try[C])) <= 1e-9 * max(q_scale, m_scale * float(np.max(zc)), 1e-300):
                z = z_try
                state[C] = CLAMP
                method = "warm_start+dantzig"
    w = dense.matvec(M, z) + q

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
                resid = dense.matvec(MCC, np.ascontiguousarray(dz[C])) + M[C, d]
                if np.max(np.abs(resid)) > 1e-8 * max(m_scale * float(np.max(np.abs(dz))), 1e-300):
                    status = "singular"
                    message = "clamped subsystem is singular and inconsistent"
                    break
            dw = dense.matvec(M, dz)
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
            w = dense.matvec(M, z) + q
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
) -> LCPResult:
    """Solve an LCP with one method and fall back to the other on failure.

    A selection among non-unique solutions (``select=``) is
    :func:`pbr_xval.reference.lcp.solve_lcp`, which builds on this one.

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

    Returns
    -------
    LCPResult
        ``method`` names the answering method; ``pivots_by_method`` lists the pivots of
        every method tried.  If both fail, the primary answer is returned.
    """
    if method not in _METHODS:
        raise ValueError(f"unknown method {method!r}; use 'dantzig' or 'lemke'")
    M, q = _as_problem(M, q)
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
