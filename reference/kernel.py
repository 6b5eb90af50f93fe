"""Compiled (numba) kernel of the reference solver: one step of :class:`dynamics.RigidBodySolver`.

:mod:`pbr_xval.reference.dynamics` is the readable implementation of the seed paper's
Section 3 (eqs. 3.1–3.7) in NumPy; this module does the same arithmetic for the common
case in compiled code so that a step costs microseconds instead of the ~0.3 ms of
per-step Python and small-array overhead measured before it existed (see
``reference/PERFORMANCE.md`` for the profile).  The two are kept equal by a test
(``tests/reference/test_kernel.py``: the same Housner run with ``compiled = False`` and
``True`` agrees to round-off).

What is compiled
    :func:`step`: contact set at the start of the step (nodes within ±ε, not separating),
    the support-hull reduction of that set (:func:`support_hull`), the start-of-step and
    end-of-step resting forces (eqs. 3.6–3.7) by the active-set solve
    (:func:`active_set_solve`), the constant-average-acceleration update with direct
    iteration (eqs. 3.1–3.4), the SO(3) check with Cayley projection and the ±ε
    penetration check.  :func:`impact_pending` is the eq. 3.5 trigger.

What is not
    The step returns a code instead of raising or calling back into Python:
    ``STEP_OK``; ``STEP_REJECTED`` (a node ended deeper than ε: step back);
    ``STEP_GENERAL`` (an active-set guess failed its verification: the caller repeats the
    step with the general NumPy path, which has the iterative cone solver and the
    pyramid-LCP fallback of :mod:`pbr_xval.reference.cone`).  Impacts (eq. 3.5):
    :func:`impact_impulses` and :func:`impact_finish` compute them when the impact cone's
    active-set guess verifies and the normal LCP has one solution (:func:`lcp_unique`) or a
    segment of solutions (:func:`lcp_select`) — inside :func:`step_block` at a block's first
    step, or for :meth:`dynamics.RigidBodySolver.resolve_impacts`, which has the iterative cone
    solver and the general impulse selection for the other cases.

Structure used
    The Delassus operator of one rigid body, A = G_m M⁻¹ G_fᵀ (G: 3k × 6 contact
    Jacobian, M⁻¹ = diag(I₃/m, I_world⁻¹)), has rank ≤ 6; it is assembled from the
    6 × 6 inverse mass and the (3k, 6) Jacobian in O(k²) — and k is the number of
    *support-hull* contacts, not of basal nodes: a contact node that is a convex
    combination of other contact nodes (interior to a flat contact patch, or on an edge
    between two of them) is dropped, which is exact: the relative acceleration and
    velocity of a rigid body are affine in the contact position and the normal is the
    pedestal's, so any force distribution on the dropped node is reproduced by one on the
    hull vertices with the same wrench and the same cone conditions, and the hull
    vertices' a_n ≥ 0 implies it at every interior node.  Everything outside the LCP is
    O(N) in the number of basal nodes N.

Compile time
    numba compiles every function to its own LLVM module, links the modules of all its
    compiled callees into it and optimises and generates code for the whole linked module
    again: each separately compiled function pays once more for its whole call tree. So the
    functions between the entry points called from Python (:func:`step_block`,
    :func:`_step`, :func:`impact_impulses`, :func:`active_set_solve`) are inlined by numba
    (``inline="always"``: their code spliced into the caller's before typing, no module of
    their own): :func:`_block_impact`, :func:`_forces`, :func:`active_set_retry`,
    :func:`_active_set_solve_into`, :func:`_active_set_rounds` (one call site in
    :func:`active_set_solve` for that), :func:`_slip_directions`,
    :func:`_free_unloaded_slip`, :func:`lcp_select`, :func:`_minnorm_solve` and :func:`_mat`.
    The same operations in the same order, without fast-math: the results are bit for bit
    those of separate compilation (``reference/PERFORMANCE.md``, "Cold JIT compile"). Called
    from Python, an inlined function is compiled as any other.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit

from pbr_xval.reference.cone import _residuals as _friction_residuals
from pbr_xval.reference.cone import cone_first_sweeps

__all__ = [
    "IMPACT_CONE",
    "IMPACT_DONE",
    "IMPACT_REVERTED",
    "IMPACT_SELECT",
    "STEP_GENERAL",
    "STEP_IMPACT",
    "STEP_OK",
    "STEP_REJECTED",
    "active_set_retry",
    "active_set_solve",
    "contact_problem",
    "impact_cone_normals",
    "impact_impulses",
    "impact_pending",
    "kinematics",
    "lcp_select",
    "lcp_unique",
    "step",
    "step_block",
    "support_hull",
]

#: ``njit`` options of the kernel functions that allocate nothing and return no array: compiled
#: without numba's reference counting, whose atomic increments and decrements of every array
#: argument cost more than their arithmetic on the step's small arrays (reference/PERFORMANCE.md,
#: thirteenth pass). Such a function must not allocate, return or store an array.
_NO_REFCOUNT: dict[str, Any] = {"cache": True, "_nrt": False}

STEP_OK = 0
STEP_REJECTED = 1
STEP_GENERAL = 2
#: with ``prm[P_IMPACT] > 0``: an in-band node approaches faster than ``prm[P_VIMP]`` at the
#: start of the step (the :func:`impact_pending` test); nothing else was done
STEP_IMPACT = 3

# parameter vector layout of :func:`step` (float64 array)
P_MASS, P_MU_S, P_MU_D, P_EPS, P_ITER, P_ITOL, P_VSEP, P_VSLIP, P_ORTH, P_LREF = range(10)
P_T0, P_DT, P_PED_KIND, P_HX, P_HY, P_REDUCE, P_NO_PEN = range(10, 17)
#: cos of the largest tilt for which the candidate nodes ``cand`` of :func:`step` are exact
#: (−2: every node is a candidate); see :meth:`dynamics.RigidBodySolver.candidates`
P_COS_CAND = 17
#: P_IMPACT > 0: :func:`step` first makes the eq. 3.5 trigger test (``STEP_IMPACT``), with
#: the impact velocity P_VIMP (m/s)
P_IMPACT, P_VIMP = 18, 19
N_PARAMS = 20
# info vector layout (float64 array) filled by :func:`step`
I_ITS, I_CONV, I_SOLVES, I_FAST, I_CAYLEY, I_NCONT, I_GMIN = range(7)
I_F1, I_TAU1, I_OMEGA = 7, 10, 13
I_SIG_F, I_SIG_A, I_COMPL, I_CONE = 16, 17, 18, 19
I_NRES = 20  # 1 when the residuals of a start-of-step solve were recorded
N_INFO = 21


# ----------------------------------------------------------------------------- small helpers
@njit(cache=True)
def _skew(w):
    s = np.zeros((3, 3))
    s[0, 1] = -w[2]
    s[0, 2] = w[1]
    s[1, 0] = w[2]
    s[1, 2] = -w[0]
    s[2, 0] = -w[1]
    s[2, 1] = w[0]
    return s


@njit(cache=True)
def _mm(a, b):
    """a @ b for (3, 3) matrices (plain loops: no BLAS call for 3 × 3)."""
    c = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            c[i, j] = a[i, 0] * b[0, j] + a[i, 1] * b[1, j] + a[i, 2] * b[2, j]
    return c


@njit(cache=True)
def _mmt(a, b):
    """a @ bᵀ for (3, 3) matrices."""
    c = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            c[i, j] = a[i, 0] * b[j, 0] + a[i, 1] * b[j, 1] + a[i, 2] * b[j, 2]
    return c


@njit(cache=True)
def _mv(a, x):
    """a @ x for a (3, 3) matrix and a (3,) vector."""
    y = np.empty(3)
    for i in range(3):
        y[i] = a[i, 0] * x[0] + a[i, 1] * x[1] + a[i, 2] * x[2]
    return y


@njit(cache=True)
def _mtv(a, x):
    """aᵀ @ x for a (3, 3) matrix and a (3,) vector."""
    y = np.empty(3)
    for i in range(3):
        y[i] = a[0, i] * x[0] + a[1, i] * x[1] + a[2, i] * x[2]
    return y


@njit(cache=True)
def _points_mt(p, R):
    """p @ Rᵀ for points p (N, 3): the body points rotated."""
    n = p.shape[0]
    out = np.empty((n, 3))
    for i in range(n):
        for j in range(3):
            out[i, j] = R[j, 0] * p[i, 0] + R[j, 1] * p[i, 1] + R[j, 2] * p[i, 2]
    return out


@njit(cache=True)
def _omega(R, inertia_inv, lm):
    """ω = R I'⁻¹ Rᵀ l."""
    return _mv(R, _mv(inertia_inv, _mtv(R, lm)))


@njit(cache=True)
def _lu_solve(a, b):
    """x = a⁻¹ b (b: (n,)) by Gaussian elimination with partial pivoting; ok flag."""
    x = b.copy()
    return x, _lu_solve_inplace(a.copy(), x)


@njit(**_NO_REFCOUNT)
def _lu_solve_inplace(m, x):
    """:func:`_lu_solve` overwriting ``m`` (n, n) and ``x`` (n,) (x ← m⁻¹ x); ok flag."""
    n = m.shape[0]
    for c in range(n):
        p = c
        best = abs(m[c, c])
        for r in range(c + 1, n):
            if abs(m[r, c]) > best:
                best = abs(m[r, c])
                p = r
        if best == 0.0:
            return False
        if p != c:
            for j in range(n):
                tmp = m[c, j]
                m[c, j] = m[p, j]
                m[p, j] = tmp
            tmp = x[c]
            x[c] = x[p]
            x[p] = tmp
        piv = m[c, c]
        for r in range(c + 1, n):
            fac = m[r, c] / piv
            if fac != 0.0:
                for j in range(c, n):
                    m[r, j] -= fac * m[c, j]
                x[r] -= fac * x[c]
    for c in range(n - 1, -1, -1):
        s = x[c]
        for j in range(c + 1, n):
            s -= m[c, j] * x[j]
        x[c] = s / m[c, c]
    return True


@njit(cache=True)
def _solve3(a, b):
    """a⁻¹ b for (3, 3) matrices (cofactor inverse; a is near a rotation or near I here):
    :func:`_solve3_into` into fresh arrays."""
    out = np.empty((3, 3))
    _solve3_into(a, b, np.empty((3, 3)), out)
    return out


@njit(cache=True)
def _cayley(w):
    """(I − [w]×/2)⁻¹ (I + [w]×/2) ∈ SO(3)."""
    s = 0.5 * _skew(w)
    e = np.eye(3)
    return _solve3(e - s, e + s)


@njit(cache=True)
def _cayley_project(r_new, r_old):
    """Projection of r_new onto SO(3) through the Cayley parameter of r_new r_oldᵀ
    (see :func:`dynamics.cayley_project`): :func:`_cayley_project_into` into fresh arrays."""
    out = np.empty((3, 3))
    _cayley_project_into(r_new, r_old, np.eye(3), np.empty((5, 3, 3)), out)
    return out


@njit(**_NO_REFCOUNT)
def _det3(r):
    return (
        r[0, 0] * (r[1, 1] * r[2, 2] - r[1, 2] * r[2, 1])
        - r[0, 1] * (r[1, 0] * r[2, 2] - r[1, 2] * r[2, 0])
        + r[0, 2] * (r[1, 0] * r[2, 1] - r[1, 1] * r[2, 0])
    )


@njit(**_NO_REFCOUNT)
def _norm3(v):
    return math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])


def layout_a(x: np.ndarray) -> np.ndarray:
    """A copy of the 2-D float array ``x`` (same shape and values) that numba types with
    layout 'A' — the layout of the workspace views of :func:`_mat` — for calls from Python
    into the compiled solves (:func:`active_set_solve`, :func:`active_set_retry`): with a
    C-contiguous argument such a call would compile the solve's whole call tree a second time
    (~13 s cold). A view of every second column of a buffer twice as wide (never contiguous,
    whatever the shape, as long as ``x`` has more than one element)."""
    out = np.empty((x.shape[0], 2 * x.shape[1]))[:, ::2]
    out[...] = x
    return out


@njit(cache=True, inline="always")
def _mat(buf, o, n, m):
    """The (n, m) row-major view of ``buf[o : o + n m]`` (1-D, contiguous): the same elements
    as ``buf[o : o + n m].reshape((n, m))``, without reshape's checks (~10 ns per call, ~70
    calls per quiet step)."""
    return np.lib.stride_tricks.as_strided(buf[o : o + n * m], (n, m), (m * buf.itemsize, buf.itemsize))


# In-place forms for the direct iteration of :func:`step` (no allocation per iteration);
# :func:`_solve3` and :func:`_cayley_project` above call them with fresh arrays.
@njit(**_NO_REFCOUNT)
def _mm_into(a, b, c):
    """c = a @ b for (3, 3) matrices (c distinct from a and b); :func:`_mm`'s arithmetic."""
    for i in range(3):
        for j in range(3):
            c[i, j] = a[i, 0] * b[0, j] + a[i, 1] * b[1, j] + a[i, 2] * b[2, j]


@njit(**_NO_REFCOUNT)
def _solve3_into(a, b, inv, out):
    """out = a⁻¹ b (3, 3) by the cofactor inverse (:func:`_solve3` is this into fresh arrays);
    ``inv`` (3, 3) scratch."""
    inv[0, 0] = a[1, 1] * a[2, 2] - a[1, 2] * a[2, 1]
    inv[0, 1] = a[0, 2] * a[2, 1] - a[0, 1] * a[2, 2]
    inv[0, 2] = a[0, 1] * a[1, 2] - a[0, 2] * a[1, 1]
    inv[1, 0] = a[1, 2] * a[2, 0] - a[1, 0] * a[2, 2]
    inv[1, 1] = a[0, 0] * a[2, 2] - a[0, 2] * a[2, 0]
    inv[1, 2] = a[0, 2] * a[1, 0] - a[0, 0] * a[1, 2]
    inv[2, 0] = a[1, 0] * a[2, 1] - a[1, 1] * a[2, 0]
    inv[2, 1] = a[0, 1] * a[2, 0] - a[0, 0] * a[2, 1]
    inv[2, 2] = a[0, 0] * a[1, 1] - a[0, 1] * a[1, 0]
    det = a[0, 0] * inv[0, 0] + a[0, 1] * inv[1, 0] + a[0, 2] * inv[2, 0]
    for i in range(3):
        for j in range(3):
            out[i, j] = (inv[i, 0] * b[0, j] + inv[i, 1] * b[1, j] + inv[i, 2] * b[2, j]) / det


@njit(**_NO_REFCOUNT)
def _cayley_project_into(r_new, r_old, e, wk, out):
    """out = the projection of r_new onto SO(3) through the Cayley parameter of r_new r_oldᵀ
    (:func:`_cayley_project` is this into fresh arrays); ``e`` the (3, 3) identity, ``wk``
    (5, 3, 3) scratch; ``out`` distinct from r_new and r_old."""
    dr, a1, b1, wt, inv = wk[0], wk[1], wk[2], wk[3], wk[4]
    for i in range(3):
        for j in range(3):
            dr[i, j] = r_new[i, 0] * r_old[j, 0] + r_new[i, 1] * r_old[j, 1] + r_new[i, 2] * r_old[j, 2]
    for i in range(3):
        for j in range(3):
            a1[i, j] = dr[j, i] + e[j, i]
            b1[i, j] = dr[j, i] - e[j, i]
    _solve3_into(a1, b1, inv, wt)
    # w = wtᵀ; ws = 0.5 (w − wᵀ); q = (e − ws)⁻¹ (e + ws)
    for i in range(3):
        for j in range(3):
            ws = 0.5 * (wt[j, i] - wt[i, j])
            a1[i, j] = e[i, j] - ws
            b1[i, j] = e[i, j] + ws
    _solve3_into(a1, b1, inv, dr)
    _mm_into(dr, r_old, out)


