"""Resting contact with Coulomb friction (seed paper, eqs. 3.6–3.7): iterative cone solver.

The paper extends Baraff's (1994) 2-D friction pivoting to 3-D; the reference solver does
not (see the deviations in :mod:`pbr_xval.reference`).  Its resting forces come first from
the verified active-set solve of :func:`pbr_xval.reference.kernel.active_set_solve`; this
module holds the general solvers used when that fails:

:func:`solve_friction_cone`
    exact circular Coulomb cone per contact, block projected Gauss–Seidel with exact
    per-contact solves and a contact-mode polish;
:func:`solve_friction_pyramid`
    the polyhedral (pyramid) approximation of the same problem cast as one LCP and solved
    by :func:`pbr_xval.reference.pivoting.lemke` (Stewart–Trinkle form), the fallback;
:func:`friction_residuals`
    the violation of every condition of eqs. 3.6–3.7 (the diagnostics).

References
----------
D. E. Stewart, J. C. Trinkle, "An implicit time-stepping scheme for rigid body dynamics
with inelastic collisions and Coulomb friction", IJNME 1996 (pyramid LCP).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from pbr_xval.reference import dense
from pbr_xval.reference.pivoting import _lstsq, lemke

__all__ = ["FrictionResult", "friction_residuals", "solve_friction_cone", "solve_friction_pyramid"]


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


def _mv(a: np.ndarray, x: np.ndarray) -> np.ndarray:
    """a @ x without BLAS (:func:`dense.matvec`: the same bits on every CPU)."""
    return dense.matvec(np.ascontiguousarray(a, dtype=float), np.ascontiguousarray(x, dtype=float))


def _mm(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a @ b without BLAS (:func:`dense.matmul`)."""
    return dense.matmul(np.ascontiguousarray(a, dtype=float), np.ascontiguousarray(b, dtype=float))


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
    k = f.size // 3
    if k == 0:
        return dict.fromkeys(_RESIDUAL_KEYS, 0.0)
    mu_arr = np.broadcast_to(np.asarray(mu, dtype=float), (k,))
    vals = _residuals(
        np.ascontiguousarray(f, dtype=float),
        np.ascontiguousarray(a, dtype=float),
        np.ascontiguousarray(mu_arr),
    )
    return dict(zip(_RESIDUAL_KEYS, vals.tolist(), strict=True))


_RESIDUAL_KEYS = (
    "signorini_f",
    "signorini_a",
    "complementarity",
    "cone",
    "friction_complementarity",
    "dissipation",
)


@njit(cache=True)
def _residuals(f, a, mu):
    """The six values of :func:`friction_residuals`, in its key order (compiled; the same
    arithmetic as the NumPy expressions it replaced: |f_t| = √(f_x² + f_y²), …)."""
    k = f.size // 3
    out = np.empty(6)
    fn_min = np.inf
    an_min = np.inf
    compl = -np.inf
    cone_v = -np.inf
    fcompl = -np.inf
    diss = -np.inf
    for i in range(k):
        fn, fx, fy = f[3 * i], f[3 * i + 1], f[3 * i + 2]
        an, ax, ay = a[3 * i], a[3 * i + 1], a[3 * i + 2]
        ftn = math.sqrt(fx * fx + fy * fy)
        atn = math.sqrt(ax * ax + ay * ay)
        fn_min = min(fn_min, fn)
        an_min = min(an_min, an)
        compl = max(compl, abs(fn * an))
        cone_v = max(cone_v, ftn - mu[i] * fn)
        fcompl = max(fcompl, abs(atn * (mu[i] * fn - ftn)))
        diss = max(diss, (fx * ax + fy * ay) + ftn * atn)
    out[0] = max(0.0, -fn_min)
    out[1] = max(0.0, -an_min)
    out[2] = compl
    out[3] = max(0.0, cone_v)
    out[4] = fcompl
    out[5] = max(0.0, diss)
    return out


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
    ct = np.array([Q[0, 0] * c[0] + Q[1, 0] * c[1], Q[0, 1] * c[0] + Q[1, 1] * c[1]])  # Qᵀ c
    c_norm = float(np.hypot(ct[0], ct[1]))
    if c_norm == 0.0:
        return np.zeros(2)
    lam_max = max(float(lam[1]), 1e-300)
    if lam[0] > 1e-14 * lam_max:
        ft = -(ct / lam)
        if np.hypot(ft[0], ft[1]) <= radius:
            return np.array([Q[0, 0] * ft[0] + Q[0, 1] * ft[1], Q[1, 0] * ft[0] + Q[1, 1] * ft[1]])
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
    return np.array([Q[0, 0] * ft[0] + Q[0, 1] * ft[1], Q[1, 0] * ft[0] + Q[1, 1] * ft[1]])  # Q ft