@njit(**_NO_REFCOUNT)
def _omega3(R, inertia_inv, lm):
    """:func:`_omega` as three floats (its arithmetic)."""
    u0 = R[0, 0] * lm[0] + R[1, 0] * lm[1] + R[2, 0] * lm[2]
    u1 = R[0, 1] * lm[0] + R[1, 1] * lm[1] + R[2, 1] * lm[2]
    u2 = R[0, 2] * lm[0] + R[1, 2] * lm[1] + R[2, 2] * lm[2]
    v0 = inertia_inv[0, 0] * u0 + inertia_inv[0, 1] * u1 + inertia_inv[0, 2] * u2
    v1 = inertia_inv[1, 0] * u0 + inertia_inv[1, 1] * u1 + inertia_inv[1, 2] * u2
    v2 = inertia_inv[2, 0] * u0 + inertia_inv[2, 1] * u1 + inertia_inv[2, 2] * u2
    return (
        R[0, 0] * v0 + R[0, 1] * v1 + R[0, 2] * v2,
        R[1, 0] * v0 + R[1, 1] * v1 + R[1, 2] * v2,
        R[2, 0] * v0 + R[2, 1] * v1 + R[2, 2] * v2,
    )


# ----------------------------------------------------------------------------- support hull
@njit(**_NO_REFCOUNT)
def _dot3(a, b):
    """a · b for (3,) vectors summed left to right (numba's ``np.dot`` calls BLAS, whose rounding
    depends on the CPU's kernels)."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@njit(cache=True)
def support_hull(nodes, idx, tol):
    """Contact nodes that are not convex combinations of the others (exact reduction).

    Parameters
    ----------
    nodes : (N, 3) body-frame node coordinates, m.
    idx : (k,) int, the contact set.
    tol : coplanarity tolerance, m.

    Returns
    -------
    (q,) int, a subset of ``idx`` (ascending): the vertices of the 2-D convex hull of the
    set in its plane when the set is coplanar within ``tol`` (collinear points on hull
    edges dropped), the two extreme points of a collinear set, and ``idx`` unchanged when
    the set is not coplanar (the 3-D case keeps every node) or has ≤ 3 points.
    """
    k = idx.size
    if k <= 3:
        return idx.copy()
    p0 = nodes[idx[0]]
    # farthest point from p0, then the point farthest from the line p0–p1
    best = -1.0
    j1 = 0
    for a in range(k):
        d = nodes[idx[a]] - p0
        dd = d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
        if dd > best:
            best = dd
            j1 = a
    e1 = nodes[idx[j1]] - p0
    l1 = _norm3(e1)
    if l1 <= tol:
        out = np.empty(1, dtype=np.int64)
        out[0] = idx[0]
        return out
    e1 = e1 / l1
    best = -1.0
    j2 = 0
    for a in range(k):
        d = nodes[idx[a]] - p0
        c = np.cross(e1, d)
        dd = _norm3(c)
        if dd > best:
            best = dd
            j2 = a
    if best <= tol:  # collinear: the two extreme points along e1
        lo, hi = 0, 0
        slo, shi = np.inf, -np.inf
        for a in range(k):
            s = _dot3(nodes[idx[a]] - p0, e1)
            if s < slo:
                slo = s
                lo = a
            if s > shi:
                shi = s
                hi = a
        out = np.empty(2, dtype=np.int64)
        out[0] = min(idx[lo], idx[hi])
        out[1] = max(idx[lo], idx[hi])
        return out
    nrm = np.cross(e1, nodes[idx[j2]] - p0)
    nrm = nrm / _norm3(nrm)
    e2 = np.cross(nrm, e1)
    u = np.empty(k)
    v = np.empty(k)
    for a in range(k):
        d = nodes[idx[a]] - p0
        if abs(_dot3(d, nrm)) > tol:
            return idx.copy()  # not coplanar: keep every node
        u[a] = _dot3(d, e1)
        v[a] = _dot3(d, e2)
    # Andrew's monotone chain; collinear points are dropped (cross ≤ tol·|edge|)
    order = np.argsort(u + 1e-12 * v)
    # stable lexicographic order (u, v)
    for a in range(1, k):
        b = a
        while b > 0 and (
            u[order[b - 1]] > u[order[b]]
            or (u[order[b - 1]] == u[order[b]] and v[order[b - 1]] > v[order[b]])
        ):
            tmp = order[b - 1]
            order[b - 1] = order[b]
            order[b] = tmp
            b -= 1
    hull = np.empty(2 * k, dtype=np.int64)
    h = 0
    for pass_ in range(2):
        start = h
        for q in range(k):
            a = order[q] if pass_ == 0 else order[k - 1 - q]
            while h - start >= 2:
                o = hull[h - 2]
                p = hull[h - 1]
                cr = (u[p] - u[o]) * (v[a] - v[o]) - (v[p] - v[o]) * (u[a] - u[o])
                ln = math.hypot(u[a] - u[o], v[a] - v[o])
                if cr <= tol * ln:
                    h -= 1
                else:
                    break
            hull[h] = a
            h += 1
        h -= 1  # the last point of each chain is the first of the other
    keep = np.zeros(k, dtype=np.bool_)
    for q in range(h):
        keep[hull[q]] = True
    n_keep = 0
    for a in range(k):
        if keep[a]:
            n_keep += 1
    out = np.empty(n_keep, dtype=np.int64)
    q = 0
    for a in range(k):
        if keep[a]:
            out[q] = idx[a]
            q += 1
    return out


# ----------------------------------------------------------------------------- contact problem
@njit(cache=True)
def _jacobians(r, slide, sdir, mu_d):
    """Measurement rows G_m and force rows G_f (3k, 6) = [d, r × d] per (n, x, y) of each
    contact; for a sliding contact the normal force row is n − μ_d ŝ (dynamic friction
    rides on the normal force)."""
    k = r.shape[0]
    gm = np.empty((3 * k, 6))
    gf = np.empty((3 * k, 6))
    _jacobians_into(r, slide, sdir, mu_d, gm, gf)
    return gm, gf


@njit(**_NO_REFCOUNT)
def _jacobians_into(r, slide, sdir, mu_d, gm, gf):
    """:func:`_jacobians` into the caller's ``gm``, ``gf`` (3k, 6) (zeroed here)."""
    k = r.shape[0]
    gm[:] = 0.0
    gf[:] = 0.0
    for i in range(k):
        rx, ry, rz = r[i, 0], r[i, 1], r[i, 2]
        # rows n = ez, x = ex, y = ey; angular parts r × d
        gm[3 * i, 2] = 1.0
        gm[3 * i, 3] = ry
        gm[3 * i, 4] = -rx
        gm[3 * i + 1, 0] = 1.0
        gm[3 * i + 1, 4] = rz
        gm[3 * i + 1, 5] = -ry
        gm[3 * i + 2, 1] = 1.0
        gm[3 * i + 2, 3] = -rz
        gm[3 * i + 2, 5] = rx
        for c in range(3):
            for j in range(6):
                gf[3 * i + c, j] = gm[3 * i + c, j]
        if slide[i]:
            d0 = -mu_d * sdir[i, 0]
            d1 = -mu_d * sdir[i, 1]
            d2 = 1.0 - mu_d * sdir[i, 2]
            gf[3 * i, 0] = d0
            gf[3 * i, 1] = d1
            gf[3 * i, 2] = d2
            gf[3 * i, 3] = ry * d2 - rz * d1
            gf[3 * i, 4] = rz * d0 - rx * d2
            gf[3 * i, 5] = rx * d1 - ry * d0


@njit(cache=True)
def contact_problem(R, lm, inertia_inv, mass, nodes_c, slide, sdir, stab, a_rel, mu_d):
    """The resting-contact problem a = A f + b (eqs. 3.6–3.7) of k contacts.

    Parameters
    ----------
    R : (3, 3) rotation; lm : (3,) angular momentum, kg m²/s; inertia_inv : (3, 3) body frame.
    mass : kg. nodes_c : (k, 3) contact nodes, body frame, m. slide : (k,) bool; sdir : (k, 3)
    unit sliding directions. stab : (3k,) velocity-stabilisation term, m/s². a_rel : (3,) the
    non-contact acceleration of the COM minus the pedestal's, m/s². mu_d : dynamic friction.

    Returns
    -------
    A : (3k, 3k) m/(N s²) per contact (n, x, y); b : (3k,) m/s²; gf : (3k, 6) force rows
    (wrench per unit force); omega2r : |ω|² max|r|, the size of the centripetal term that
    no contact force can cancel, m/s².
    """
    k = nodes_c.shape[0]
    n3 = 3 * k
    # A and gf in the layout of :func:`_forces`' workspace views ('A', :func:`_mat`): one
    # compilation of :func:`_contact_problem_into` for both callers
    A = _mat(np.empty(n3 * n3), 0, n3, n3)
    b = np.empty(n3)
    gf = _mat(np.empty(n3 * 6), 0, n3, 6)
    work = np.empty(n3 * 9 + 3 * k + 45)
    cons = _contact_problem_into(
        R, lm, inertia_inv, mass, nodes_c, np.arange(k), slide, sdir, stab, a_rel, mu_d, A, b, gf, work
    )
    return A, b, gf, cons


@njit(cache=True)
def _contact_problem_into(
    R, lm, inertia_inv, mass, nodes, idx, slide, sdir, stab, a_rel, mu_d, A, b, gf, work
):
    """:func:`contact_problem` of the nodes ``nodes[idx]`` (k contacts) into the caller's
    ``A`` (3k, 3k), ``b`` (3k,), ``gf`` (3k, 6), with ``work`` (≥ 27k + 3k + 45 floats)
    scratch; returns omega2r. The same operations in the same order (the 3 × 3 products of
    :func:`_mm`, :func:`_mmt`, :func:`_mv` on the same zero-filled skew matrices)."""
    k = idx.size
    n3 = 3 * k
    t33 = _mat(work, 0, 3, 3)
    iw = _mat(work, 9, 3, 3)
    wx = _mat(work, 18, 3, 3)
    sa = _mat(work, 27, 3, 3)
    kin = _mat(work, 36, 3, 3)
    gm = _mat(work, 45, n3, 6)
    H = _mat(work, 45 + 6 * n3, n3, 3)
    r = _mat(work, 45 + 9 * n3, k, 3)
    # iw = _mmt(_mm(R, inertia_inv), R)
    for i in range(3):
        for j in range(3):
            t33[i, j] = (
                R[i, 0] * inertia_inv[0, j] + R[i, 1] * inertia_inv[1, j] + R[i, 2] * inertia_inv[2, j]
            )
    for i in range(3):
        for j in range(3):
            iw[i, j] = t33[i, 0] * R[j, 0] + t33[i, 1] * R[j, 1] + t33[i, 2] * R[j, 2]
    # w = _mv(iw, lm)
    w0 = iw[0, 0] * lm[0] + iw[0, 1] * lm[1] + iw[0, 2] * lm[2]
    w1 = iw[1, 0] * lm[0] + iw[1, 1] * lm[1] + iw[1, 2] * lm[2]
    w2 = iw[2, 0] * lm[0] + iw[2, 1] * lm[1] + iw[2, 2] * lm[2]
    # r = _points_mt(nodes[idx], R)
    for a in range(k):
        p = idx[a]
        for j in range(3):
            r[a, j] = R[j, 0] * nodes[p, 0] + R[j, 1] * nodes[p, 1] + R[j, 2] * nodes[p, 2]
    # wx = _skew(w); alpha = -_mv(iw, _mv(wx, lm)); kin = _skew(alpha) + _mm(wx, wx)
    _skew_into(w0, w1, w2, wx)
    y0 = wx[0, 0] * lm[0] + wx[0, 1] * lm[1] + wx[0, 2] * lm[2]
    y1 = wx[1, 0] * lm[0] + wx[1, 1] * lm[1] + wx[1, 2] * lm[2]
    y2 = wx[2, 0] * lm[0] + wx[2, 1] * lm[1] + wx[2, 2] * lm[2]
    al0 = -(iw[0, 0] * y0 + iw[0, 1] * y1 + iw[0, 2] * y2)
    al1 = -(iw[1, 0] * y0 + iw[1, 1] * y1 + iw[1, 2] * y2)
    al2 = -(iw[2, 0] * y0 + iw[2, 1] * y1 + iw[2, 2] * y2)
    _skew_into(al0, al1, al2, sa)
    for i in range(3):
        for j in range(3):
            kin[i, j] = sa[i, j] + (wx[i, 0] * wx[0, j] + wx[i, 1] * wx[1, j] + wx[i, 2] * wx[2, j])
    rmax = 0.0
    for i in range(k):
        # acc = kin r_i + a_rel (as _mv(kin, r[i]) + a_rel, without the two arrays)
        r0, r1, r2 = r[i, 0], r[i, 1], r[i, 2]
        acc0 = (kin[0, 0] * r0 + kin[0, 1] * r1 + kin[0, 2] * r2) + a_rel[0]
        acc1 = (kin[1, 0] * r0 + kin[1, 1] * r1 + kin[1, 2] * r2) + a_rel[1]
        acc2 = (kin[2, 0] * r0 + kin[2, 1] * r1 + kin[2, 2] * r2) + a_rel[2]
        b[3 * i] = acc2 + stab[3 * i]
        b[3 * i + 1] = acc0 + stab[3 * i + 1]
        b[3 * i + 2] = acc1 + stab[3 * i + 2]
        rmax = max(rmax, math.sqrt(r0 * r0 + r1 * r1 + r2 * r2))
    _jacobians_into(r, slide, sdir, mu_d, gm, gf)
    # A = G_m M⁻¹ G_fᵀ through the 6 × 6 inverse mass (rank ≤ 6): H = G_f,ang I_w⁻¹ᵀ
    # (3k × 3), then A_pq = G_m,lin,p · G_f,lin,q / m + G_m,ang,p · H_q
    for q in range(n3):
        for c in range(3):
            H[q, c] = iw[c, 0] * gf[q, 3] + iw[c, 1] * gf[q, 4] + iw[c, 2] * gf[q, 5]
    inv_m = 1.0 / mass
    for p in range(n3):
        for q in range(n3):
            A[p, q] = (gm[p, 0] * gf[q, 0] + gm[p, 1] * gf[q, 1] + gm[p, 2] * gf[q, 2]) * inv_m + (
                gm[p, 3] * H[q, 0] + gm[p, 4] * H[q, 1] + gm[p, 5] * H[q, 2]
            )
    return (w0 * w0 + w1 * w1 + w2 * w2) * rmax


@njit(**_NO_REFCOUNT)
def _skew_into(w0, w1, w2, s):
    """s = :func:`_skew` (w) in place (its zeros included)."""
    s[0, 0] = 0.0
    s[0, 1] = -w2
    s[0, 2] = w1
    s[1, 0] = w2
    s[1, 1] = 0.0
    s[1, 2] = -w0
    s[2, 0] = -w1
    s[2, 1] = w0
    s[2, 2] = 0.0


@njit(cache=True)
def _check(A, b, f, status, mu, cons_tol, tdir):
    """Every condition of eqs. 3.6–3.7 for the active set ``status`` (0 free, 1 stick,
    2 slide: normal clamped, friction folded into A; 3 impending slip: normal clamped,
    friction μ f_n ŝ on the static cone, ŝ = ``tdir[i]``); returns (ok, a).

    For status 3 the tangential acceleration must oppose the friction force (maximum
    dissipation, as the cone solver's :func:`cone._disc_local_solve`): a_t = −λ ŝ with
    λ ≥ 0, i.e. its component across ŝ and its component along ŝ within the clamped rows'
    tolerance."""
    a = np.empty(b.size)
    return _check_into(A, b, f, status, mu, cons_tol, tdir, a), a


@njit(**_NO_REFCOUNT)
def _check_into(A, b, f, status, mu, cons_tol, tdir, a):
    """:func:`_check` with the accelerations written into the caller's ``a`` (3k,); returns ok."""
    k = status.size
    n3 = b.size
    for p in range(n3):
        a[p] = b[p]  # b.copy()
    for p in range(n3):
        for q in range(n3):
            a[p] += A[p, q] * f[q]
    bmax = 0.0
    for x in b:
        bmax = max(bmax, abs(x))
    tol = 1e-9 * bmax
    fmax = 0.0
    for i in range(k):
        fmax = max(fmax, abs(f[3 * i]))
    fscale = 1e-9 * fmax
    for i in range(k):
        st = status[i]
        fn = f[3 * i]
        if st > 0:
            if abs(a[3 * i]) > tol + cons_tol:
                return False
        if st == 1:
            if abs(a[3 * i + 1]) > tol + cons_tol or abs(a[3 * i + 2]) > tol + cons_tol:
                return False
        if fn < -fscale:
            return False
        if st == 0 and a[3 * i] < -tol:
            return False
        if st == 1 and math.hypot(f[3 * i + 1], f[3 * i + 2]) > mu[i] * fn * (1 + 1e-12) + fscale:
            return False
        if st == 3 and not _opposes(tdir[i, 0], tdir[i, 1], a[3 * i + 1], a[3 * i + 2], tol + cons_tol):
            return False
    return True


@njit(**_NO_REFCOUNT)
def _opposes(s0, s1, ax, ay, tol):
    """Whether the tangential acceleration (ax, ay) (m/s²) opposes the unit friction direction
    (s0, s1) of an impending slip: across it within ``tol`` and not along it by more than ``tol``
    (eqs. 3.6–3.7; :func:`_check_into` with the solve's direction, :func:`_slip_opposes` with the
    answer's)."""
    return not (abs(s0 * ay - s1 * ax) > tol or s0 * ax + s1 * ay > tol)  # (NaN passes, as before)


@njit(cache=True)
def _basis(a, rtol):
    """Orthonormal basis (n, r) of the column space of a (n, m): modified Gram–Schmidt with
    column pivoting; a column whose remaining norm is below ``rtol`` of the largest column
    norm counts as dependent."""
    n, m = a.shape
    out = np.empty((n, min(n, m)))
    r = _basis_into(a, rtol, np.empty((n, m)), np.empty(m), np.empty(m, dtype=np.bool_), out)
    return out[:, :r]


@njit(**_NO_REFCOUNT)
def _basis_into(a, rtol, q, norms, used, out):
    """:func:`_basis` into caller buffers — ``q`` (n, m), ``norms`` (m,), ``used`` (m,) bool
    scratch; the basis in ``out[:, :r]`` ((n, ≥ min(n, m))) — returns its rank r."""
    n, m = a.shape
    for i in range(n):
        for j in range(m):
            q[i, j] = a[i, j]
    big = 0.0
    for j in range(m):
        s = 0.0
        for i in range(n):
            s += q[i, j] * q[i, j]
        norms[j] = s
        big = max(big, s)
    used[:] = False
    r = 0
    if big == 0.0:
        return 0
    for _ in range(min(n, m)):
        jb = -1
        best = rtol * rtol * big
        for j in range(m):
            if not used[j] and norms[j] > best:
                best = norms[j]
                jb = j
        if jb < 0:
            break
        used[jb] = True
        nb = math.sqrt(norms[jb])
        for i in range(n):
            out[i, r] = q[i, jb] / nb
        for j in range(m):
            if not used[j]:
                d = 0.0
                for i in range(n):
                    d += out[i, r] * q[i, j]
                s = 0.0
                for i in range(n):
                    q[i, j] -= d * out[i, r]
                    s += q[i, j] * q[i, j]
                norms[j] = s
        r += 1
    return r


@njit(cache=True)
def _clamped_solve(A, b, status, scale):
    """Clamped rows of ``status`` solved for the forces f with A_EE f_E = −b_E in the
    least-squares sense, minimising ‖f_E / scale_E‖ among the solutions (``scale``: (3k,)
    weights, 1 for the plain minimum-norm split): :func:`_clamped_solve_into` into fresh
    arrays; returns (f (3k,), ok)."""
    n3 = 3 * status.size
    f = np.empty(n3)
    ok = _clamped_solve_into(
        A,
        b,
        status,
        scale,
        np.empty(_clamped_work(n3)),
        np.empty(n3, dtype=np.int64),
        np.empty(n3, dtype=np.int64),
        f,
    )
    return f, ok


@njit(cache=True)
def _clamped_work(n3):
    """Floats of :func:`_clamped_solve_into`'s scratch for 3k = ``n3`` rows."""
    return 8 * n3 * n3 + 5 * n3


@njit(cache=True)
def _clamped_solve_into(A, b, status, scale, ws, rows, used, f):
    """:func:`_clamped_solve` into the caller's buffers: ``ws`` (≥ :func:`_clamped_work` (3k)
    floats), ``rows`` and ``used`` ((3k,) int scratch), the forces in ``f`` (3k,); returns ok.
    Every sum is accumulated term by term in the order of the loops over its index (the
    products of the block, of its bases and of the right-hand side)."""
    k = status.size
    ne = 0
    for i in range(k):
        if status[i] > 0:
            rows[ne] = 3 * i
            ne += 1
        if status[i] == 1:
            rows[ne] = 3 * i + 1
            rows[ne + 1] = 3 * i + 2
            ne += 2
    for p in range(3 * k):
        f[p] = 0.0
    if ne == 0:
        return True
    # the work arrays as views of the caller's scratch
    nn = ne * ne
    sub = _mat(ws, 0, ne, ne)
    rhs = ws[8 * nn : 8 * nn + ne]
    # symmetric scaling: (S A S) u = −S b, f = S u (S = diag(scale_E))
    for p in range(ne):
        sp = scale[rows[p]]
        rhs[p] = -b[rows[p]] * sp
        for q in range(ne):
            sub[p, q] = sp * A[rows[p], rows[q]] * scale[rows[q]]
    # minimum-norm least-squares solution x = A⁺ rhs: with Qc, Qr orthonormal bases of the
    # column and row spaces of the (rank-r) block, x = Qr (Qcᵀ A Qr)⁻¹ Qcᵀ rhs — the part of
    # rhs outside the column space (which no force can reach) is left over, and x has no
    # component along the redundant (null-space) directions
    subt = _mat(ws, nn, ne, ne)
    for p in range(ne):
        for q in range(ne):
            subt[p, q] = sub[q, p]
    use = used[0:ne]
    scratch = _mat(ws, 2 * nn, ne, ne)
    norms = ws[8 * nn + ne : 8 * nn + 2 * ne]
    qc = _mat(ws, 3 * nn, ne, ne)  # basis columns 0 … r − 1
    qr = _mat(ws, 4 * nn, ne, ne)
    r = _basis_into(sub, 1e-10, scratch, norms, use, qc)
    if _basis_into(subt, 1e-10, scratch, norms, use, qr) != r:
        return False
    if r == 0:
        return True
    aq = _mat(ws, 5 * nn, ne, r)  # sub @ qr
    for p in range(ne):
        for c in range(r):
            acc = 0.0
            for q in range(ne):
                acc += sub[p, q] * qr[q, c]
            aq[p, c] = acc
    K = _mat(ws, 6 * nn, r, r)  # qcᵀ sub qr
    g = ws[8 * nn + 2 * ne : 8 * nn + 2 * ne + r]  # qcᵀ rhs
    for c1 in range(r):
        acc = 0.0
        for p in range(ne):
            acc += qc[p, c1] * rhs[p]
        g[c1] = acc
        for c2 in range(r):
            acc = 0.0
            for p in range(ne):
                acc += qc[p, c1] * aq[p, c2]
            K[c1, c2] = acc
    y = g  # solved in place (K and g are not needed after)
    if not _lu_solve_inplace(K, y):
        return False
    for p in range(ne):
        acc = 0.0
        for c in range(r):
            acc += qr[p, c] * y[c]
        f[rows[p]] = acc * scale[rows[p]]
    return True


@njit(**_NO_REFCOUNT)
def _count_slip(st):
    m = 0
    for i in range(st.size):
        if st[i] == 3:
            m += 1
    return m


@njit(cache=True)
def _solve_status(A, b, st, mu, tdir, scale):
    """Forces of the active set ``st`` (:func:`_clamped_solve`); an impending-slip contact
    (status 3) has one unknown, f_n, with the friction μ f_n ŝ folded into its column of A
    (A e_n + μ A e_t ŝ, as :func:`contact_problem` folds dynamic friction into a sliding
    contact's force row), and its friction filled in afterwards."""
    m = _count_slip(st)
    if m == 0:
        return _clamped_solve(A, b, st, scale)
    n3 = A.shape[0]
    # a copy of A in the layout of :func:`_forces`' A ('A', :func:`_mat`): one compilation of
    # :func:`_clamped_solve`
    Af = _mat(np.empty(n3 * n3), 0, n3, n3)
    Af[:] = A
    for i in range(st.size):
        if st[i] == 3:
            c0 = mu[i] * tdir[i, 0]
            c1 = mu[i] * tdir[i, 1]
            for p in range(n3):
                Af[p, 3 * i] = A[p, 3 * i] + c0 * A[p, 3 * i + 1] + c1 * A[p, 3 * i + 2]
    f, ok = _clamped_solve(Af, b, st, scale)
    for i in range(st.size):
        if st[i] == 3:
            f[3 * i + 1] = mu[i] * tdir[i, 0] * f[3 * i]
            f[3 * i + 2] = mu[i] * tdir[i, 1] * f[3 * i]
    return f, ok


@njit(cache=True)
def _slip_residual(A, b, f, st, tdir, js):
    """Tangential acceleration across ŝ, ŝ × a_t, of each impending-slip contact ``js``."""
    m = js.size
    r = np.empty(m)
    for q in range(m):
        i = js[q]
        ax = b[3 * i + 1]
        ay = b[3 * i + 2]
        for p in range(b.size):
            ax += A[3 * i + 1, p] * f[p]
            ay += A[3 * i + 2, p] * f[p]
        r[q] = tdir[i, 0] * ay - tdir[i, 1] * ax
    return r


#: Newton iterations on the impending-slip directions per active-set solve
SLIP_NEWTON_ITERATIONS = 8
#: finite-difference step of that Newton iteration's Jacobian, rad
SLIP_FD_STEP = 1e-7


@njit(cache=True, inline="always")
def _slip_directions(A, b, st, mu, tdir, scale, f, rtol):
    """Newton iteration on the angles of the impending-slip directions ŝ (``tdir``, updated
    in place) until every such contact's tangential acceleration is parallel to ŝ (ŝ × a_t
    below ``rtol``); the Jacobian by forward differences (one solve per direction).
    Returns the forces of the last directions; :func:`_check` decides."""
    m = _count_slip(st)
    js = np.empty(m, dtype=np.int64)
    q = 0
    for i in range(st.size):
        if st[i] == 3:
            js[q] = i
            q += 1
    r = _slip_residual(A, b, f, st, tdir, js)
    td = tdir.copy()
    J = np.empty((m, m))
    for _ in range(SLIP_NEWTON_ITERATIONS):
        rmax = 0.0
        for q in range(m):
            rmax = max(rmax, abs(r[q]))
        if rmax <= rtol:
            break
        h = SLIP_FD_STEP
        ch, sh = math.cos(h), math.sin(h)
        for q in range(m):
            i = js[q]
            s0, s1 = tdir[i, 0], tdir[i, 1]
            td[i, 0] = ch * s0 - sh * s1
            td[i, 1] = sh * s0 + ch * s1
            fh, solved = _solve_status(A, b, st, mu, td, scale)
            td[i, 0], td[i, 1] = s0, s1
            if not solved:
                return f
            # the residual of contact q is measured across its own rotated direction
            for p in range(m):
                j = js[p]
                if p == q:
                    c0 = ch * s0 - sh * s1
                    c1 = sh * s0 + ch * s1
                else:
                    c0, c1 = tdir[j, 0], tdir[j, 1]
                ax = b[3 * j + 1]
                ay = b[3 * j + 2]
                for c in range(b.size):
                    ax += A[3 * j + 1, c] * fh[c]
                    ay += A[3 * j + 2, c] * fh[c]
                J[p, q] = (c0 * ay - c1 * ax - r[p]) / h
        dth, solved = _lu_solve(J, -r)
        if not solved:
            return f
        for q in range(m):
            i = js[q]
            d = max(-0.5, min(0.5, dth[q]))
            s0, s1 = tdir[i, 0], tdir[i, 1]
            c, s = math.cos(d), math.sin(d)
            tdir[i, 0] = c * s0 - s * s1
            tdir[i, 1] = s * s0 + c * s1
            td[i, 0], td[i, 1] = tdir[i, 0], tdir[i, 1]
        f, solved = _solve_status(A, b, st, mu, tdir, scale)
        if not solved:
            return f
        r = _slip_residual(A, b, f, st, tdir, js)
    return f


@njit(cache=True)
def active_set_solve(A, b, status, mu, cons_tol, max_rounds, tdir, slide):
    """Exact solve of eqs. 3.6–3.7 on a guessed active set, verified; a few corrections.

    Clamped rows (all three of a sticking contact, the normal of a sliding or impending-slip
    one) satisfy A_EE f_E = −b_E, solved as the minimum-norm least-squares solution (through
    orthonormal bases of the block's column and row spaces, :func:`_basis`): redundant forces
    are split with minimum norm, and the part of b_E no force can reach is left over.  An
    answer is accepted only if it satisfies every condition of eqs. 3.6–3.7 — f_n ≥ 0, a_n ≥ 0
    on free contacts, the static cone on sticking ones, friction opposing the tangential
    acceleration on impending-slip ones — and the clamped rows' residual is within
    1e-9 |b| + ``cons_tol`` (``cons_tol``: the centripetal part |ω|² r of b, which no contact
    force can cancel on three or more sticking points; zero at rest).  When it fails,
    contacts pulled into tension are freed and free contacts that would penetrate are clamped,
    and the solve is repeated (at most ``max_rounds`` rounds); when no such change is left, a
    sticking contact whose force leaves its cone is put at the cone's boundary (impending
    slip, status 3, friction along its least-squares force) and an impending-slip contact whose
    acceleration goes with its friction sticks again.  When that fails too and the first
    answer put a sticking contact's force outside its cone (often with a normal pulling,
    which the first corrections then free), the rounds are repeated once from the guess
    "those contacts at the cone's boundary, along their first force".

    Impending slip (status 3): the contact does not slide yet (|v_t| ≤ the slip velocity) but
    its static friction is saturated, f_t = μ f_n ŝ, and the tangential acceleration opposes
    it, a_t = −λ ŝ, λ ≥ 0 (eq. 3.7 with maximum dissipation). The unknown direction ŝ is found
    by a Newton iteration on its angle (:func:`_slip_directions`), starting from ``tdir``.

    Parameters
    ----------
    A : (3k, 3k); b : (3k,); status : (k,) int guess (0 free, 1 stick, 2 slide, 3 impending
    slip); mu : (k,) static friction; cons_tol : m/s² (or m/s for impacts); max_rounds : int;
    tdir : (k, 2) unit tangential directions (x, y) of the friction of the status-3 contacts
    of the guess (other rows unused).
    slide : (k,) bool, the contacts that slide (dynamic friction folded into A's normal
    column): a free one that would penetrate is clamped as sliding (status 2), a free
    non-sliding one as sticking (status 1).

    Returns
    -------
    (ok, f (3k,), a (3k,), status (k,) of the answer).
    """
    k = status.size
    guess = status
    td = tdir
    # one call site of :func:`_active_set_rounds` (inlined: its code once in this function),
    # the second pass from the retry guess
    for attempt in range(2):
        ok, f, a, st, first = _active_set_rounds(A, b, guess, mu, cons_tol, max_rounds, td, slide)
        if ok or attempt == 1:
            break
        guess = status.copy()
        # a copy of tdir in the layout of tdir's in :func:`_forces` ('A', :func:`_mat`)
        td = _mat(np.empty(2 * k), 0, k, 2)
        td[:] = tdir
        retry = False
        for i in range(k):
            if status[i] == 1 and mu[i] > 0:
                ft = math.hypot(first[3 * i + 1], first[3 * i + 2])
                if ft > mu[i] * max(first[3 * i], 0.0) * (1 + 1e-12) and ft > 0:
                    guess[i] = 3
                    td[i, 0] = first[3 * i + 1] / ft
                    td[i, 1] = first[3 * i + 2] / ft
                    retry = True
        if not retry:
            break
    return ok, f, a, st