@njit(cache=True)
def _disc_local_nb(lam0, lam1, Q, c0, c1, radius):
    """:func:`_disc_local_solve` compiled, on scalars: (f_t0, f_t1)."""
    if radius <= 0.0:
        return 0.0, 0.0
    ct0 = Q[0, 0] * c0 + Q[1, 0] * c1
    ct1 = Q[0, 1] * c0 + Q[1, 1] * c1
    c_norm = math.hypot(ct0, ct1)
    if c_norm == 0.0:
        return 0.0, 0.0
    lam_max = max(lam1, 1e-300)
    if lam0 > 1e-14 * lam_max:
        f0 = -(ct0 / lam0)
        f1 = -(ct1 / lam1)
        if math.hypot(f0, f1) <= radius:
            return Q[0, 0] * f0 + Q[0, 1] * f1, Q[1, 0] * f0 + Q[1, 1] * f1
    lo, hi = 0.0, c_norm / radius
    g = 0.0 if lam0 > 1e-14 * lam_max else 0.5 * hi
    for _ in range(100):
        d0 = lam0 + g
        d1 = lam1 + g
        fk0 = ct0 / d0
        fk1 = ct1 / d1
        nf = math.hypot(fk0, fk1)
        phi = 1.0 / nf - 1.0 / radius
        if phi < 0.0:
            lo = g
        else:
            hi = g
        if abs(phi) <= 1e-15 / radius or hi - lo <= 1e-15 * hi:
            break
        dphi = (ct0 * ct0 / d0**3 + ct1 * ct1 / d1**3) / nf**3
        g_new = g - phi / dphi if dphi > 0 else 0.5 * (lo + hi)
        if not (lo < g_new < hi):
            g_new = 0.5 * (lo + hi)
        g = g_new
    f0 = -(ct0 / (lam0 + g))
    f1 = -(ct1 / (lam1 + g))
    sc = radius / math.hypot(f0, f1)
    f0 *= sc
    f1 *= sc
    return Q[0, 0] * f0 + Q[0, 1] * f1, Q[1, 0] * f0 + Q[1, 1] * f1


@njit(cache=True)
def _gs_sweeps(A, f, a, diag_n, active, lam, Q, mu, it0, it1, tol, force_scale):
    """Sweeps it0 … it1 of :func:`solve_friction_cone` (no polish or restart among them),
    compiled; ``f`` and ``a`` are updated in place. Returns (last sweep, converged)."""
    k = diag_n.size
    n = A.shape[0]
    it = it0
    for it in range(it0, it1 + 1):
        max_change = 0.0
        for i in range(k):
            rn = 3 * i
            if not active[i]:
                if f[rn] != 0.0 or f[rn + 1] != 0.0 or f[rn + 2] != 0.0:
                    for r in range(n):
                        a[r] -= A[r, rn] * f[rn] + A[r, rn + 1] * f[rn + 1] + A[r, rn + 2] * f[rn + 2]
                    f[rn] = 0.0
                    f[rn + 1] = 0.0
                    f[rn + 2] = 0.0
                continue
            fn_new = max(0.0, f[rn] - a[rn] / diag_n[i])
            dfn = fn_new - f[rn]
            if dfn != 0.0:
                for r in range(n):
                    a[r] += A[r, rn] * dfn
                f[rn] = fn_new
            o1 = f[rn + 1]
            o2 = f[rn + 2]
            c0 = a[rn + 1] - (A[rn + 1, rn + 1] * o1 + A[rn + 1, rn + 2] * o2)
            c1 = a[rn + 2] - (A[rn + 2, rn + 1] * o1 + A[rn + 2, rn + 2] * o2)
            n1, n2 = _disc_local_nb(lam[i, 0], lam[i, 1], Q[i], c0, c1, mu[i] * fn_new)
            d1 = n1 - o1
            d2 = n2 - o2
            if d1 != 0.0 or d2 != 0.0:
                for r in range(n):
                    a[r] += A[r, rn + 1] * d1 + A[r, rn + 2] * d2
                f[rn + 1] = n1
                f[rn + 2] = n2
            max_change = max(max_change, abs(dfn), abs(d1), abs(d2))
        f_scale = force_scale
        for j in range(n):
            f_scale = max(f_scale, abs(f[j]))
        f_scale = max(f_scale, 1e-300)
        if max_change <= tol * f_scale:
            return it, True
    return it, False


@njit(cache=True)
def _eig_sym2(p, r, s):
    """Eigen-decomposition of the symmetric 2 × 2 matrix [[p, r], [r, s]] by one Jacobi
    rotation (exact to round-off; the LAPACK call it replaces cost ~10 µs from Python):
    (λ (2,) ascending, clipped at 0; Q (2, 2), the eigenvectors in its columns)."""
    lam = np.empty(2)
    Q = np.empty((2, 2))
    if r == 0.0:
        c, sn, l0, l1 = 1.0, 0.0, p, s
    else:
        tau = (s - p) / (2.0 * r)
        t = (1.0 if tau >= 0.0 else -1.0) / (abs(tau) + math.sqrt(1.0 + tau * tau))
        c = 1.0 / math.sqrt(1.0 + t * t)
        sn = t * c
        l0, l1 = p - t * r, s + t * r
    # columns (c, -sn) for l0 and (sn, c) for l1
    if l0 <= l1:
        lam[0], lam[1] = l0, l1
        Q[0, 0], Q[1, 0], Q[0, 1], Q[1, 1] = c, -sn, sn, c
    else:
        lam[0], lam[1] = l1, l0
        Q[0, 0], Q[1, 0], Q[0, 1], Q[1, 1] = sn, c, c, -sn
    lam[0] = max(lam[0], 0.0)
    lam[1] = max(lam[1], 0.0)
    return lam, Q


@njit(cache=True)
def _cone_setup(A, b, mu, f):
    """The start of :func:`solve_friction_cone`, compiled: ``f`` (3k,) (the warm start, or
    zeros) projected onto the cones in place (f_n ≥ 0, |f_t| ≤ μ f_n), and returns
    (a = A f + b (3k,), the force scale max|b| / max|A|, A's normal diagonal (k,), the contacts
    with A_nn > 0 (k,) bool, the eigenvalues (k, 2) and eigenvectors (k, 2, 2) of each
    contact's symmetrised tangential block)."""
    k = b.size // 3
    n = 3 * k
    for i in range(k):
        fn = max(f[3 * i], 0.0)
        f[3 * i] = fn
        fx, fy = f[3 * i + 1], f[3 * i + 2]
        nt = math.sqrt(fx * fx + fy * fy)
        if nt > mu[i] * fn:
            sc = mu[i] * fn / nt
            f[3 * i + 1] = fx * sc
            f[3 * i + 2] = fy * sc
    a = np.empty(n)
    a_scale = 0.0
    for r in range(n):
        acc = 0.0
        for c in range(n):
            acc += A[r, c] * f[c]
            a_scale = max(a_scale, abs(A[r, c]))
        a[r] = acc + b[r]
    b_max = 0.0
    for r in range(n):
        b_max = max(b_max, abs(b[r]))
    force_scale = b_max / a_scale if a_scale > 0 else 0.0
    diag_n = np.empty(k)
    active = np.empty(k, dtype=np.bool_)
    lam = np.empty((k, 2))
    Q = np.empty((k, 2, 2))
    for i in range(k):
        diag_n[i] = A[3 * i, 3 * i]
        active[i] = diag_n[i] > 1e-14 * max(a_scale, 1e-300)
        off = 0.5 * (A[3 * i + 1, 3 * i + 2] + A[3 * i + 2, 3 * i + 1])
        li, Qi = _eig_sym2(A[3 * i + 1, 3 * i + 1], off, A[3 * i + 2, 3 * i + 2])
        lam[i, 0], lam[i, 1] = li[0], li[1]
        Q[i] = Qi
    return a, force_scale, diag_n, active, lam, Q


@njit(cache=True)
def cone_first_sweeps(A, b, mu, warm, tol):
    """:func:`solve_friction_cone` from the warm start ``warm`` (3k,) up to its first
    contact-mode polish (sweeps 1 … ``POLISH_EVERY`` − 1), compiled: the same arithmetic
    (:func:`_cone_setup`, :func:`_gs_sweeps`), so the same forces when it converges there —
    the common case of the impacts of a rocking rock (8–24 sweeps). Returns (converged,
    sweeps, forces (3k,)); not converged: the caller runs :func:`solve_friction_cone`."""
    f = warm.copy()
    a, force_scale, diag_n, active, lam, Q = _cone_setup(A, b, mu, f)
    it, converged = _gs_sweeps(A, f, a, diag_n, active, lam, Q, mu, 1, POLISH_EVERY - 1, tol, force_scale)
    return converged, it, f


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
    a = _mv(A, base) + b
    E = _mm(A, Gm)[rows]
    dx = _lstsq(E, -a[rows], 1e-12)
    return base + _mv(Gm, dx)