@njit(cache=True, inline="always")
def active_set_retry(A, b, status, mu, cons_tol, max_rounds, tdir, slide, stab):
    """The resting solve's second try, after :func:`active_set_solve` failed from ``status``
    (same arguments, plus ``stab`` (3k,), m/s², the velocity-stabilisation part of b); run
    only then, so that every solve the first try answers is unchanged. Returns as
    :func:`active_set_solve`.

    Two cases the first try cannot answer (issue 23, ninth pass; recorded in SP1's campaign):

    * a stale impending slip: a contact guessed at the cone's boundary (status 3, from the
      last solve) whose tangential acceleration is now zero is never released by the rounds
      (they release it only when its acceleration goes with its friction), and when the
      friction another sticking contact needs leaves that one's cone, the rounds cycle
      between "stick" and "impending slip" there. Retried from the guess with every
      status-3 contact sticking.
    * a stabilisation no force can reach: the tangential rows of ``stab`` are zero on sliding
      contacts and its components below 1e-8 m/s are zeroed (until 2026-11-28 its normal rows
      were also zero on receding contacts: min(v_n, 0)/dt), so it is not
      the acceleration field of a rigid body; on three sticking contacts (9 rows, rank 6) its
      component outside A's range is left in the clamped rows' least-squares residual, and
      exceeds the tolerance (1e-9 |b| + ``cons_tol``, which bounds only the centripetal term).
      Retried with ``cons_tol`` + 2 |stab|₂, a bound on that component (an orthogonal
      projection is no longer than the vector), as ``cons_tol`` = 2 |ω|² r bounds the
      centripetal one. Every other condition of eqs. 3.6–3.7 is still verified, the
      impending-slip direction (friction opposing the tangential acceleration) at the first
      try's tolerance (:func:`_slip_opposes`).
    """
    k = status.size
    n_slip = _count_slip(status)
    stick = status.copy()
    for i in range(k):
        if stick[i] == 3:
            stick[i] = 1
    if n_slip > 0:
        ok, f, a, st = active_set_solve(A, b, stick, mu, cons_tol, max_rounds, tdir, slide)
        if ok:
            return ok, f, a, st
    s2 = 0.0
    for x in stab:
        s2 += x * x
    if s2 == 0.0:
        return False, np.zeros(b.size), b.copy(), status.copy()
    tol2 = cons_tol + 2.0 * math.sqrt(s2)
    ok, f, a, st = active_set_solve(A, b, status, mu, tol2, max_rounds, tdir, slide)
    if ok and _slip_opposes(b, f, a, st, cons_tol):
        return ok, f, a, st
    if n_slip == 0:
        return False, f, a, st
    ok, f, a, st = active_set_solve(A, b, stick, mu, tol2, max_rounds, tdir, slide)
    return ok and _slip_opposes(b, f, a, st, cons_tol), f, a, st


@njit(**_NO_REFCOUNT)
def _slip_opposes(b, f, a, st, cons_tol):
    """Whether every impending-slip contact (status 3) of an answer has its tangential
    acceleration opposite its friction (across it and along it within 1e-9 |b| + ``cons_tol``,
    as :func:`_check`): the widened tolerance of :func:`active_set_retry` is for the clamped
    rows' residual only, not for this condition (without it, contacts that stick in the exact
    answer were let slip at up to 0.2 m/s²)."""
    bmax = 0.0
    for x in b:
        bmax = max(bmax, abs(x))
    tol = 1e-9 * bmax + cons_tol
    for i in range(st.size):
        if st[i] == 3:
            ft = math.hypot(f[3 * i + 1], f[3 * i + 2])
            if ft <= 0.0:
                return False
            if not _opposes(f[3 * i + 1] / ft, f[3 * i + 2] / ft, a[3 * i + 1], a[3 * i + 2], tol):
                return False
    return True


@njit(cache=True)
def _active_set_work(n3):
    """Floats of :func:`_active_set_solve_into`'s scratch for 3k = ``n3`` rows."""
    return 3 * n3 + _clamped_work(n3)


@njit(cache=True, inline="always")
def _active_set_solve_into(A, b, status, mu, cons_tol, max_rounds, tdir, slide, ws, iws):
    """:func:`active_set_solve` with its common case in the caller's scratch (``ws``: ≥
    :func:`_active_set_work` (3k) floats, ``iws``: (≥ 6k,) int): a guess without impending
    slip whose first solve verifies — the first attempt of :func:`_active_set_rounds`, the
    same operations; the answer's arrays are views of the scratch, its status the guess
    itself. Any other case is :func:`active_set_solve` (which repeats that first solve)."""
    n3 = b.size
    if max_rounds > 0 and _count_slip(status) == 0:
        f = ws[0:n3]
        a = ws[n3 : 2 * n3]
        scale = ws[2 * n3 : 3 * n3]
        for p in range(n3):
            scale[p] = 1.0
        if _clamped_solve_into(A, b, status, scale, ws[3 * n3 :], iws[0:n3], iws[n3 : 2 * n3], f):
            if _check_into(A, b, f, status, mu, cons_tol, tdir, a):
                return True, f, a, status
    return active_set_solve(A, b, status, mu, cons_tol, max_rounds, tdir, slide)


@njit(cache=True, inline="always")
def _free_unloaded_slip(A, b, f, a, st, mu, cons_tol, tdir):
    """An impending-slip contact whose normal force is zero within the verification's
    tolerance (|f_n| ≤ 1e-9 max f_n: a contact that carries nothing) is freed — status 0, no
    force — when the answer still verifies so (``f``, ``a``, ``st`` updated in place): its
    friction μ f_n ŝ would otherwise be round-off of either sign."""
    k = st.size
    fmax = 0.0
    for i in range(k):
        fmax = max(fmax, abs(f[3 * i]))
    any_free = False
    for i in range(k):
        if st[i] == 3 and abs(f[3 * i]) <= 1e-9 * fmax:
            any_free = True
    if not any_free:
        return
    changed = False
    f2 = f.copy()
    st2 = st.copy()
    for i in range(k):
        if st[i] == 3 and abs(f[3 * i]) <= 1e-9 * fmax:
            st2[i] = 0
            f2[3 * i] = 0.0
            f2[3 * i + 1] = 0.0
            f2[3 * i + 2] = 0.0
            changed = True
    if not changed:
        return
    ok, a2 = _check(A, b, f2, st2, mu, cons_tol, tdir)
    if ok:
        f[:] = f2
        a[:] = a2
        st[:] = st2


@njit(cache=True, inline="always")
def _active_set_rounds(A, b, status, mu, cons_tol, max_rounds, tdir, slide):
    """The rounds of :func:`active_set_solve` from one guess: (ok, f, a, status, the first
    answer's forces (3k,))."""
    st = status.copy()
    td = tdir.copy()
    k = st.size
    first = np.zeros(3 * k)
    n_answers = 0
    f = np.zeros(3 * k)
    a = b.copy()
    # (f and a are rebound, never written in place, before an answer is accepted: the
    # fallback answer can share their arrays)
    f1 = f
    a1 = a
    scale = np.ones(3 * k)
    bmax = 0.0
    for x in b:
        bmax = max(bmax, abs(x))
    for _ in range(max_rounds):
        for attempt in range(2):
            if attempt == 1:
                # the plain split failed: weight the friction of each sticking contact by
                # √(μ f_n) of the last answer, so that redundant friction is shared in
                # proportion to the cone radii (uniform use of the cones under shear)
                fmean = 0.0
                cnt = 0
                for i in range(k):
                    if st[i] == 1 and f[3 * i] > 0:
                        fmean += mu[i] * f[3 * i]
                        cnt += 1
                if cnt == 0 or fmean <= 0:
                    break
                fmean /= cnt
                for i in range(k):
                    s = math.sqrt(max(mu[i] * f[3 * i], 1e-6 * fmean) / fmean)
                    scale[3 * i + 1] = s
                    scale[3 * i + 2] = s
            f_try, solved = _solve_status(A, b, st, mu, td, scale)
            if not solved:
                continue
            if _count_slip(st) > 0:
                f_try = _slip_directions(A, b, st, mu, td, scale, f_try, 1e-11 * bmax)
            f = f_try
            if n_answers == 0:
                first[:] = f
            n_answers += 1
            ok, a = _check(A, b, f, st, mu, cons_tol, td)
            if ok:
                _free_unloaded_slip(A, b, f, a, st, mu, cons_tol, td)
                return True, f, a, st, first
            if attempt == 0:
                a1 = a.copy()
                f1 = f.copy()
        f = f1
        a = a1
        for j in range(3 * k):
            scale[j] = 1.0
        # correction of the guess from the last (least-squares) answer
        changed = False
        fmax = 0.0
        for i in range(k):
            fmax = max(fmax, abs(f[3 * i]))
        for i in range(k):
            if st[i] > 0 and f[3 * i] < -1e-9 * fmax:
                st[i] = 0
                changed = True
            elif st[i] == 0 and a[3 * i] < -1e-9 * bmax:
                st[i] = 2 if slide[i] else 1
                changed = True
        if not changed:
            # the normal statuses hold: correct the friction statuses (impending slip)
            for i in range(k):
                fn = f[3 * i]
                if st[i] == 1 and fn > 0:
                    ft = math.hypot(f[3 * i + 1], f[3 * i + 2])
                    if ft > mu[i] * fn * (1 + 1e-12) and mu[i] > 0:
                        st[i] = 3
                        td[i, 0] = f[3 * i + 1] / ft
                        td[i, 1] = f[3 * i + 2] / ft
                        changed = True
                elif st[i] == 3:
                    along = td[i, 0] * a[3 * i + 1] + td[i, 1] * a[3 * i + 2]
                    if along > 1e-9 * bmax + cons_tol:
                        st[i] = 1
                        changed = True
        if not changed:
            break
    return False, f, a, st, first


#: relative tolerance of :func:`lcp_unique`'s check (that of ``pivoting.VERIFY_RTOL``)
UNIQUE_RTOL = 1e-9
#: :func:`lcp_unique` answers only when λ_min(M) > this × λ_max(M) (then the selection of
#: ``selection.solve_lcp_min_norm`` has no null space to choose in: its SVD rank test uses 1e-10)
UNIQUE_COND = 1e-8
#: :func:`lcp_unique` answers only up to this many unknowns (2ⁿ principal subsets)
UNIQUE_MAX_N = 6


@njit(cache=True)
def _lcp_scales(M, q):
    """(max |q_i|, max |M_ij|): the scales of the LCP tolerances of :func:`lcp_unique` and
    :func:`lcp_select`."""
    n = q.size
    mmax = 0.0
    qmax = 0.0
    for i in range(n):
        qmax = max(qmax, abs(q[i]))
        for j in range(n):
            mmax = max(mmax, abs(M[i, j]))
    return qmax, mmax


@njit(cache=True)
def _subset_solution(M, q, mask, idx, minnorm):
    """The candidate z of one principal subset (the bits of ``mask``) of the LCP (M, q):
    z_S solves M[S, S] z_S = −q_S (LU, or the minimum-norm least-squares solve of
    :func:`_minnorm_solve` when ``minnorm``), z = 0 off S; (z, solved). ``idx`` (n,) is scratch."""
    n = q.size
    m = 0
    for i in range(n):
        if mask >> i & 1:
            idx[m] = i
            m += 1
    zt = np.zeros(n)
    if m > 0:
        sub = np.empty((m, m))
        rhs = np.empty(m)
        for a in range(m):
            rhs[a] = -q[idx[a]]
            for b in range(m):
                sub[a, b] = M[idx[a], idx[b]]
        if minnorm:
            x, solved = _minnorm_solve(sub, rhs)
        else:
            x, solved = _lu_solve(sub, rhs)
        if not solved:
            return zt, False
        for a in range(m):
            zt[idx[a]] = x[a]
    return zt, True


@njit(cache=True)
def lcp_unique(M, q):
    """The LCP w = M z + q ≥ 0, z ≥ 0, zᵀw = 0 for a small, well-conditioned symmetric
    positive definite M, by enumerating the principal subsets: (ok, z).

    A positive definite M is a P-matrix, so the LCP has exactly one solution; every exact
    method (the paper's Dantzig pivoting, :func:`pivoting.dantzig`) returns it, up to
    round-off. ``ok`` is False — the caller then pivots — when n > ``UNIQUE_MAX_N``, when
    M is not positive definite with λ_min > ``UNIQUE_COND`` λ_max (the bound used:
    λ_min ≥ 1 / tr M⁻¹, λ_max ≤ tr M, from the Cholesky factor), or when no subset passes
    the check (z ≥ −tol, w ≥ −tol on the free rows, tol = ``UNIQUE_RTOL`` × max(|q|, |M||z|)).
    """
    n = q.size
    z = np.zeros(n)
    if n == 0:
        return True, z
    if n > UNIQUE_MAX_N:
        return False, z
    # Cholesky M = L Lᵀ, then tr M⁻¹ = ‖L⁻¹‖_F²
    L = np.zeros((n, n))
    for j in range(n):
        s = M[j, j]
        for c in range(j):
            s -= L[j, c] * L[j, c]
        if not s > 0.0:
            return False, z
        L[j, j] = math.sqrt(s)
        for i in range(j + 1, n):
            s = M[i, j]
            for c in range(j):
                s -= L[i, c] * L[j, c]
            L[i, j] = s / L[j, j]
    tr = 0.0
    for i in range(n):
        tr += M[i, i]
    linv = np.zeros((n, n))
    for j in range(n):
        linv[j, j] = 1.0 / L[j, j]
        for i in range(j + 1, n):
            s = 0.0
            for c in range(j, i):
                s -= L[i, c] * linv[c, j]
            linv[i, j] = s / L[i, i]
    tri = 0.0
    for i in range(n):
        for j in range(n):
            tri += linv[i, j] * linv[i, j]
    if not 1.0 / tri > UNIQUE_COND * tr:
        return False, z
    qmax, mmax = _lcp_scales(M, q)
    idx = np.empty(n, dtype=np.int64)
    for mask in range(1 << n):
        zt, solved = _subset_solution(M, q, mask, idx, np.bool_(False))  # not a literal: one compilation
        if not solved:
            continue
        zmax = 0.0
        for i in range(n):
            zmax = max(zmax, abs(zt[i]))
        tol = UNIQUE_RTOL * max(1e-300, qmax, mmax * zmax)
        good = True
        for i in range(n):
            if zt[i] < -tol:
                good = False
                break
        if not good:
            continue
        for i in range(n):
            if zt[i] < 0.0:
                zt[i] = 0.0
        for i in range(n):
            if not (mask >> i & 1):
                w = q[i]
                for j in range(n):
                    w += M[i, j] * zt[j]
                if w < -tol:
                    good = False
                    break
        if good:
            return True, zt
    return False, z