#: sweeps between the contact-mode polishes of :func:`solve_friction_cone` (its Newton solves come
#: at multiples of it)
POLISH_EVERY = 25

#: a Newton candidate (:func:`_mode_newton`) is accepted when its dimensionless residual merit
#: (:func:`_friction_merit`) is at most this: eqs. 3.6–3.7 hold to round-off (a converged
#: Gauss–Seidel answer measures 1e-14–1e-13 on the impacts of the SP1/SP2 campaigns)
NEWTON_MERIT_TOL = 1e-12


def _mode_system(
    x: np.ndarray, slots: list[tuple[int, int]], A: np.ndarray, b: np.ndarray, mu: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The residuals (n,), their Jacobian (n, n) and the forces (3k,) of :func:`_mode_newton`'s
    unknowns ``x`` (n,): ``slots`` lists (contact, 3) for a sticking and (contact, 2) for a
    sliding contact, in the order of ``x``."""
    k = b.size // 3
    ff = np.zeros(3 * k)
    df = np.zeros((3 * k, x.size))
    j = 0
    for i, m in slots:
        if m == 3:
            ff[3 * i : 3 * i + 3] = x[j : j + 3]
            df[3 * i : 3 * i + 3, j : j + 3] = np.eye(3)
        else:
            fn, c, s = x[j], math.cos(x[j + 1]), math.sin(x[j + 1])
            ff[3 * i : 3 * i + 3] = (fn, mu[i] * fn * c, mu[i] * fn * s)
            df[3 * i : 3 * i + 3, j] = (1.0, mu[i] * c, mu[i] * s)
            df[3 * i + 1 : 3 * i + 3, j + 1] = (-mu[i] * fn * s, mu[i] * fn * c)
        j += m
    aa = _mv(A, ff) + b
    da = _mm(A, df)
    res = np.empty(x.size)
    jac = np.empty((x.size, x.size))
    j = 0
    for i, m in slots:
        if m == 3:
            res[j : j + 3] = aa[3 * i : 3 * i + 3]
            jac[j : j + 3] = da[3 * i : 3 * i + 3]
        else:
            c, s = math.cos(x[j + 1]), math.sin(x[j + 1])
            res[j] = aa[3 * i]
            jac[j] = da[3 * i]
            res[j + 1] = aa[3 * i + 1] * s - aa[3 * i + 2] * c
            jac[j + 1] = da[3 * i + 1] * s - da[3 * i + 2] * c
            jac[j + 1, j + 1] += aa[3 * i + 1] * c + aa[3 * i + 2] * s
        j += m
    return res, jac, ff


def _mode_newton(
    A: np.ndarray, b: np.ndarray, f: np.ndarray, mu: np.ndarray, *, rounds: int = 4, iters: int = 30
) -> np.ndarray | None:
    """The solution of eqs. 3.6–3.7 with the contact modes of the iterate ``f``, by Newton.

    Gauss–Seidel finds the modes of a contact problem (open, sticking, sliding) long before
    it converges: on a singular ``A`` (three contacts, rank 6 of 9, the rock's impacts on
    its pedestal) the load drifts between redundant contacts and the sliding directions
    turn slowly, for thousands of sweeps, and some problems never meet the sweep-change
    criterion. With the modes fixed the rest is a small smooth system. Unknowns: ``f`` of a
    sticking contact (3), ``(f_n, θ)`` of a sliding one, ``f_t = μ f_n (cos θ, sin θ)``.
    Equations: ``a = 0`` (sticking), ``a_n = 0`` and ``a_t × (cos θ, sin θ) = 0`` (sliding),
    with ``a = A f + b``: as many equations as unknowns, solved by Gauss–Newton (minimum-norm
    steps, ``lstsq``: the redundant load is left where it is) with a backtracking line
    search. A mode that the result contradicts is switched (a sticking or sliding contact
    pulled into tension opens; an open one pushed into the pedestal sticks; a sticking
    force outside its cone slides; a sliding force along its acceleration turns round) and
    the solve repeated, at most ``rounds`` times.

    Returns the candidate forces (3k,), or None when there is nothing to solve (every
    contact open). The caller verifies the candidate against every condition
    (:func:`_friction_merit`); nothing here claims it is a solution.
    """
    k = b.size // 3
    F = f.reshape(k, 3)
    fs = max(float(np.max(np.abs(f))) if f.size else 0.0, 1e-300)
    b_scale = max(float(np.max(np.abs(b))), 1e-300)
    mode = np.zeros(k, dtype=int)  # 0 open, 1 sticking, 2 sliding
    theta = np.zeros(k)
    for i in range(k):
        nt = math.hypot(F[i, 1], F[i, 2])
        if F[i, 0] <= 1e-9 * fs:
            mode[i] = 0
        elif nt < mu[i] * F[i, 0] * (1.0 - 1e-6):
            mode[i] = 1
        else:
            mode[i] = 2
            theta[i] = math.atan2(F[i, 2], F[i, 1])
    cand: np.ndarray | None = None
    for _ in range(rounds):
        # unknown layout: sticking contact i -> (f_n, f_x, f_y); sliding -> (f_n, θ)
        slots = [(i, 3) for i in range(k) if mode[i] == 1] + [(i, 2) for i in range(k) if mode[i] == 2]
        if not slots:
            return None
        x0: list[float] = []
        for i, m in slots:
            x0 += [F[i, 0], F[i, 1], F[i, 2]] if m == 3 else [F[i, 0], theta[i]]
        x = np.array(x0)

        res, jac, ff = _mode_system(x, slots, A, b, mu)
        norm = float(dense.norm2(res))
        for _ in range(iters):
            if norm <= 1e-15 * b_scale:
                break
            dx = _lstsq(jac, -res, 1e-12)
            step = 1.0
            while True:
                res2, jac2, ff2 = _mode_system(x + step * dx, slots, A, b, mu)
                norm2 = float(dense.norm2(res2))
                if norm2 < norm or step < 1e-4:
                    break
                step *= 0.5
            if not norm2 < norm:
                break
            x, res, jac, ff, norm = x + step * dx, res2, jac2, ff2, norm2
        cand = ff
        aa = _mv(A, ff) + b
        F = ff.reshape(k, 3).copy()
        changed = False
        j = 0
        for i in range(k):
            if mode[i] == 0:
                if aa[3 * i] < -1e-12 * b_scale:
                    mode[i], changed = 1, True
        for i, m in slots:
            if m == 3:
                if F[i, 0] < 0.0:
                    mode[i], changed = 0, True
                elif math.hypot(F[i, 1], F[i, 2]) > mu[i] * F[i, 0]:
                    mode[i], theta[i], changed = 2, math.atan2(F[i, 2], F[i, 1]), True
            else:
                theta[i] = x[j + 1]
                if F[i, 0] < 0.0:
                    mode[i], changed = 0, True
                elif aa[3 * i + 1] * math.cos(theta[i]) + aa[3 * i + 2] * math.sin(theta[i]) > 0.0:
                    theta[i], changed = theta[i] + math.pi, True  # friction along the slip: turn round
            j += m
        F[mode == 0] = 0.0
        if not changed:
            break
    return cand


def solve_friction_cone(
    A: np.ndarray,
    b: np.ndarray,
    mu: float | np.ndarray,
    *,
    tol: float = 1e-12,
    max_iter: int = 10000,
    warm_start: np.ndarray | None = None,
    restart_after: int | None = 500,
    newton_every: int | None = 100,
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
    Every ``newton_every`` sweeps the modes of the iterate are solved for by Newton
    (:func:`_mode_newton`); a candidate that meets every condition to round-off (merit
    ≤ :data:`NEWTON_MERIT_TOL`) is the answer (converged; ``method`` gains ``"+newton"``).
    Gauss–Seidel alone needed 400–9,600 sweeps on the few impacts of a long rocking run whose
    three contacts load a rank-6 ``A``, and on about one such impact per run it did not meet
    its criterion in 20,000 (residual merit 1e-6–1e-4 left); Newton from the 100th sweep's
    modes met them to 1e-16 in 0.1–0.4 ms. A problem that converges within ``newton_every``
    sweeps never meets this stage (the answer is bit for bit that of Gauss–Seidel alone).
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
    newton_every : int or None
        Sweeps between Newton solves of the iterate's contact modes (a multiple of 25, the
        polish period); ``None`` disables them.

    Returns
    -------
    FrictionResult
        ``method == "pgs_cone"``, ``"pgs_cone+pyramid_restart"`` when the restart
        was used, either with ``"+newton"`` when a Newton candidate was the answer.
    """
    A = np.asarray(A, dtype=float)
    b = np.asarray(b, dtype=float).reshape(-1)
    if b.size % 3 or A.shape != (b.size, b.size):
        raise ValueError("A must be (3k, 3k) and b (3k,)")
    if newton_every is not None and (newton_every <= 0 or newton_every % POLISH_EVERY):
        raise ValueError(
            f"newton_every must be a positive multiple of {POLISH_EVERY} (the polish period), got {newton_every}"
        )
    k = b.size // 3
    mu_arr = _mu_vector(mu, k)
    f = np.zeros(3 * k)
    if warm_start is not None:
        f = np.asarray(warm_start, dtype=float).reshape(-1).copy()
        if f.size != 3 * k:
            raise ValueError("warm_start has the wrong size")
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
    A_c = np.ascontiguousarray(A)
    b = np.ascontiguousarray(b)
    # the warm start projected onto the cones, a = A f + b and the per-contact data of the
    # sweeps, compiled (the arithmetic the kernel's impacts use: cone_first_sweeps)
    a, force_scale, diag_n, active, lam_arr, q_arr = _cone_setup(A_c, b, mu_arr, f)
    acc_scale = max(float(np.max(np.abs(b))), 1e-300)
    polish_every = POLISH_EVERY
    converged = False
    it = 0
    method = "pgs_cone"
    while it < max_iter:
        # sweep it + 1 after its restart or polish, then the
        # compiled sweeps up to the next restart or polish
        it += 1
        if restart_after is not None and it == restart_after + 1:
            pyr = solve_friction_pyramid(A, b, mu_arr, n_facets=16)
            if pyr.converged:
                f = pyr.f.copy()
                a = _mv(A, f) + b
                method = "pgs_cone+pyramid_restart"
        if it % polish_every == 0:
            fs = max(float(np.max(np.abs(f))), force_scale, 1e-300)
            cand = _mode_polish(A, b, f, mu_arr)
            a_c = _mv(A, cand) + b
            a = _mv(A, f) + b
            if _friction_merit(cand, a_c, mu_arr, fs, acc_scale) < _friction_merit(
                f, a, mu_arr, fs, acc_scale
            ):
                f, a = cand, a_c
            if newton_every and it % newton_every == 0:
                newt = _mode_newton(A, b, f, mu_arr)
                if newt is not None:
                    a_n = _mv(A, newt) + b
                    fs_n = max(float(np.max(np.abs(newt))), force_scale, 1e-300)
                    if _friction_merit(newt, a_n, mu_arr, fs_n, acc_scale) <= NEWTON_MERIT_TOL:
                        f, converged, method = newt, True, method + "+newton"
                        it -= 1  # sweeps done
                        break
        end = min(max_iter, (it // polish_every + 1) * polish_every - 1)
        if restart_after is not None and restart_after + 1 > it:
            end = min(end, restart_after)
        f = np.ascontiguousarray(f, dtype=float)
        a = np.ascontiguousarray(a, dtype=float)
        it, converged = _gs_sweeps(
            A_c, f, a, diag_n, active, lam_arr, q_arr, mu_arr, it, end, float(tol), float(force_scale)
        )
        if converged:
            break
    a = _mv(A, f) + b
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
    ang = [2.0 * math.pi * j / m for j in range(m)]  # libm's cos and sin, not NumPy's SIMD loops
    D = np.array([[math.cos(x) for x in ang], [math.sin(x) for x in ang]])  # (2, m)
    nv = k * (1 + m)  # (f_n, beta) per contact
    H = np.zeros((3 * k, nv))  # f = H x
    for i in range(k):
        H[3 * i, i * (1 + m)] = 1.0
        H[3 * i + 1 : 3 * i + 3, i * (1 + m) + 1 : (i + 1) * (1 + m)] = D
    L = np.zeros((nv + k, nv + k))
    L[:nv, :nv] = _mm(_mm(H.T, A), H)
    for i in range(k):
        beta = slice(i * (1 + m) + 1, (i + 1) * (1 + m))
        L[beta, nv + i] = 1.0
        L[nv + i, i * (1 + m)] = mu_arr[i]
        L[nv + i, beta] = -1.0
    qq = np.concatenate([_mv(H.T, b), np.zeros(k)])
    res = lemke(L, qq, max_pivots=max_pivots, tol=tol)
    f = _mv(H, res.z[:nv])
    a = _mv(A, f) + b
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