#: :func:`lcp_select` tolerances (those of ``selection.solve_lcp_min_norm``): the support set
#: w*_i ≤ SELECT_SUPPORT_RTOL × scale, the null space below SELECT_RANK_RTOL of the largest
#: column norm
SELECT_SUPPORT_RTOL = 1e-9
SELECT_RANK_RTOL = 1e-10


@njit(cache=True, inline="always")
def _minnorm_solve(sub, rhs):
    """Minimum-norm least-squares solution x = sub⁺ rhs of a small square system (the
    orthonormal-basis construction of :func:`_clamped_solve`); ok flag."""
    n = rhs.size
    x = np.zeros(n)
    qc = _basis(sub, 1e-10)
    qr = _basis(sub.T.copy(), 1e-10)
    r = qc.shape[1]
    if qr.shape[1] != r:
        return x, False
    if r == 0:
        return x, True
    K = np.zeros((r, r))
    g = np.zeros(r)
    for c1 in range(r):
        for p in range(n):
            g[c1] += qc[p, c1] * rhs[p]
            for c2 in range(r):
                s = 0.0
                for q_ in range(n):
                    s += sub[p, q_] * qr[q_, c2]
                K[c1, c2] += qc[p, c1] * s
    y, ok = _lu_solve(K, g)
    if not ok:
        return x, False
    for p in range(n):
        for c in range(r):
            x[p] += qr[p, c] * y[c]
    return x, True


@njit(cache=True, inline="always")
def lcp_select(M, q, ref):
    """The solution of the LCP w = M z + q ≥ 0, z ≥ 0, zᵀw = 0 (M symmetric PSD, small,
    singular) closest to ``ref`` — ``selection.solve_lcp_min_norm``'s answer — when the
    solution set is a segment (a one-dimensional null space on the support, e.g. four
    coplanar contacts of a flat landing): (ok, z).

    A first solution z₀ by enumerating the principal subsets (minimum-norm least-squares
    solves, :func:`_minnorm_solve`; for PSD M every solution has the same w*); the solution
    set is {z ≥ 0 : z_i = 0 off S = {w*_i = 0}, M[:, S] z_S = w* − q} = z₀ + n y on S
    (n spanning null(M[:, S])), and the closest point to ``ref`` is y* = n·(ref − z₀) clipped
    to the interval where z₀ + n y ≥ 0. ``ok`` is False (the caller selects in Python) when
    n > ``UNIQUE_MAX_N``, no subset passes, or the null space is not one-dimensional."""
    n = q.size
    z = np.zeros(n)
    if n == 0 or n > UNIQUE_MAX_N:
        return False, z
    qmax, mmax = _lcp_scales(M, q)
    idx = np.empty(n, dtype=np.int64)
    found = False
    for mask in range(1 << n):
        zt, solved = _subset_solution(M, q, mask, idx, np.bool_(True))
        if not solved:
            continue
        zmax = 0.0
        for i in range(n):
            zmax = max(zmax, abs(zt[i]))
        tol = UNIQUE_RTOL * max(1e-300, qmax, mmax * zmax)
        good = True
        for i in range(n):
            if zt[i] < -tol:
                good = False
                break
        if not good:
            continue
        for i in range(n):
            w = q[i]
            for j in range(n):
                w += M[i, j] * zt[j]
            # clamped rows: w = 0 (the subset's system must be consistent); free rows: w ≥ 0
            if (mask >> i & 1 and abs(w) > tol) or w < -tol:
                good = False
                break
        if good:
            for i in range(n):
                z[i] = max(zt[i], 0.0)
            found = True
            break
    if not found:
        return False, z
    # the support S of w* and the null space of M[:, S]
    zmax = 0.0
    for i in range(n):
        zmax = max(zmax, abs(z[i]))
    wstar = q.copy()
    for i in range(n):
        for j in range(n):
            wstar[i] += M[i, j] * z[j]
    sup = np.empty(n, dtype=np.int64)
    ns = 0
    for i in range(n):
        if wstar[i] <= SELECT_SUPPORT_RTOL * max(qmax, mmax * zmax, 1e-300):
            sup[ns] = i
            ns += 1
    if ns == 0:
        return True, z
    ms_t = np.empty((ns, n))  # M[:, S]ᵀ
    for a in range(ns):
        for i in range(n):
            ms_t[a, i] = M[i, sup[a]]
    rowb = _basis(ms_t, SELECT_RANK_RTOL)  # (ns, rank): the row space of M[:, S]
    d = ns - rowb.shape[1]
    if d == 0:
        return True, z
    if d != 1:
        return False, z
    # the null direction: the unit vector of R^ns orthogonal to the row space (Gram–Schmidt
    # of the identity column that keeps the most after projecting the basis out)
    best = -1.0
    nv = np.zeros(ns)
    for c in range(ns):
        e = np.zeros(ns)
        e[c] = 1.0
        for b in range(rowb.shape[1]):
            dd = rowb[c, b]
            for a in range(ns):
                e[a] -= dd * rowb[a, b]
        nn = 0.0
        for a in range(ns):
            nn += e[a] * e[a]
        if nn > best:
            best = nn
            nv = e / math.sqrt(nn)
    y = 0.0
    for a in range(ns):
        y += nv[a] * (ref[sup[a]] - z[sup[a]])
    lo, hi = -np.inf, np.inf
    for a in range(ns):
        if nv[a] > 0:
            lo = max(lo, -z[sup[a]] / nv[a])
        elif nv[a] < 0:
            hi = min(hi, -z[sup[a]] / nv[a])
    y = min(max(y, lo), hi)
    zs = z.copy()
    for a in range(ns):
        zs[sup[a]] = z[sup[a]] + nv[a] * y
    # feasibility, as the Python selection checks it
    zmax2 = 0.0
    for i in range(n):
        zmax2 = max(zmax2, abs(zs[i]))
    vt = UNIQUE_RTOL * max(1e-300, qmax, mmax * zmax2)
    for i in range(n):
        if zs[i] < -vt:
            return False, z
        w = q[i]
        for j in range(n):
            w += M[i, j] * zs[j]
        if abs(w - wstar[i]) > 1e3 * vt:
            return False, z
    for i in range(n):
        z[i] = max(zs[i], 0.0)
    return True, z


# ----------------------------------------------------------------------------- one step
@njit(cache=True)
def _kinematics(x, v, R, lm, inertia_inv, nodes, cand, d, vp, ped_kind, hx, hy):
    """Lever arms r (N, 3), gaps (N,), relative velocities (N, 3) in the (n, x, y) basis, ω —
    of the candidate nodes ``cand`` (the others: gap +inf, r and velocity left unset):
    :func:`_kinematics_into` into fresh arrays."""
    n = nodes.shape[0]
    r = np.empty((n, 3))
    gaps = np.full(n, np.inf)
    vel = np.empty((n, 3))
    w0, w1, w2 = _kinematics_into(
        x, v, R, lm, inertia_inv, nodes, cand, d, vp, ped_kind, hx, hy, r, gaps, vel
    )
    w = np.empty(3)
    w[0] = w0
    w[1] = w1
    w[2] = w2
    return r, gaps, vel, w


@njit(**_NO_REFCOUNT)
def _kinematics_into(x, v, R, lm, inertia_inv, nodes, cand, d, vp, ped_kind, hx, hy, r, gaps, vel):
    """The lever arms, gaps and velocities of :func:`_kinematics` of the candidate nodes
    ``cand`` into the caller's ``r`` (N, 3), ``gaps`` (N,) and ``vel`` (N, 3) — the other
    nodes' entries are not written — and ω (:func:`_omega3`) as three floats."""
    w0, w1, w2 = _omega3(R, inertia_inv, lm)
    for c in range(cand.size):
        i = cand[c]
        for j in range(3):
            r[i, j] = R[j, 0] * nodes[i, 0] + R[j, 1] * nodes[i, 1] + R[j, 2] * nodes[i, 2]
        px = x[0] + r[i, 0] - d[0]
        py = x[1] + r[i, 1] - d[1]
        gaps[i] = x[2] + r[i, 2] - d[2]
        if ped_kind == 1 and (abs(px) > hx or abs(py) > hy):
            gaps[i] = np.inf
        vx = v[0] + w1 * r[i, 2] - w2 * r[i, 1] - vp[0]
        vy = v[1] + w2 * r[i, 0] - w0 * r[i, 2] - vp[1]
        vz = v[2] + w0 * r[i, 1] - w1 * r[i, 0] - vp[2]
        vel[i, 0] = vz
        vel[i, 1] = vx
        vel[i, 2] = vy
    return w0, w1, w2


@njit(cache=True)
def kinematics(sv, inertia_inv, nodes, cand, d, vp, ped_kind, hx, hy):
    """:func:`_kinematics` of the packed state ``sv`` (18,) = (x, v, R row-major, l)."""
    return _kinematics(
        sv[0:3], sv[3:6], sv[6:15].reshape(3, 3), sv[15:18], inertia_inv, nodes, cand, d, vp, ped_kind, hx, hy
    )


@njit(cache=True)
def impact_pending(sv, inertia_inv, nodes, cand, d, vp, eps, v_imp, ped_kind, hx, hy):
    """True when an in-band node (gap ≤ ε) approaches faster than ``v_imp`` (eq. 3.5 trigger).

    ``sv`` is the packed state (18,) = (x, v, R row-major, l); ``cand`` the candidate nodes."""
    x = sv[0:3]
    v = sv[3:6]
    R = sv[6:15].reshape(3, 3)
    lm = sv[15:18]
    _, gaps, vel, _ = _kinematics(x, v, R, lm, inertia_inv, nodes, cand, d, vp, ped_kind, hx, hy)
    for c in range(cand.size):
        i = cand[c]
        if gaps[i] <= eps and vel[i, 0] < -v_imp:
            return True
    return False


@njit(cache=True)
def contact_set(gaps, vel, nodes, cand, eps, v_sep, v_slip, mu_d, dt, reduce):
    """Contacts of a step (see :meth:`dynamics.RigidBodySolver._contacts`) among the candidate nodes
    ``cand`` (ascending), support-hull reduced when no contact slides.

    Returns (idx (k,), slide (k,) bool, sdir (k, 3), stab (3k,)). ``stab`` (m/s²) is the velocity
    stabilisation (deviation 6 of :mod:`pbr_xval.reference`): v/Δt of each contact's normal
    velocity (approaching or receding: a resting contact receding slower than ``v_sep`` carries
    a force, which without it would hold that velocity constant) and of a sticking contact's
    tangential velocity, components below 1e-8 m/s left out."""
    cnt = 0
    for c in range(cand.size):
        i = cand[c]
        if gaps[i] <= eps and vel[i, 0] <= v_sep:
            cnt += 1
    idx = np.empty(cnt, dtype=np.int64)
    cnt = 0
    any_slide = False
    for c in range(cand.size):
        i = cand[c]
        if gaps[i] <= eps and vel[i, 0] <= v_sep:
            idx[cnt] = i
            cnt += 1
            if mu_d > 0 and math.hypot(vel[i, 1], vel[i, 2]) > v_slip:
                any_slide = True
    if reduce and not any_slide and cnt > 3:
        size = 0.0
        for i in range(nodes.shape[0]):
            size = max(size, _norm3(nodes[i]))
        idx = support_hull(nodes, idx, 1e-9 * max(size, 1e-300))
    k = idx.size
    slide = np.zeros(k, dtype=np.bool_)
    sdir = np.zeros((k, 3))
    stab = np.zeros(3 * k)
    for a in range(k):
        i = idx[a]
        vt = math.hypot(vel[i, 1], vel[i, 2])
        if mu_d > 0 and vt > v_slip:
            slide[a] = True
            sdir[a, 0] = vel[i, 1] / vt
            sdir[a, 1] = vel[i, 2] / vt
        for c in range(3):
            vv = vel[i, c] if abs(vel[i, c]) > 1e-8 else 0.0
            if c == 0:
                stab[3 * a] = vv / dt
            elif not slide[a]:
                stab[3 * a + c] = vv / dt
    return idx, slide, sdir, stab


@njit(cache=True, inline="always")
def _forces(
    R,
    lm,
    prm,
    inertia_inv,
    nodes,
    idx,
    slide,
    sdir,
    stab,
    a_load,
    ap,
    active,
    prev_force,
    mu_vec,
    info,
    diag,
    fws,
    iws,
    F,
    tau,
    wrench,
):
    """Total force F (3,), torque τ (3,) at a state, written into the caller's ``F``, ``tau``
    and returned; False when the active-set guess failed.

    ``fws``: float scratch of :func:`_forces_work` (k) floats, ``iws``: (≥ 7k,) int scratch,
    ``wrench`` (6,) float scratch — reused by the calls of one step (the contact problem's
    arrays are not kept)."""
    m = prm[P_MASS]
    k = idx.size
    for c in range(3):
        F[c] = m * a_load[c]  # m * a_load
        tau[c] = 0.0
    if k == 0:
        return F, tau, True
    n3 = 3 * k
    A = _mat(fws, 0, n3, n3)
    o = n3 * n3
    b = fws[o : o + n3]
    o += n3
    gf = _mat(fws, o, n3, 6)
    o += 6 * n3
    tdir = _mat(fws, o, k, 2)
    o += 2 * k
    a_rel = fws[o : o + 3]
    o += 3
    sws = fws[o : o + _active_set_work(n3)]
    o += _active_set_work(n3)
    status = iws[0:k]
    for c in range(3):
        a_rel[c] = a_load[c] - ap[c]
    cons = _contact_problem_into(
        R, lm, inertia_inv, m, nodes, idx, slide, sdir, stab, a_rel, prm[P_MU_D], A, b, gf, fws[o:]
    )
    tdir[:] = 0.0
    for a in range(k):
        s = active[idx[a]]
        if slide[a]:
            status[a] = 0 if s == 0 else 2
        else:
            status[a] = 1 if s == 2 else s
            if s == 3:
                # impending slip: the friction's direction from the last solve
                fx = prev_force[idx[a], 1]
                fy = prev_force[idx[a], 2]
                ft = math.hypot(fx, fy)
                if ft > 0.0:
                    tdir[a, 0] = fx / ft
                    tdir[a, 1] = fy / ft
                else:
                    status[a] = 1
    info[I_SOLVES] += 1
    ok, f, acc, st = _active_set_solve_into(
        A, b, status, mu_vec, 2.0 * cons, k + 2, tdir, slide, sws, iws[k:]
    )
    if not ok:
        ok, f, acc, st = active_set_retry(A, b, status, mu_vec, 2.0 * cons, k + 2, tdir, slide, stab)
    if not ok:
        return F, tau, False
    info[I_FAST] += 1
    for a in range(k):
        active[idx[a]] = st[a]
    for a in range(k):
        for c in range(3):
            prev_force[idx[a], c] = f[3 * a + c]
    wrench[:] = 0.0
    for p in range(3 * k):
        for j in range(6):
            wrench[j] += gf[p, j] * f[p]
    for c in range(3):
        F[c] = F[c] + wrench[c]  # F + wrench[:3]
        tau[c] = wrench[3 + c]
    if diag:
        fmin = 0.0
        amin = 0.0
        compl = 0.0
        cone = 0.0
        for a in range(k):
            fn = f[3 * a]
            fmin = min(fmin, fn)
            amin = min(amin, acc[3 * a])
            compl = max(compl, abs(fn * acc[3 * a]))
            mu_fn = 0.0 if slide[a] else prm[P_MU_S] * fn
            cone = max(cone, math.hypot(f[3 * a + 1], f[3 * a + 2]) - mu_fn)
        info[I_SIG_F] = -fmin
        info[I_SIG_A] = -amin
        info[I_COMPL] = compl
        info[I_CONE] = cone
        info[I_NRES] = 1.0
    return F, tau, True


@njit(cache=True)
def _forces_work(k):
    """Floats of :func:`_forces`' scratch for k contacts: A, b, G_f, the friction directions,
    a_rel, :func:`_active_set_solve_into`'s scratch and :func:`_contact_problem_into`'s work."""
    n3 = 3 * k
    return n3 * n3 + n3 + 6 * n3 + 2 * k + 3 + _active_set_work(n3) + (9 * n3 + 3 * k + 45)


@njit(**_NO_REFCOUNT)
def _end_gaps(x1, R1, d1, nodes, cand, full, ped_kind, hx, hy, eps, out_gaps):
    """(smallest gap, nodes within ε) at the end of a step, over ``cand`` or every node."""
    n = nodes.shape[0] if full else cand.size
    gmin = np.inf
    ncont = 0
    for c in range(n):
        i = c if full else cand[c]
        rx = R1[0, 0] * nodes[i, 0] + R1[0, 1] * nodes[i, 1] + R1[0, 2] * nodes[i, 2]
        ry = R1[1, 0] * nodes[i, 0] + R1[1, 1] * nodes[i, 1] + R1[1, 2] * nodes[i, 2]
        rz = R1[2, 0] * nodes[i, 0] + R1[2, 1] * nodes[i, 1] + R1[2, 2] * nodes[i, 2]
        px = x1[0] + rx - d1[0]
        py = x1[1] + ry - d1[1]
        g = x1[2] + rz - d1[2]
        if ped_kind == 1 and (abs(px) > hx or abs(py) > hy):
            g = np.inf
        out_gaps[i] = g
        gmin = min(gmin, g)
        if g <= eps:
            ncont += 1
    return gmin, ncont


#: floats of :func:`_step`'s fixed workspace beyond the 7N of the start kinematics
STEP_WORK_FIXED = 18 + 9 + 90 + 18 + 18


@njit(cache=True)
def _step_work(n_nodes, k_max):
    """(float workspace, int workspace) of :func:`_step` for N nodes and up to ``k_max``
    contacts (a step with more allocates its own contact-sized arrays)."""
    nf = 7 * n_nodes + STEP_WORK_FIXED + k_max + _forces_work(k_max)
    return np.empty(nf), np.empty(max(7 * k_max, 1), dtype=np.int64)


def step(
    sv: np.ndarray,
    prm: np.ndarray,
    ext: np.ndarray,
    inertia_inv: np.ndarray,
    nodes: np.ndarray,
    cand: np.ndarray,
    active: np.ndarray,
    prev_force: np.ndarray,
    pred: np.ndarray,
    pred_idx: np.ndarray,
    out_sv: np.ndarray,
    out_gaps: np.ndarray,
    info: np.ndarray,
) -> int:
    """:func:`_step` with a fresh workspace (the engine's single steps; arguments and return
    as :func:`_step`'s). A Python function: compiled, this two-line wrapper cost ~5 s of the
    cold JIT compile (numba links and re-optimises the callee's whole call tree into every
    compiled caller)."""
    swf, swi = _step_work(nodes.shape[0], 0)
    return _step(
        sv,
        prm,
        ext,
        inertia_inv,
        nodes,
        cand,
        active,
        prev_force,
        pred,
        pred_idx,
        out_sv,
        out_gaps,
        info,
        swf,
        swi,
    )


@njit(cache=True)
def _step(
    sv,
    prm,
    ext,
    inertia_inv,
    nodes,
    cand,
    active,
    prev_force,
    pred,
    pred_idx,
    out_sv,
    out_gaps,
    info,
    swf,
    swi,
):
    """One constant-average-acceleration step t0 → t0 + Δt with direct iteration.

    Parameters
    ----------
    sv : (18,) packed state (x m, v m/s, R row-major, l kg m²/s) at t0.
    prm : (N_PARAMS,) parameters (layout ``P_*``).
    ext : (7, 3) non-contact COM acceleration at t0⁺ and t1⁻, pedestal displacement and
        velocity at t0, pedestal acceleration at t0⁺ and t1⁻, pedestal displacement at t1.
    inertia_inv : (3, 3) inverse inertia about the COM, body frame, 1/(kg m²).
    nodes : (N, 3) body-frame contact nodes relative to the COM, m.
    cand : (n,) int, ascending: the candidate nodes — every node that can be within ε of the
        pedestal at a tilt up to arccos ``prm[P_COS_CAND]`` (the others stay more than 3ε above
        the deepest node; :meth:`dynamics.RigidBodySolver.candidates`). The end-of-step check falls
        back to every node when the step ends beyond that tilt or deeper than 2ε.
    active : (N,) int, per node status of the last full solve (read).
    prev_force : (N, 3) last contact force per node (written).
    pred : (9,) predictor memory (valid, t1, Δt, F0 (3), τ0 (3)), read and written.
    pred_idx : (N + 1,) int, predictor contact ids (count first), read and written.
    out_sv : (18,) the state at t1 (written). out_gaps : (N,) node gaps at t1, m (written).
    info : (N_INFO,) statistics (layout ``I_*``, written).
    swf, swi : float and int workspace of :func:`_step_work` (its contents are not read
        before they are written; contact-sized parts beyond its ``k_max`` are allocated here).

    Returns
    -------
    int : ``STEP_OK``, ``STEP_REJECTED``, ``STEP_GENERAL`` (see the module docstring) or
    ``STEP_IMPACT``.

    Why one long function (~170 lines, over the house's 150): it is the compiled hot path of every
    step (numba, ``nopython``); its blocks follow the paper's eqs. 3.1–3.7 in order (kinematics,
    contact set, resting solve, update, end-of-step check) and share their temporaries without
    call boundaries inside the kernel.
    """
    for j in range(N_INFO):
        info[j] = 0.0
    m = prm[P_MASS]
    dt = prm[P_DT]
    t0 = prm[P_T0]
    t1 = t0 + dt
    ped_kind = int(prm[P_PED_KIND])
    hx, hy = prm[P_HX], prm[P_HY]
    nn = nodes.shape[0]
    # C-layout views (reshape), as the arrays of :func:`_kinematics` and of the Python path:
    # each layout of an argument is a separate compilation of the callee (and of its callees)
    r0s = swf[0 : 3 * nn].reshape((nn, 3))
    gaps0 = swf[3 * nn : 4 * nn]
    vel0 = swf[4 * nn : 7 * nn].reshape((nn, 3))
    o = 7 * nn
    x0 = swf[o : o + 3]
    v0 = swf[o + 3 : o + 6]
    l0 = swf[o + 6 : o + 9]
    # R0 and the vectors below: C-layout views too, as R1 (``wk[9]``)
    R0 = swf[o + 9 : o + 18].reshape((3, 3))
    for c in range(3):
        x0[c] = sv[c]
        v0[c] = sv[3 + c]
        l0[c] = sv[15 + c]
    for c in range(9):
        R0[c // 3, c % 3] = sv[6 + c]
    o += 18
    eye = _mat(swf, o, 3, 3)
    o += 9
    wk = swf[o : o + 90].reshape((10, 3, 3))
    o += 90
    vecs = swf[o : o + 18].reshape((6, 3))
    o += 18
    F0 = swf[o : o + 3]
    tau0 = swf[o + 3 : o + 6]
    F1 = swf[o + 6 : o + 9]
    tau1 = swf[o + 9 : o + 12]
    wrench = swf[o + 12 : o + 18]
    o += 18
    a_load0, a_load1 = ext[0], ext[1]
    d0, vp0, ap0, ap1, d1 = ext[2], ext[3], ext[4], ext[5], ext[6]
    w00, w01, w02 = _kinematics_into(
        x0, v0, R0, l0, inertia_inv, nodes, cand, d0, vp0, ped_kind, hx, hy, r0s, gaps0, vel0
    )
    if prm[P_IMPACT] > 0:
        eps = prm[P_EPS]
        v_imp = prm[P_VIMP]
        for c in range(cand.size):
            i = cand[c]
            if gaps0[i] <= eps and vel0[i, 0] < -v_imp:
                return STEP_IMPACT
    idx, slide, sdir, stab = contact_set(
        gaps0, vel0, nodes, cand, prm[P_EPS], prm[P_VSEP], prm[P_VSLIP], prm[P_MU_D], dt, prm[P_REDUCE] > 0
    )
    k = idx.size
    if o + k + _forces_work(k) <= swf.size and 7 * k <= swi.size:
        mu_vec = swf[o : o + k]
        fws = swf[o + k :]
        fst = swi
    else:
        mu_vec = np.empty(k)
        fws = np.empty(_forces_work(k))
        fst = np.empty(7 * k, dtype=np.int64)
    mu_vec[:] = prm[P_MU_S]  # np.full(k, μ_s)
    _, _, ok = _forces(
        R0,
        l0,
        prm,
        inertia_inv,
        nodes,
        idx,
        slide,
        sdir,
        stab,
        a_load0,
        ap0,
        active,
        prev_force,
        mu_vec,
        info,
        np.bool_(True),  # ``diag``, not a literal: the type of the iteration's np.bool_(False)
        fws,
        fst,
        F0,
        tau0,
        wrench,
    )
    if not ok:
        return STEP_GENERAL
    # the step's small arrays, in the workspace (the array expressions in the comments are
    # evaluated element by element, the same operations in the same order)
    for i in range(3):
        for j in range(3):
            eye[i, j] = 1.0 if i == j else 0.0
    Sw, SR, Rn, Rp, W0R0, R1 = wk[5], wk[6], wk[7], wk[0:5], wk[8], wk[9]
    x1, v1, l1, vn, xn, ln = vecs[0], vecs[1], vecs[2], vecs[3], vecs[4], vecs[5]
    half_dt = 0.5 * dt
    # W0R0 = _mm(_skew(w0), R0)
    _skew_into(w00, w01, w02, Sw)
    _mm_into(Sw, R0, W0R0)
    same = pred[0] > 0 and pred[1] == t0 and pred[2] == dt and pred_idx[0] == k
    if same:
        for a in range(k):
            if pred_idx[1 + a] != idx[a]:
                same = False
                break
    for c in range(3):
        # predictor: Fp = 2 F0 − F(last step) when the contact set is the same, else F0
        fp = 2.0 * F0[c] - pred[3 + c] if same else F0[c]
        tp = 2.0 * tau0[c] - pred[6 + c] if same else tau0[c]
        v1[c] = v0[c] + half_dt * (F0[c] + fp) / m  # vp = v0 + 0.5 Δt (F0 + Fp) / m
        l1[c] = l0[c] + half_dt * (tau0[c] + tp)  # lp = l0 + 0.5 Δt (τ0 + τp)
    for c in range(3):
        x1[c] = x0[c] + half_dt * (v0[c] + v1[c])  # x0 + 0.5 Δt (v0 + vp)
    # R1 = _mm(_cayley(dt * w0), R0), _cayley(w) = _solve3(I − s, I + s), s = 0.5 [w]×
    _skew_into(dt * w00, dt * w01, dt * w02, Sw)
    a1, b1 = Rp[1], Rp[2]
    for i in range(3):
        for j in range(3):
            sij = 0.5 * Sw[i, j]
            a1[i, j] = eye[i, j] - sij
            b1[i, j] = eye[i, j] + sij
    _solve3_into(a1, b1, Rp[4], Rp[3])
    _mm_into(Rp[3], R0, R1)
    vscale = max(_norm3(v0), _norm3(a_load0) * dt, 1e-300)
    lscale = max(_norm3(l0), prm[P_LREF] * vscale, 1e-300)
    itol = prm[P_ITOL]
    orth = prm[P_ORTH]
    its = 0
    converged = False
    F1[:] = F0
    tau1[:] = tau0
    for it in range(1, int(prm[P_ITER]) + 1):
        its = it
        _, _, ok = _forces(
            R1,
            l1,
            prm,
            inertia_inv,
            nodes,
            idx,
            slide,
            sdir,
            stab,
            a_load1,
            ap1,
            active,
            prev_force,
            mu_vec,
            info,
            np.bool_(False),
            fws,
            fst,
            F1,
            tau1,
            wrench,
        )
        if not ok:
            return STEP_GENERAL
        for c in range(3):
            vn[c] = v0[c] + half_dt * (F0[c] + F1[c]) / m  # eq. 3.2: v0 + 0.5 Δt (F0 + F1) / m
        for c in range(3):
            xn[c] = x0[c] + half_dt * (v0[c] + vn[c])  # eq. 3.1: x0 + 0.5 Δt (v0 + vn)
            ln[c] = l0[c] + half_dt * (tau0[c] + tau1[c])  # eq. 3.4: l0 + 0.5 Δt (τ0 + τ1)
        wn0, wn1, wn2 = _omega3(R1, inertia_inv, ln)
        # eq. 3.3: Rn = R0 + 0.5 Δt (W0 R0 + [ωn]× R1)
        Sw[0, 1] = -wn2
        Sw[0, 2] = wn1
        Sw[1, 0] = wn2
        Sw[1, 2] = -wn0
        Sw[2, 0] = -wn1
        Sw[2, 1] = wn0
        _mm_into(Sw, R1, SR)
        for i in range(3):
            for j in range(3):
                Rn[i, j] = R0[i, j] + half_dt * (W0R0[i, j] + SR[i, j])
        # |det Rn − 1| > tol or max |Rnᵀ Rn − I| > tol (a NaN element: the max is NaN, not > tol)
        bad = abs(_det3(Rn) - 1.0) > orth
        if not bad:
            nan = False
            for i in range(3):
                for j in range(3):
                    d = abs(Rn[0, i] * Rn[0, j] + Rn[1, i] * Rn[1, j] + Rn[2, i] * Rn[2, j] - eye[i, j])
                    if d != d:
                        nan = True
                    elif d > orth:
                        bad = True
            bad = bad and not nan
        if bad:
            _cayley_project_into(Rn, R0, eye, Rp, SR)
            Rn[:] = SR
            info[I_CAYLEY] += 1
        ev = vn[0] - v1[0]
        ev1 = vn[1] - v1[1]
        ev2 = vn[2] - v1[2]
        dv = math.sqrt(ev * ev + ev1 * ev1 + ev2 * ev2) / vscale
        ev = ln[0] - l1[0]
        ev1 = ln[1] - l1[1]
        ev2 = ln[2] - l1[2]
        dl = math.sqrt(ev * ev + ev1 * ev1 + ev2 * ev2) / lscale
        dR = 0.0  # max |Rn − R1| (NaN if any element is)
        for i in range(3):
            for j in range(3):
                d = abs(Rn[i, j] - R1[i, j])
                if d != d or dR != dR:
                    dR = math.nan
                elif d > dR:
                    dR = d
        x1[:] = xn
        v1[:] = vn
        R1[:] = Rn
        l1[:] = ln
        if max(dv, dl, dR) <= itol:
            converged = True
            break
    # predictor memory for the next step (kept also when this step is rejected)
    pred[0] = 1.0
    pred[1] = t1
    pred[2] = dt
    pred[3:6] = F0
    pred[6:9] = tau0
    pred_idx[0] = k
    pred_idx[1 : 1 + k] = idx
    out_sv[0:3] = x1
    out_sv[3:6] = v1
    out_sv[6:15] = R1.ravel()
    out_sv[15:18] = l1
    info[I_ITS] = its
    info[I_CONV] = 1.0 if converged else 0.0
    info[I_F1 : I_F1 + 3] = F1
    info[I_TAU1 : I_TAU1 + 3] = tau1
    om0, om1, om2 = _omega3(R1, inertia_inv, l1)  # _omega(R1, inertia_inv, l1)
    info[I_OMEGA] = om0
    info[I_OMEGA + 1] = om1
    info[I_OMEGA + 2] = om2
    # penetration check at the end of the step: over the candidates, or every node when the
    # step ended beyond their tilt or deeper than 2ε (then a non-candidate could be in band)
    full = R1[2, 2] < prm[P_COS_CAND] or cand.size == nodes.shape[0]
    gmin, ncont = _end_gaps(x1, R1, d1, nodes, cand, full, ped_kind, hx, hy, prm[P_EPS], out_gaps)
    if not full and gmin < -2.0 * prm[P_EPS]:
        # (np.bool_: a literal True would compile a second _end_gaps specialised on it)
        gmin, ncont = _end_gaps(
            x1, R1, d1, nodes, cand, np.bool_(True), ped_kind, hx, hy, prm[P_EPS], out_gaps
        )
    info[I_GMIN] = gmin
    info[I_NCONT] = ncont
    if gmin < -prm[P_EPS] and prm[P_NO_PEN] == 0:
        return STEP_REJECTED
    return STEP_OK


# ----------------------------------------------------------------------------- many steps
#: :func:`step_block` exit codes beyond the ``STEP_*`` ones: the last step ended with the rock
#: possibly at rest (the caller makes the exact test), or with a non-finite state
BLOCK_AT_REST = 4
BLOCK_NONFINITE = 5

#: :func:`excitation_load` component kinds: none, a record (piecewise-linear samples),
#: a sine pulse A sin(ω τ + φ) on [0, T)
EXC_NONE, EXC_RECORD, EXC_SINE = 0, 1, 2
#: floats per component in the excitation layout (kind, factor, six parameters)
EXC_COMP = 8
#: excitation layout: g (m/s²), the horizontal direction (cos az, sin az), then the horizontal
#: and the vertical component (``EXC_COMP`` floats each)
EXC_SIZE = 3 + 2 * EXC_COMP


@njit(**_NO_REFCOUNT)
def _component_acc(exc, k0, data, t):
    """Ground acceleration (m/s²) of one component at t (s), the arithmetic of
    ``motion.Record._acceleration`` / ``motion.pulses._Pulse._acceleration`` times the
    ``ScaledMotion`` factor, operation for operation (the same IEEE results)."""
    kind = int(exc[k0])
    if kind == EXC_NONE:
        return 0.0
    factor = exc[k0 + 1]
    if kind == EXC_RECORD:
        t0, dt, npts, dur, off = exc[k0 + 2], exc[k0 + 3], int(exc[k0 + 4]), exc[k0 + 5], int(exc[k0 + 6])
        kf = math.floor((t - t0) / dt)
        kf = min(max(kf, 0.0), float(npts - 2))
        k = int(kf)
        s = t - (t0 + float(k) * dt)
        s = min(max(s, 0.0), dt)
        a = data[off + k] + data[off + npts + k] * (s / dt)
        if not (t >= t0 and t <= dur):
            a = 0.0
        return factor * a
    amp, w, phi, period = exc[k0 + 2], exc[k0 + 3], exc[k0 + 4], exc[k0 + 5]
    tau = min(max(t, 0.0), period)
    a = amp * math.sin(w * tau + phi)
    if not (t >= 0.0 and t < period):
        a = 0.0
    return factor * a


@njit(**_NO_REFCOUNT)
def excitation_load(exc, data, t, out):
    """The inertial non-contact load per unit mass at t (s), g − a_ground(t), into ``out``
    (3,) m/s²: ``exc`` the layout ``EXC_*`` built by ``adapter.compiled_excitation``,
    ``data`` the records' samples and differences. The same numbers as the engine's
    ``gvec − Excitation3D.acceleration(t)``."""
    g, d0, d1 = exc[0], exc[1], exc[2]
    ah = _component_acc(exc, np.int64(3), data, t)  # not a literal 3: one compilation
    az = _component_acc(exc, 3 + EXC_COMP, data, t)
    out[0] = 0.0 - ah * d0
    out[1] = 0.0 - ah * d1
    out[2] = -g - az


@njit(cache=True)
def _block_candidates(cur, prm, dt, nodes, cull, cull_lim, inv_lmin, allc, cand_buf, cached, bounds):
    """The candidate nodes of a step from the packed state ``cur`` (those of
    :meth:`dynamics.RigidBodySolver.candidates`); sets ``prm[P_COS_CAND]``.

    ``cached`` is the set this function last computed afresh, for the tilt bounds
    ``bounds`` (2,): its largest ``cull_lim`` and the smallest one above it. A bound θ with
    ``bounds[0]`` ≤ θ < ``bounds[1]`` passes exactly the same nodes, and ``cached`` is
    returned; otherwise the set is computed and ``bounds`` updated. Returns (candidates,
    True when computed afresh)."""
    if not cull:
        return allc, False
    nn = nodes.shape[0]
    cz = min(1.0, max(-1.0, cur[14]))
    lmag = math.sqrt(cur[15] * cur[15] + cur[16] * cur[16] + cur[17] * cur[17])
    th = math.acos(cz) + 0.02 + 2.0 * dt * lmag * inv_lmin
    if th >= math.pi:
        prm[P_COS_CAND] = -2.0
        return allc, False
    prm[P_COS_CAND] = math.cos(th)
    if bounds[0] <= th and th < bounds[1]:
        return cached, False
    m = 0
    lo = -np.inf
    hi = np.inf
    for j in range(nn):
        lim = cull_lim[j]
        if lim <= th:
            cand_buf[m] = j
            m += 1
            if lim > lo:
                lo = lim
        elif lim < hi:
            hi = lim
    bounds[0] = lo
    bounds[1] = hi
    return cand_buf[:m].copy(), True


@njit(cache=True)
def step_block(
    sv,
    prm,
    loads,
    t0s,
    hs,
    inertia_inv,
    nodes,
    cull,
    cull_lim,
    inv_lmin,
    band_tol,
    rest,
    active,
    prev_force,
    pred,
    pred_idx,
    gaps,
    rows_sv,
    rows_info,
    rows_lift,
    imp,
    rows_imp,
    exc,
    exc_data,
    grid,
    bps,
    rows_t,
    rows_acc,
):
    """Consecutive :func:`step` calls of the engine loop in one call (inertial ground motion).

    Step i starts from the state left by step i − 1 (``sv`` for i = 0) at ``t0s[i]`` with
    Δt ``hs[i]`` and the non-contact loads ``loads[i]`` (at t0⁺ and t1⁻), and makes exactly
    what ``RigidBodySolver.step`` with ``impact_check`` and the engine loop do around a
    compiled step: the candidate nodes of :meth:`dynamics.RigidBodySolver.candidates`
    (``cull``: nodes with ``cull_lim[i]`` ≤ the start tilt + 0.02 + 2 Δt |l| / λ_min), the
    acceptance of a step ending within ``band_tol``·ε of the band and the projection of a
    node left deeper than ε back onto the band (``rows_lift``, m; the row's gap set to −ε).

    It stops before a step that needs the Python path — an impact (``STEP_IMPACT``), the
    general resting solver (``STEP_GENERAL``) or a step-back (``STEP_REJECTED``) — with the
    mutable solver memory (``active``, ``prev_force``, ``pred``, ``pred_idx``) restored to
    its state before that step, so that the caller repeats it exactly; and after a step
    that ends with a non-finite state (``BLOCK_NONFINITE``) or, when ``rest[0]`` (rest
    velocity, m/s) > 0 and t1 ≥ ``rest[1]`` (end of the excitation), with the rest test
    of the engine (|u̇| + |ω| size and the velocity change per step below ``rest[0]``;
    ``rest[2]`` size m, ``rest[3]`` nominal Δt s, ``rest[4]`` mass kg) holding within a
    relative 1e-6 (``BLOCK_AT_REST``: the caller decides).

    An eq. 3.5 impact pending at the first step (``imp`` not empty: restitution, μ_s, hull
    reduction, size, layout ``IMP_*``) is resolved here when :func:`_block_impact` can (the
    compiled stages of the impact; its event in ``rows_imp[0]``, layout ``J_*``), and the
    step is then made from the post-impact state without the trigger, as the engine loop
    does; if that step needs the Python path (or, with ``exc``, a step-back beyond the
    limit), everything is restored and the block returns before it. Without ``exc`` an impact
    pending at a later step ends the block before that step (the next block starts with it);
    with ``exc`` it is resolved there too, its event in ``rows_imp`` at its step's first row.

    With an excitation ``exc`` (not empty; layout of :func:`excitation_load`, samples
    ``exc_data``) the block makes its own steps instead of ``t0s``/``hs``/``loads``: from
    ``grid[0]`` (s), steps of ``grid[1]`` (nominal Δt, s) ending on the breakpoints ``bps``
    (s, sorted, the last = ``grid[2]``, the duration), at most ``grid[5]`` accepted ones, the
    loads evaluated here; and it makes the engine loop's step-backs itself: a rejected step is
    repeated with Δt halved (at most ``grid[3]`` times, not below ``grid[4]`` s) from the
    solver memory the rejected step left, as :meth:`RigidBodySolver.step` does. Every attempt
    takes a row (``rows_acc`` 1 accepted, 0 rejected; ``rows_t`` the time after an accepted
    step). A step-back sequence that reaches the limit, or whose retry needs the Python
    path, is undone entirely (memory restored, its rows dropped) and the block returns
    before it.

    Returns (rows done, exit code); rows i < rows done hold the state after step i
    (``rows_sv``) and the step's info (``rows_info``, layout ``I_*``).
    """
    own = exc.size > 0
    n = t0s.size
    cap = rows_sv.shape[0]
    t = grid[0] if own else 0.0
    dt_nom = grid[1] if own else 0.0
    duration = grid[2] if own else 0.0
    max_back = int(grid[3]) if own else 0
    min_dt = grid[4] if own else 0.0
    n_lim = int(grid[5]) if own else n
    nb = bps.size
    bp_i = 0
    t_next_bp = 0.0
    backs = 0
    h = 0.0
    seq = 0  # the first row of the current step's attempts
    acc_n = 0  # accepted steps
    r = 0  # rows used
    nn = nodes.shape[0]
    ext = np.zeros((7, 3))
    eps = prm[P_EPS]
    allc = np.arange(nn)
    cand_buf = np.empty(nn, dtype=np.int64)
    snap_active = np.empty(nn, dtype=np.int64)
    snap_force = np.empty((nn, 3))
    snap_pred = np.empty(pred.size)
    snap_idx = np.empty(pred_idx.size, dtype=np.int64)
    cur = sv
    prm[P_NO_PEN] = 0.0
    prm[P_IMPACT] = 1.0
    snap_n = 0
    snap_cand = cand_buf.copy()
    full_active = np.empty(nn, dtype=active.dtype)
    full_force = np.empty((nn, 3))
    post = np.empty(18)
    swf, swi = _step_work(nn, 8)
    after_imp = False  # the current step's retries start from the post-impact state
    cand = allc
    # the candidates last computed and their tilt bounds (:func:`_block_candidates`)
    cand_cache = allc
    cand_bounds = np.array([np.inf, -np.inf])
    while True:
        i = r
        if own:
            if backs == 0:
                if acc_n >= n_lim or not (t < duration - 1e-12 * dt_nom) or r + max_back + 1 > cap:
                    return r, STEP_OK
                while bp_i < nb and bps[bp_i] <= t + 1e-12 * dt_nom:
                    bp_i += 1
                t_next_bp = bps[bp_i] if bp_i < nb else duration
                h = min(dt_nom, t_next_bp - t)
                seq = r
            dt = h
            t0 = t
            excitation_load(exc, exc_data, t0 + 1e-9 * dt, ext[0])
            excitation_load(exc, exc_data, (t0 + dt) - 1e-9 * dt, ext[1])
        else:
            if i >= n:
                return n, STEP_OK
            dt = hs[i]
            t0 = t0s[i]
            for c in range(3):
                ext[0, c] = loads[i, 0, c]
                ext[1, c] = loads[i, 1, c]
        prm[P_T0] = t0
        prm[P_DT] = dt
        start = post if after_imp else cur
        if backs == 0:
            # a retry keeps the first attempt's candidates and P_COS_CAND, as
            # RigidBodySolver.candidates does (cached per start state, not per Δt)
            cand, fresh = _block_candidates(
                start, prm, dt, nodes, cull, cull_lim, inv_lmin, allc, cand_buf, cand_cache, cand_bounds
            )
            if fresh:
                cand_cache = cand
            # the memory before the step's first attempt
            snap_n = cand.size
            for a in range(cand.size):
                j = cand[a]
                snap_cand[a] = j
                snap_active[j] = active[j]
                for c in range(3):
                    snap_force[j, c] = prev_force[j, c]
            snap_pred[:] = pred
            snap_idx[:] = pred_idx
        out = rows_sv[i]
        info = rows_info[i]
        if after_imp:
            prm[P_IMPACT] = 0.0
        code = _step(
            start,
            prm,
            ext,
            inertia_inv,
            nodes,
            cand,
            active,
            prev_force,
            pred,
            pred_idx,
            out,
            gaps,
            info,
            swf,
            swi,
        )
        prm[P_IMPACT] = 1.0
        impact = after_imp
        if code == STEP_IMPACT and backs > 0:
            # (not expected: the retry starts from the same state) undo the sequence
            for a in range(snap_n):
                j = snap_cand[a]
                active[j] = snap_active[j]
                for c in range(3):
                    prev_force[j, c] = snap_force[j, c]
            pred[:] = snap_pred
            pred_idx[:] = snap_idx
            return seq, code
        if code == STEP_IMPACT:
            # (with the block's own excitation an impact is resolved at any step, its event
            # in rows_imp[i]; else at the first step only, in rows_imp[0])
            if (i > 0 and not own) or imp.size == 0:
                return i, code
            # the impact at the block's first step: every node's memory saved (the impact
            # and the step after it may touch nodes outside this step's candidates)
            full_active[:] = active
            full_force[:] = prev_force
            if not _block_impact(
                cur, prm, imp, inertia_inv, nodes, cand, active, prev_force, pred, dt, post, rows_imp[i]
            ):
                return i, code
            impact = True
            after_imp = True
            cand, fresh = _block_candidates(
                post, prm, dt, nodes, cull, cull_lim, inv_lmin, allc, cand_buf, cand_cache, cand_bounds
            )
            if fresh:
                cand_cache = cand
            prm[P_IMPACT] = 0.0
            code = _step(
                post,
                prm,
                ext,
                inertia_inv,
                nodes,
                cand,
                active,
                prev_force,
                pred,
                pred_idx,
                out,
                gaps,
                info,
                swf,
                swi,
            )
            prm[P_IMPACT] = 1.0
        gmin = info[I_GMIN]
        rejected = code == STEP_REJECTED and gmin < -eps * (1.0 + band_tol)
        if own and rejected and backs < max_back and h * 0.5 >= min_dt:
            # a step-back, as the engine loop makes it: the rejected attempt's row is kept
            # (its statistics count), the solver memory it left is not restored; after an
            # impact resolved here the retries start from the post-impact state, unchecked
            rows_acc[i] = 0.0
            rows_lift[i] = 0.0
            r += 1
            backs += 1
            h *= 0.5
            continue
        if code == STEP_GENERAL or rejected:
            if impact:
                active[:] = full_active
                prev_force[:] = full_force
                rows_imp[seq if own else i, J_FLAG] = 0.0
            else:
                for a in range(snap_n):
                    j = snap_cand[a]
                    active[j] = snap_active[j]
                    for c in range(3):
                        prev_force[j, c] = snap_force[j, c]
            pred[:] = snap_pred
            pred_idx[:] = snap_idx
            return (seq if own else i), STEP_IMPACT if impact else code
        after_imp = False
        rows_acc[i] = 1.0
        rows_lift[i] = 0.0
        if gmin < -eps:
            lift = -eps - gmin
            out[2] += lift
            info[I_GMIN] = -eps
            rows_lift[i] = lift
        cur = out
        r = i + 1
        acc_n += 1
        backs = 0
        if own:
            t = t + h if t + h < t_next_bp - 1e-12 * dt_nom else t_next_bp
            rows_t[i] = t
        finite = True
        for c in range(18):
            if not np.isfinite(out[c]):
                finite = False
        if not finite:
            return i + 1, BLOCK_NONFINITE
        if rest[0] > 0 and t0 + dt >= rest[1]:
            lim = rest[0] * (1.0 + 1e-6)
            wx, wy, wz = info[I_OMEGA], info[I_OMEGA + 1], info[I_OMEGA + 2]
            speed = math.sqrt(out[3] * out[3] + out[4] * out[4] + out[5] * out[5])
            speed += math.sqrt(wx * wx + wy * wy + wz * wz) * rest[2]
            if speed < lim:
                fx, fy, fz = info[I_F1], info[I_F1 + 1], info[I_F1 + 2]
                dv = math.sqrt(fx * fx + fy * fy + fz * fz) / rest[4] * rest[3]
                R = out[6:15].reshape(3, 3)
                tb = _mtv(R, info[I_TAU1 : I_TAU1 + 3].copy())
                al = _mv(R, _mv(inertia_inv, tb))
                if dv + _norm3(al) * rest[2] * rest[3] < lim:
                    return i + 1, BLOCK_AT_REST


# ----------------------------------------------------------------------------- impacts (eq. 3.5)
#: :func:`impact_impulses` stages: the impulses are complete; the cone's active-set guess failed
#: (the caller runs the iterative cone solver and the normal LCP); the normal LCP has no unique
#: solution (the caller selects); complete, with the re-selected normal impulses reverted
IMPACT_DONE, IMPACT_CONE, IMPACT_SELECT, IMPACT_REVERTED = 0, 1, 2, 3


@njit(cache=True, inline="always")
def _normal_problem(A, q, j):
    """The normal LCP of eq. 3.5 with the tangential impulses of ``j`` (3k,) held fixed:
    (q_n (k,) = q_n + A_nt j_t, A_nn (k, k))."""
    k = q.size // 3
    qn = np.empty(k)
    Ann = np.empty((k, k))
    for i in range(k):
        s = q[3 * i]
        for c in range(k):
            s += A[3 * i, 3 * c + 1] * j[3 * c + 1] + A[3 * i, 3 * c + 2] * j[3 * c + 2]
            Ann[i, c] = A[3 * i, 3 * c]
        qn[i] = s
    return qn, Ann


@njit(cache=True, inline="always")
def _outside_cone(j, jn, mu_s):
    """Whether a tangential impulse of ``j`` (3k,) leaves its cone μ_s jn (``jn`` (k,) the normal
    impulses), beyond 1e-9 relative and 1e-12 of the largest tangential impulse."""
    k = jn.size
    jt_max = 0.0
    for i in range(k):
        jt_max = max(jt_max, math.hypot(j[3 * i + 1], j[3 * i + 2]))
    for i in range(k):
        if math.hypot(j[3 * i + 1], j[3 * i + 2]) > mu_s * jn[i] * (1 + 1e-9) + 1e-12 * jt_max:
            return True
    return False


@njit(cache=True)
def impact_impulses(R, inertia_inv, mass, r, bvel, e, mu_s, ref):
    """The impulses of an eq. 3.5 impact on k hull contacts, when they take the fast path.

    The velocity form of the resting problem: A = G M⁻¹ Gᵀ (3k, 3k) per contact (n, x, y),
    q = v⁻ + e v_n⁻ on the approaching normals; with μ_s > 0 the impact cone by
    :func:`active_set_solve` (guess: approaching contacts stick, the others separate;
    impending slip found by its corrections), then eq. 3.5 on the normal impulses with the
    tangential ones held fixed, by :func:`lcp_unique` (one solution: no selection to make) or,
    for a singular A_nn, :func:`lcp_select` (the solution closest to ``ref``), and the
    re-selected normal impulses kept only if every tangential impulse stays in its cone —
    the arithmetic of :meth:`dynamics.RigidBodySolver.resolve_impacts`, which handles the other
    stages.

    Parameters
    ----------
    R : (3, 3) rotation; inertia_inv : (3, 3) body frame, 1/(kg m²); mass : kg;
    r : (k, 3) lever arms of the contacts, world frame, m; bvel : (3k,) relative velocities
    (n, x, y), m/s; e : restitution; mu_s : static friction.

    Returns
    -------
    (stage ``IMPACT_*``, A (3k, 3k) m/(N s²)·s, q (3k,) m/s, j (3k,) impulses N s — complete
    for ``IMPACT_DONE`` / ``IMPACT_REVERTED``, the cone's for ``IMPACT_SELECT``).
    """
    k = r.shape[0]
    n3 = 3 * k
    gm, _ = _jacobians(r, np.zeros(k, dtype=np.bool_), np.zeros((k, 3)), 0.0)
    iw = _mmt(_mm(R, inertia_inv), R)
    H = np.empty((n3, 3))
    for p in range(n3):
        for c in range(3):
            H[p, c] = iw[c, 0] * gm[p, 3] + iw[c, 1] * gm[p, 4] + iw[c, 2] * gm[p, 5]
    Abuf = np.empty(n3 * n3)
    A = Abuf.reshape((n3, n3))
    inv_m = 1.0 / mass
    for p in range(n3):
        for q_ in range(n3):
            A[p, q_] = (gm[p, 0] * gm[q_, 0] + gm[p, 1] * gm[q_, 1] + gm[p, 2] * gm[q_, 2]) * inv_m + (
                gm[p, 3] * H[q_, 0] + gm[p, 4] * H[q_, 1] + gm[p, 5] * H[q_, 2]
            )
    q = bvel.copy()
    guess = np.zeros(k, dtype=np.int64)
    for i in range(k):
        if bvel[3 * i] < 0:
            q[3 * i] += e * bvel[3 * i]
            guess[i] = 1
    j = np.zeros(n3)
    if mu_s > 0:
        # A (and the friction directions) in the layout of :func:`_forces`' workspace views
        # ('A', :func:`_mat`, same values): one compilation of active_set_solve for both
        ok, j, _, _ = active_set_solve(
            _mat(Abuf, 0, n3, n3),
            q,
            guess,
            np.full(k, mu_s),
            0.0,
            k + 2,
            _mat(np.zeros(2 * k), 0, k, 2),
            np.zeros(k, dtype=np.bool_),
        )
        if not ok:
            return IMPACT_CONE, A, q, j
    qn, Ann = _normal_problem(A, q, j)
    unique, zn = lcp_unique(Ann, qn)
    if not unique:
        # a singular A_nn (a flat landing): the solution closest to ``ref``, when the solution
        # set is a segment
        unique, zn = lcp_select(Ann, qn, ref)
        if not unique:
            return IMPACT_SELECT, A, q, j
    if mu_s > 0 and _outside_cone(j, zn, mu_s):
        return IMPACT_REVERTED, A, q, j
    for i in range(k):
        j[3 * i] = zn[i]
    return IMPACT_DONE, A, q, j


@njit(cache=True)
def impact_cone_normals(A, q, j, mu_s):
    """Eq. 3.5 on the normal impulses of the cone solver's impulses ``j`` (3k,), its tangential
    impulses held fixed, when the normal LCP has one solution (:func:`lcp_unique`): the normal
    impulses are replaced in place, and put back (reverted) if a tangential impulse then
    leaves its cone (μ_s > 0). Returns (unique, reverted, q_n (k,), A_nn (k, k)); not unique:
    ``j`` untouched, the caller selects among the solutions from q_n and A_nn
    (:meth:`dynamics.RigidBodySolver._impact_normals`)."""
    k = q.size // 3
    qn, Ann = _normal_problem(A, q, j)
    unique, zn = lcp_unique(Ann, qn)
    if not unique:
        return False, False, qn, Ann
    jn_cone = np.empty(k)
    for i in range(k):
        jn_cone[i] = j[3 * i]
        j[3 * i] = zn[i]
    # the re-selection moves normal impulse only within null(A_nn) (no change of motion); kept
    # only if every tangential impulse stays inside its cone
    reverted = mu_s > 0 and _outside_cone(j, zn, mu_s)
    if reverted:
        for i in range(k):
            j[3 * i] = jn_cone[i]
    return True, reverted, qn, Ann


@njit(cache=True)
def impact_finish(R, inertia_inv, mass, r, A, q, bvel, j, v, lm):
    """The velocity jump of eq. 3.5 impulses ``j`` (3k,) on the contacts at lever arms ``r``
    (k, 3) (world frame, m), from the COM velocity ``v`` (3,) m/s and angular momentum ``lm``
    (3,) kg m²/s: Δu̇_cm = Σ J / m, Δl = Σ r × J (J = (j_x, j_y, j_n) in the world frame).

    Returns (v⁺ (3,), l⁺ (3,), |ω⁺| rad/s, the smallest post-impact normal velocity
    min (A j + bvel)_n m/s, and w = A j + q (3k,), the velocity-form residual of the impulses).
    """
    k = r.shape[0]
    n3 = 3 * k
    w = q.copy()
    vn_min = np.inf
    for p in range(n3):
        s = 0.0
        for c in range(n3):
            s += A[p, c] * j[c]
        w[p] += s
        if p % 3 == 0:
            vn_min = min(vn_min, s + bvel[p])
    v2 = v.copy()
    l2 = lm.copy()
    for i in range(k):
        jx, jy, jz = j[3 * i + 1], j[3 * i + 2], j[3 * i]
        v2[0] += jx / mass
        v2[1] += jy / mass
        v2[2] += jz / mass
        l2[0] += r[i, 1] * jz - r[i, 2] * jy
        l2[1] += r[i, 2] * jx - r[i, 0] * jz
        l2[2] += r[i, 0] * jy - r[i, 1] * jx
    w2 = _omega(R, inertia_inv, l2)
    return v2, l2, _norm3(w2), vn_min, w


# ----------------------------------------------------------------------------- impacts in a block
#: columns of :func:`step_block`'s impact rows (``rows_imp``, one per step): J_FLAG 1 when an
#: eq. 3.5 impact was resolved at the step's start (then: the smallest approaching normal
#: velocity of the hull contacts m/s, in-band nodes, hull contacts, contacts with a normal
#: impulse, ω before (3, rad/s), |ω| after rad/s, the smallest post-impact normal velocity m/s,
#: the four residuals of :func:`cone.friction_residuals` kept in the statistics, 1 when the
#: re-selected normal impulses were reverted, the iterative cone solver's sweeps)
J_FLAG, J_VNMIN, J_NODES, J_HULL, J_IMPULSE, J_W0, J_W1 = 0, 1, 2, 3, 4, 5, 8
J_VNAFTER, J_SIGF, J_SIGA, J_COMPL, J_CONE, J_REVERTED, J_SWEEPS = 9, 10, 11, 12, 13, 14, 15
N_IMP = 16
# impact parameters of :func:`step_block` (``imp``): restitution, μ_s, support-hull reduction
# (1/0), the body's size m (the hull's tolerance is 1e-9 of it), 1 when the impulse selection is
# "closest_to_previous" (0: minimum norm)
IMP_E, IMP_MU, IMP_REDUCE, IMP_SIZE, IMP_CLOSEST = range(5)


@njit(cache=True, inline="always")
def _block_impact(cur, prm, imp, inertia_inv, nodes, cand, active, prev_force, pred, dt, out_sv, row):
    """:meth:`dynamics.RigidBodySolver.resolve_impacts` for inertial ground motion (the pedestal
    is the frame: no displacement or velocity), when :func:`impact_impulses` answers on its
    compiled stages; the same functions in the same order, so the same numbers. Writes the
    post-impact state to ``out_sv`` and the event to ``row`` (``J_*``); False (nothing written)
    when the Python path must answer (the iterative cone solver or the impulse selection)."""
    eps = prm[P_EPS]
    zero = np.zeros(3)
    R = cur[6:15].reshape(3, 3)
    r_all, gaps, vel, w = _kinematics(
        cur[0:3],
        cur[3:6],
        R,
        cur[15:18],
        inertia_inv,
        nodes,
        cand,
        zero,
        zero,
        int(prm[P_PED_KIND]),
        prm[P_HX],
        prm[P_HY],
    )
    n_in = 0
    for c in range(cand.size):
        if gaps[cand[c]] <= eps:
            n_in += 1
    inband = np.empty(n_in, dtype=np.int64)
    n_in = 0
    for c in range(cand.size):
        if gaps[cand[c]] <= eps:
            inband[n_in] = cand[c]
            n_in += 1
    idx = inband
    if imp[IMP_REDUCE] > 0 and imp[IMP_E] == 0.0 and idx.size > 3:
        idx = support_hull(nodes, idx, 1e-9 * imp[IMP_SIZE])
    k = idx.size
    r = np.empty((k, 3))
    bvel = np.empty(3 * k)
    vn_min = np.inf
    for a in range(k):
        for c in range(3):
            r[a, c] = r_all[idx[a], c]
            bvel[3 * a + c] = vel[idx[a], c]
        vn_min = min(vn_min, vel[idx[a], 0])
    mu_s = imp[IMP_MU]
    ref = np.zeros(k)
    if imp[IMP_CLOSEST] > 0:
        for a in range(k):
            ref[a] = prev_force[idx[a], 0] * dt
    stage, A, q, j = impact_impulses(R, inertia_inv, prm[P_MASS], r, bvel, imp[IMP_E], mu_s, ref)
    sweeps = 0
    if stage == IMPACT_CONE:
        # the iterative cone solver's first sweeps (most impacts of a rocking rock converge
        # there), then eq. 3.5 on the normal impulses — as the Python path starts them
        # (solve_friction_cone, _impact_normals); anything further is left to it
        warm = np.empty(3 * k)
        for a in range(k):
            for c in range(3):
                warm[3 * a + c] = prev_force[idx[a], c] * dt
        conv, sweeps, j = cone_first_sweeps(A, q, np.full(k, mu_s), warm, 1e-13)
        if not conv:
            return False
        unique, reverted, _, _ = impact_cone_normals(A, q, j, mu_s)
        if not unique:
            return False
        stage = IMPACT_REVERTED if reverted else IMPACT_DONE
    elif stage == IMPACT_SELECT:
        return False
    v2, l2, nw2, vn_after, wres = impact_finish(
        R, inertia_inv, prm[P_MASS], r, A, q, bvel, j, cur[3:6].copy(), cur[15:18].copy()
    )
    res6 = _friction_residuals(j, wres, np.full(k, mu_s))
    out_sv[:] = cur
    out_sv[3:6] = v2
    out_sv[15:18] = l2
    pred[0] = 0.0
    for a in range(n_in):
        for c in range(3):
            prev_force[inband[a], c] = 0.0
        active[inband[a]] = 0
    hd = max(dt, 1e-300)
    n_imp = 0
    for a in range(k):
        for c in range(3):
            prev_force[idx[a], c] = j[3 * a + c] / hd
        active[idx[a]] = 1 if j[3 * a] > 0 else 0
        if j[3 * a] > 0:
            n_imp += 1
    row[J_FLAG] = 1.0
    row[J_VNMIN] = vn_min
    row[J_NODES] = n_in
    row[J_HULL] = k
    row[J_IMPULSE] = n_imp
    row[J_W0 : J_W0 + 3] = w
    row[J_W1] = nw2
    row[J_VNAFTER] = vn_after
    row[J_SIGF] = res6[0]
    row[J_SIGA] = res6[1]
    row[J_COMPL] = res6[2]
    row[J_CONE] = res6[3]
    row[J_REVERTED] = 1.0 if stage == IMPACT_REVERTED else 0.0
    row[J_SWEEPS] = sweeps
    return True
