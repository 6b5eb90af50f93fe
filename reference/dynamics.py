"""Rigid-body stepping of the reference solver (seed paper, Section 3).

This module follows Veeraraghavan & Krishnan's algorithm so a reader can go from the
paper's equations to the code:

State (Section 3, first paragraph)
    ``x`` = u_cm (COM position), ``v`` = u̇_cm (COM velocity), ``R`` (body → world rotation,
    the paper's X'Y'Z' → XYZ map), ``l`` (angular momentum about the COM, world frame).

Equations of motion (eqs. 3.1–3.4)
    dx/dt = v                      (3.1)
    dv/dt = F_T / m                (3.2)
    dR/dt = [ω]× R                 (3.3)   with ω = I⁻¹ l,  I = R I' Rᵀ
    dl/dt = τ_T                    (3.4)

    (The paper writes I = Rᵀ I' R for its transposed convention of R; with R mapping body
    to world coordinates the world inertia is R I' Rᵀ.)

Time stepping
    Constant-average-acceleration (trapezoidal) rule with direct (fixed-point) iteration:
    the end-of-step forces are re-evaluated at the current estimate of the end-of-step
    state until the trapezoidal equilibrium residual is below ``iteration_tol``. After every
    iteration R is checked (det R = 1, RᵀR = I); when it drifts it is projected back onto
    SO(3) with the Cayley transform.

Contact (Section 3, after eq. 3.4)
    The rock carries a set of basal nodes. A node whose gap to the pedestal surface is
    within ±ε is *in contact*; a gap below −ε rejects the step, which is retried with half
    the step (a *step-back*) down to ``min_timestep``.

Collisions (eq. 3.5)
    Contacts whose normal velocity is approaching faster than ``impact_velocity`` receive
    impulses. v⁺ = A j + b with A the contact-space inverse inertia
    A_mn = d_mᵀ (M⁻¹ + [r_m]×ᵀ I⁻¹ [r_n]×) d_n. With friction (μ > 0) the impulses are
    found together with Coulomb's cone on the impulses (the velocity-level form of
    eqs. 3.6–3.7; active-set solve, else :func:`cone.solve_friction_cone`): Housner's impact rule (angular
    momentum conserved about the landing edge, ratio 1 − 1.5 sin²α = 0.850 for the
    project block) *requires* a sticking tangential impulse at the landing edge — a
    frictionless eq. 3.5 impulse would let the block slide on impact. The normal impulses
    are then re-selected with the eq. 3.5 LCP (tangential impulses held fixed): for
    e = 0 and redundant contacts the LCP matrix is singular and the normal impulse
    distribution is not unique, although the post-impact velocity is (for symmetric
    PSD A, w = A j + b is the same for every solution and Jᵀ j too, so the motion does
    not depend on the choice). ``impact_selection = "closest_to_previous"`` takes the
    solution closest to the previous step's contact impulses (Veeraraghavan, Hall &
    Krishnan: continuity, independent of the pivoting path); ``"min_norm"`` the
    minimum-norm split. Both use :func:`selection.solve_lcp_min_norm`.

Resting contact (eqs. 3.6–3.7)
    Contacts in the band that are neither approaching nor separating carry forces with
    a = A f + b, f_n ≥ 0, a_n ≥ 0, f_n a_n = 0 and the static Coulomb cone. A contact whose
    tangential velocity exceeds ``slip_velocity`` slides: its friction is μ_d f_n opposite
    to the sliding velocity, applied with the normal force (normal-only LCP with the
    non-symmetric matrix A' = G_n M⁻¹ (G_n − μ_d G_s)ᵀ). Small residual normal (approaching)
    and tangential velocities of resting/sticking contacts left by the integration are
    removed by a velocity-stabilisation term v₀/Δt in b (documented deviation; it is the
    acceleration needed to null them over one step and is zero in exact arithmetic;
    velocities below 1e-8 m/s are left alone).

    The direct iteration starts from end-of-step forces extrapolated linearly from the
    previous step.

    Solving: the active set (free / stick / slide / impending slip per contact) of the previous solve is
    tried first (:func:`kernel.active_set_solve`); the answer is accepted only if it
    satisfies every condition of eqs. 3.6–3.7; otherwise the general solvers of
    :mod:`pbr_xval.reference.cone` are called. Every deviation from the paper is listed in
    :mod:`pbr_xval.reference` (the package docstring).

    Speed: :meth:`RigidBodySolver.step` runs the compiled :func:`kernel.step` (the same arithmetic
    as :meth:`RigidBodySolver._step_general`, kept equal by a test) and falls back to the NumPy
    step when an active-set guess fails.

Ground motion
    ``inertial``: the pedestal is the (non-inertial) reference frame, the load −m a_g(t) is
    added to gravity. ``moving_pedestal``: the world is inertial, the pedestal surface moves
    with the excitation's displacement/velocity/acceleration, contacts use relative
    kinematics, positions are reported relative to the pedestal.
"""

from __future__ import annotations

import bisect
import hashlib
import math
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from pbr_xval.linalg3 import eigh3, inv3, norm3
from pbr_xval.reference import cone, dense, kernel, pivoting, selection

__all__ = [
    "Body",
    "ContactStats",
    "ImpactPending",
    "Pedestal",
    "RigidBodySolver",
    "State",
    "cayley_project",
    "skew",
]

#: contact basis rows (n, x, y) for a horizontal pedestal surface
BASIS = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])

#: a step that ends with its deepest node at most this fraction of ε beyond the band (−ε) is
#: accepted, not stepped back: halving Δt cannot remove a penetration that was already at the
#: band's edge when the step began (a resting node drifting by round-off), and every halved
#: step would be rejected again — the step-back cascade. The engine then projects the rock
#: back onto the band (``ReferenceEngine``: ``band_projections`` in the diagnostics).
BAND_TOLERANCE = 1e-3

# empty arguments of kernel.step_block for the mode not used
_NO_EXC = np.zeros(0)
_NO_LOADS = np.zeros((0, 2, 3))
#: the count columns of a kernel step's info summed per block (:meth:`RigidBodySolver.account_block_impacts`)
_COUNT_COLS = [kernel.I_SOLVES, kernel.I_FAST, kernel.I_CAYLEY, kernel.I_ITS, kernel.I_CONV]
#: after a general resting solve, a sticking contact whose friction is within this fraction of
#: the static cone's radius is guessed as impending slip (status 3) by the next active-set solve
#: (a guess only, verified there; the 16-facet pyramid fallback reaches 98 % of the radius)
SLIP_GUESS_RTOL = 0.03


#: :func:`cull_tilts` answers by (node values, ε, n_ref): the same scanned rock is run many
#: times in one process (a campaign, a benchmark), ~3 ms per call on SP1's 875 nodes
_CULL_TILTS: dict[tuple[bytes, tuple[int, ...], float, int], np.ndarray] = {}
_CULL_TILTS_MAX = 8


def cull_tilts(nodes: np.ndarray, eps: float, n_ref: int = 64) -> np.ndarray:
    """θ_i (N,) rad: below this tilt node i stays more than 3ε above one of the ``n_ref`` lowest
    nodes (rest pose), whatever the orientation; −inf when no such bound exists. Memoised on
    the nodes' values (a copy is returned).

    With Δ = n_i − n_j and β its angle to the rest vertical, the height of i above j for a tilt
    θ is u·Δ ≥ |Δ| cos(β + θ) (u: the pedestal normal in body axes, within θ of the rest
    vertical), > 3ε while θ < arccos(3ε/|Δ|) − β; θ_i is the largest such bound over j.
    """
    nodes = np.ascontiguousarray(nodes, dtype=float)
    key = (hashlib.blake2b(nodes.tobytes(), digest_size=16).digest(), nodes.shape, float(eps), int(n_ref))
    hit = _CULL_TILTS.get(key)
    if hit is None:
        hit = _cull_tilts(nodes, eps, n_ref)
        if len(_CULL_TILTS) >= _CULL_TILTS_MAX:
            _CULL_TILTS.pop(next(iter(_CULL_TILTS)))
        _CULL_TILTS[key] = hit
    return hit.copy()


def _cull_tilts(nodes: np.ndarray, eps: float, n_ref: int) -> np.ndarray:
    """:func:`cull_tilts` computed."""
    ref = nodes[np.argsort(nodes[:, 2], kind="stable")[:n_ref]]
    d = nodes[:, None, :] - ref[None, :, :]
    dn = np.sqrt((d * d).sum(axis=2))
    with np.errstate(invalid="ignore", divide="ignore"):
        beta = np.arccos(np.clip(d[..., 2] / dn, -1.0, 1.0))
        lim = np.arccos(np.clip(3.0 * eps / dn, -1.0, 1.0)) - beta
    lim[~(dn > 3.0 * eps)] = -np.inf
    return lim.max(axis=1)


_ZERO3 = np.zeros(3)
_ZERO3.flags.writeable = False
_EYE3 = np.eye(3)
_EYE3.flags.writeable = False


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a × b for (3,) or (N, 3) arrays (broadcast); a fast replacement of ``np.cross``."""
    if a.ndim == 1 and b.ndim == 2:  # ω × r for all nodes: ω as plain floats
        a0, a1, a2 = a.tolist()
        b0, b1, b2 = b[:, 0], b[:, 1], b[:, 2]
        out = np.empty(b.shape)
        out[:, 0] = a1 * b2 - a2 * b1
        out[:, 1] = a2 * b0 - a0 * b2
        out[:, 2] = a0 * b1 - a1 * b0
        return out
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    """``np.array_equal`` for two arrays (without its wrapper overhead)."""
    return a.shape == b.shape and bool((a == b).all())


def skew(w: np.ndarray) -> np.ndarray:
    """[w]× (3, 3) such that [w]× u = w × u."""
    w0, w1, w2 = w.tolist()
    return np.array([[0.0, -w2, w1], [w2, 0.0, -w0], [-w1, w0, 0.0]])


def cayley(w: np.ndarray) -> np.ndarray:
    """Cayley transform of the rotation vector-like w: (I − [w]×/2)⁻¹ (I + [w]×/2) ∈ SO(3)
    (:func:`kernel._cayley`: cofactors, no LAPACK, the compiled step's arithmetic)."""
    return kernel._cayley(np.ascontiguousarray(w, dtype=float))


def cayley_project(r_new: np.ndarray, r_old: np.ndarray) -> np.ndarray:
    """Project ``r_new`` onto SO(3) with the Cayley transform (Cayley 1846).

    The increment ΔR = R_new R_oldᵀ (near identity for one step) is written through its
    Cayley parameter W = (ΔR − I)(ΔR + I)⁻¹ (skew for a rotation); the skew part of W is
    mapped back by Q = (I − W_s)⁻¹ (I + W_s), which is exactly orthogonal with det = +1.
    ``r_old`` must be a rotation. :func:`kernel._cayley_project`: the compiled step's
    arithmetic, no BLAS or LAPACK.
    """
    return kernel._cayley_project(
        np.ascontiguousarray(r_new, dtype=float), np.ascontiguousarray(r_old, dtype=float)
    )


@dataclass
class Body:
    """Rigid rock: mass (kg), inertia about the COM in body axes (3, 3), nodes (N, 3) in body
    coordinates relative to the COM (m)."""

    mass: float
    inertia: np.ndarray
    nodes: np.ndarray

    def __post_init__(self) -> None:
        self.inertia = np.asarray(self.inertia, dtype=float)
        self.inertia_inv = inv3(self.inertia)  # cofactors: no LAPACK (module docstring of dense)
        self.nodes = np.ascontiguousarray(self.nodes, dtype=float)


class State:
    """(u_cm, u̇_cm, R, l) of Section 3; world (inertial-mode: pedestal) frame.

    Stored in one packed buffer ``buf`` (18,) = (x, v, R row-major, l) that the compiled
    kernel reads and writes; ``x``, ``v``, ``R``, ``l`` are views of it (assigning one
    writes into the buffer).
    """

    __slots__ = ("_R", "_l", "_v", "_x", "buf")

    def __init__(self, x: np.ndarray, v: np.ndarray, R: np.ndarray, l: np.ndarray) -> None:  # noqa: E741
        buf = np.empty(18)
        buf[0:3] = x
        buf[3:6] = v
        buf[6:15] = np.ravel(R)
        buf[15:18] = l
        self._bind(buf)

    def _bind(self, buf: np.ndarray) -> None:
        self.buf = buf
        self._x = buf[0:3]
        self._v = buf[3:6]
        self._R = buf[6:15].reshape(3, 3)
        self._l = buf[15:18]

    @classmethod
    def from_buf(cls, buf: np.ndarray) -> State:
        s = cls.__new__(cls)
        s._bind(buf)
        return s

    x = property(lambda self: self._x, lambda self, val: self._x.__setitem__(slice(None), val))
    v = property(lambda self: self._v, lambda self, val: self._v.__setitem__(slice(None), val))
    R = property(lambda self: self._R, lambda self, val: self._R.__setitem__(slice(None), val))
    l = property(lambda self: self._l, lambda self, val: self._l.__setitem__(slice(None), val))  # noqa: E741

    def copy(self) -> State:
        return State.from_buf(self.buf.copy())


@dataclass
class Pedestal:
    """Horizontal pedestal surface z = d_z(t) (plane, or a box top limited to its extents).

    ``kinematics(t)`` returns the surface displacement, velocity and acceleration (3,) each;
    all zero in the inertial mode.
    """

    kind: str = "plane"
    half_extents: np.ndarray | None = None
    kinematics: Callable[[float], tuple[np.ndarray, np.ndarray, np.ndarray]] | None = None

    def motion(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        if self.kinematics is None:
            return _ZERO3, _ZERO3, _ZERO3
        return self.kinematics(t)

    def gaps(self, pts: np.ndarray, d: np.ndarray) -> np.ndarray:
        """Signed normal gap (N,) of world points (N, 3) to the surface displaced by d."""
        rel = pts - d
        g = rel[:, 2].copy()
        if self.kind == "box" and self.half_extents is not None:
            hx, hy = self.half_extents[0], self.half_extents[1]
            outside = (np.abs(rel[:, 0]) > hx) | (np.abs(rel[:, 1]) > hy)
            g[outside] = np.inf
        return g


@dataclass
class ContactStats:
    """Per-run solver diagnostics (Le Lidec et al.-style physical residuals)."""

    steps: int = 0
    stepbacks: int = 0
    cayley_projections: int = 0
    iterations_total: int = 0
    iterations_max: int = 0
    iteration_nonconverged: int = 0
    min_timestep_hits: int = 0
    impacts: int = 0
    kernel_steps: int = 0
    general_steps: int = 0
    full_solves: int = 0
    selection_reverted: int = 0
    lcp_solves: int = 0
    lcp_fast_path: int = 0
    lcp_pivots: int = 0
    lcp_failures: int = 0
    pgs_sweeps: int = 0
    cone_fallbacks: int = 0
    lcp_time: float = 0.0
    kernel_time: float = 0.0
    signorini_f: list[float] = field(default_factory=list)
    signorini_a: list[float] = field(default_factory=list)
    complementarity: list[float] = field(default_factory=list)
    cone: list[float] = field(default_factory=list)
    max_penetration: float = 0.0
    impact_ratios: list[float] = field(default_factory=list)

    def record_residuals(self, r: dict[str, float]) -> None:
        self.signorini_f.append(r.get("signorini_f", 0.0))
        self.signorini_a.append(r.get("signorini_a", 0.0))
        self.complementarity.append(r.get("complementarity", 0.0))
        self.cone.append(r.get("cone", 0.0))

    def summary(self) -> dict[str, Any]:
        def mx(a: list[float]) -> float:
            return float(np.max(a)) if a else 0.0

        def mean(a: list[float]) -> float:
            return float(np.mean(a)) if a else 0.0

        return {
            "steps": self.steps,
            "stepbacks": self.stepbacks,
            "min_timestep_hits": self.min_timestep_hits,
            "cayley_projections": self.cayley_projections,
            "iterations_mean": self.iterations_total / max(1, self.steps),
            "iterations_max": self.iterations_max,
            "iterations_nonconverged": self.iteration_nonconverged,
            "impacts": self.impacts,
            "kernel_steps": self.kernel_steps,
            "general_steps": self.general_steps,
            "lcp_full_solves": self.full_solves,
            "impact_selection_reverted": self.selection_reverted,
            "impact_ratios": [float(x) for x in self.impact_ratios[:50]],
            "lcp_solves": self.lcp_solves,
            "lcp_fast_path": self.lcp_fast_path,
            "lcp_pivots": self.lcp_pivots,
            "lcp_failures": self.lcp_failures,
            "pgs_sweeps": self.pgs_sweeps,
            "cone_fallbacks": self.cone_fallbacks,
            "lcp_time_s": self.lcp_time,
            "kernel_time_s": self.kernel_time,
            "impact_solves": self.impacts,
            "signorini_force_max": mx(self.signorini_f),
            "signorini_accel_max": mx(self.signorini_a),
            "signorini_accel_mean": mean(self.signorini_a),
            "signorini_gap_max_m": self.max_penetration,
            "complementarity_max": mx(self.complementarity),
            "complementarity_mean": mean(self.complementarity),
            "cone_violation_max": mx(self.cone),
            "max_penetration_m": self.max_penetration,
        }


class StepRejected(Exception):
    """A trial step penetrated deeper than ε."""


class ImpactPending(Exception):
    """:meth:`RigidBodySolver.step` with ``impact_check``: an in-band node approaches faster
    than ``impact_velocity`` at the start of the step (resolve the impact, then step)."""


@dataclass
class _Contacts:
    """Contacts of one step: node ids, status per contact (support-hull reduced)."""

    idx: np.ndarray
    slide: np.ndarray  # bool (k,) dynamic friction
    sdir: np.ndarray  # (k, 3) unit sliding direction (world) for sliding contacts
    stab: np.ndarray  # (3k,) velocity-stabilisation term v0/Δt added to b
    nodes: np.ndarray  # (k, 3) the contact nodes in body coordinates
    any_slide: bool = False


class RigidBodySolver:
    """Advances the :class:`State` by one constant-average-acceleration step with contact.

    Parameters
    ----------
    body : :class:`Body`.
    pedestal : :class:`Pedestal`.
    load : t -> (3,) acceleration of the COM from non-contact loads (gravity and, in the
        inertial mode, −a_g(t)), m/s².
    mu_s, mu_d, restitution : contact parameters.
    settings : the engine's resolved settings (``compiled``: run the step in
        :func:`kernel.step`; ``support_hull``: reduce the contact set to its support hull).
    """

    def __init__(
        self,
        body: Body,
        pedestal: Pedestal,
        load: Callable[[float], np.ndarray],
        mu_s: float,
        mu_d: float,
        restitution: float,
        settings: Mapping[str, Any],
    ) -> None:
        self.body = body
        self.ped = pedestal
        self.load = load
        self.mu_s = float(mu_s)
        self.mu_d = float(mu_d)
        self.e = float(restitution)
        self.eps = float(settings["epsilon"])
        self._dt_hint = float(settings["timestep"])  # the candidates of the impact check
        self.iterations = int(settings["iterations"])
        self.itol = float(settings["iteration_tol"])
        self.method = str(settings["lcp_method"])
        self.selection = str(settings["impact_selection"])
        self.v_imp = float(settings["impact_velocity"])
        self.v_sep = float(settings["separation_velocity"])
        self.v_slip = float(settings["slip_velocity"])
        self.orth_tol = float(settings["orthogonality_tol"])
        self.compiled = bool(settings.get("compiled", True))
        self.reduce = bool(settings.get("support_hull", True))
        #: accept the next step whatever its penetration (set by the caller after the
        #: step-back limit; counted and reported there)
        self.accept_any = False
        self.stats = ContactStats()
        n = body.nodes.shape[0]
        self._active = np.ones(
            n, dtype=np.int64
        )  # per node: 0 free, 1 stick, 2 slide, 3 impending slip (last solve)
        self._prev_force = np.zeros((n, 3))  # per node: last (n, x, y) contact force, N
        self._pred = np.zeros(9)  # predictor memory: valid, t1, Δt, F0 (3), τ0 (3)
        self._pred_idx = np.zeros(n + 1, dtype=np.int64)  # its contact ids (count first)
        self._load_cache: tuple[float, np.ndarray] = (math.nan, np.zeros(3))
        # the principal moments (ascending; eigh3: no LAPACK) and the largest node lever arm
        moments = eigh3(body.inertia)[0]
        lever = float(np.linalg.norm(body.nodes, axis=1).max())
        # angular-momentum scale per unit COM speed: λ_max(I') / (largest node lever arm)
        self._lref = float(moments[2]) / max(lever, 1e-300)
        self._size = max(lever, 1e-300)
        # impacts resolved inside kernel.step_block (layout kernel.IMP_*)
        closest = 1.0 if self.selection == "closest_to_previous" else 0.0
        self._imp = np.array([self.e, self.mu_s, 1.0 if self.reduce else 0.0, self._size, closest])
        self._kin_cache: tuple | None = None  # (state, t, node_kinematics(state, t))
        prm = np.zeros(kernel.N_PARAMS)
        prm[kernel.P_MASS] = body.mass
        prm[kernel.P_MU_S] = self.mu_s
        prm[kernel.P_MU_D] = self.mu_d
        prm[kernel.P_EPS] = self.eps
        prm[kernel.P_ITER] = self.iterations
        prm[kernel.P_ITOL] = self.itol
        prm[kernel.P_VSEP] = self.v_sep
        prm[kernel.P_VSLIP] = self.v_slip
        prm[kernel.P_ORTH] = self.orth_tol
        prm[kernel.P_LREF] = self._lref
        if pedestal.kind == "box" and pedestal.half_extents is not None:
            prm[kernel.P_PED_KIND] = 1.0
            prm[kernel.P_HX], prm[kernel.P_HY] = pedestal.half_extents[0], pedestal.half_extents[1]
        prm[kernel.P_REDUCE] = 1.0 if self.reduce else 0.0
        prm[kernel.P_COS_CAND] = -2.0
        prm[kernel.P_VIMP] = self.v_imp
        self._prm = prm
        # candidate nodes (exact culling, see :meth:`candidates`): every node on a box pedestal
        # (a node beside the box can hang below its top), else by tilt
        self._all = np.arange(n, dtype=np.int64)
        self._cull = pedestal.kind == "plane" and n > 8
        self._cand_cache: dict[int, np.ndarray] = {}
        self._cand_key: tuple[float, float] = (math.nan, 0.0)
        self._cand_n = n
        if self._cull:
            lim = cull_tilts(body.nodes, self.eps)
            self._cull_lim_id = lim  # per node id (kernel.step_block)
            self._cull_order = np.argsort(lim, kind="stable")
            self._cull_lim = lim[self._cull_order].tolist()
        # |ω| ≤ |l| / λ_min(I): the tilt margin of a step
        self._inv_lmin = 1.0 / max(float(moments[0]), 1e-300)
        self._ext = np.zeros((7, 3))
        self._info = np.zeros(kernel.N_INFO)
        self.last_gaps = np.zeros(n)
        self.last_force = np.zeros(3)
        self.last_torque = np.zeros(3)
        #: after :meth:`step`: ω (3,) at the end of the step, rad/s; the smallest node gap (m)
        #: and the number of nodes within ε
        self.last_omega: Any = np.zeros(3)
        self.last_gmin = 0.0
        self.last_ncontacts = 0

    # ------------------------------------------------------------------ kinematics
    def omega(self, s: State) -> np.ndarray:
        """ω = I⁻¹ l with I = R I' Rᵀ (Section 3)."""
        return kernel._omega(np.ascontiguousarray(s.R), self.body.inertia_inv, np.ascontiguousarray(s.l))

    def inv_inertia_world(self, R: np.ndarray) -> np.ndarray:
        R = np.ascontiguousarray(R)
        return kernel._mmt(kernel._mm(R, self.body.inertia_inv), R)

    def node_kinematics(self, s: State, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Lever arms r (N, 3), gaps (N,), relative velocities (N, 3) in the (n, x, y) basis, ω.

        The answer for the last (state object, t) is kept: the impact check and the contact
        set of the step that follows are made at the same state."""
        kc = self._kin_cache
        if kc is not None and kc[0] is s and kc[1] == t and np.array_equal(kc[3], s.buf):
            return kc[2]
        r = kernel._points_mt(self.body.nodes, np.ascontiguousarray(s.R))
        d, vp, _ = self.ped.motion(t)
        gaps = self.ped.gaps(s.x + r, d)
        w = self.omega(s)
        vel = s.v + cross(w, r) - vp
        out = (r, gaps, np.ascontiguousarray(vel[:, (2, 0, 1)]), w)  # vel @ BASIS.T, a permutation
        self._kin_cache = (s, t, out, s.buf.copy())
        return out

    def candidates(self, s: State, dt: float) -> np.ndarray:
        """The nodes (ascending ids) that can come within ε of the pedestal during a step of
        ``dt`` from ``s``; sets ``P_COS_CAND`` for the kernel.

        Exact culling: node i stays more than 3ε above some node j — so out of the band while
        no node is deeper than 2ε — at every orientation whose tilt (the angle between the
        body's rest vertical and the pedestal normal) is below ``cull_tilts``'s θ_i. The
        candidates are the nodes with θ_i ≤ the start tilt + 0.02 rad + 2|ω|Δt (|ω| ≤ |l|/λ_min);
        the kernel checks the end of the step against every node when it ends beyond that tilt
        or deeper than 2ε. A rock standing on a scanned base keeps a few tens of its 875 nodes.
        """
        if not self._cull:
            return self._all
        b = s.buf
        c = min(1.0, max(-1.0, float(b[14])))  # R[2, 2]: cos of the tilt
        lx, ly, lz = float(b[15]), float(b[16]), float(b[17])
        lmag = math.sqrt(lx * lx + ly * ly + lz * lz)
        key = (c, lmag)
        prm = self._prm
        if key != self._cand_key:
            th = math.acos(c) + 0.02 + 2.0 * dt * lmag * self._inv_lmin
            self._cand_key = key
            if th >= math.pi:
                self._cand_n = len(self._cull_lim)
                prm[kernel.P_COS_CAND] = -2.0
            else:
                self._cand_n = bisect.bisect_right(self._cull_lim, th)
                prm[kernel.P_COS_CAND] = math.cos(th)
        n_c = self._cand_n
        cand = self._cand_cache.get(n_c)
        if cand is None:
            cand = np.sort(self._cull_order[:n_c]).astype(np.int64)
            self._cand_cache[n_c] = cand
        return cand

    def impact_pending(self, s: State, t: float) -> bool:
        """True when an in-band node approaches faster than ``impact_velocity`` (eq. 3.5)."""
        d, vp, _ = self.ped.motion(t)
        prm = self._prm
        return bool(
            kernel.impact_pending(
                s.buf,
                self.body.inertia_inv,
                self.body.nodes,
                self.candidates(s, self._dt_hint),
                d,
                vp,
                self.eps,
                self.v_imp,
                int(prm[kernel.P_PED_KIND]),
                prm[kernel.P_HX],
                prm[kernel.P_HY],
            )
        )

    # ------------------------------------------------------------------ resting contact
    def _load(self, t: float) -> np.ndarray:
        if t != self._load_cache[0]:
            self._load_cache = (t, np.asarray(self.load(t), dtype=float))
        return self._load_cache[1]

    def contact_forces(
        self, s: State, t: float, c: _Contacts, diag: bool = False
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Total force F_T (3,), torque τ_T (3,) and contact forces f (3k,) at state s (eqs. 3.6–3.7).

        a = A f + b with A = G_m M⁻¹ G_fᵀ (:func:`kernel.contact_problem`) and b the free
        relative acceleration of the contact points (gravity, ground load, centripetal and
        gyroscopic terms, velocity stabilisation). ``diag``: record the eq. 3.6–3.7
        residuals of this solve.
        """
        m = self.body.mass
        a_load = self._load(t)
        k = c.idx.size
        if k == 0:
            return m * a_load, np.zeros(3), np.zeros(0)
        _, _, ap = self.ped.motion(t)
        A, b, gf, cons = kernel.contact_problem(
            s.R, s.l, self.body.inertia_inv, m, c.nodes, c.slide, c.sdir, c.stab, a_load - ap, self.mu_d
        )
        f = self._solve_resting(A, b, c, diag, 2.0 * cons)
        wrench = dense.matvec(np.ascontiguousarray(gf.T), f)
        return m * a_load + wrench[:3], wrench[3:], f

    def _resting_guess(self, c: _Contacts) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The active-set guess of a resting solve from the last solve's statuses and forces:
        (status (k,) int: 0 free, 1 sticking, 2 sliding, 3 impending slip; tdir (k, 2): the
        impending slip's friction direction from the last solve; mu (k,) static friction)."""
        k = c.idx.size
        status = self._active[c.idx]
        status = np.where(c.slide, np.where(status == 0, 0, 2), np.where(status == 2, 1, status))
        # impending slip (status 3): the friction's direction from the last solve
        prev_t = self._prev_force[c.idx, 1:]
        ft = np.hypot(prev_t[:, 0], prev_t[:, 1])
        status = np.where((status == 3) & (ft == 0.0), 1, status)
        tdir = np.divide(prev_t, ft[:, None], out=np.zeros((k, 2)), where=ft[:, None] > 0)
        return status, tdir, np.full(k, self.mu_s)

    def _solve_resting(
        self, A: np.ndarray, b: np.ndarray, c: _Contacts, diag: bool, cons_tol: float
    ) -> np.ndarray:
        t0 = time.perf_counter()
        k = c.idx.size
        self.stats.lcp_solves += 1
        status, tdir, mu = self._resting_guess(c)
        # A and tdir in the compiled callers' layout (kernel.layout_a: same values), so that
        # this call uses their compilation of the solve
        A_, tdir_ = kernel.layout_a(A), kernel.layout_a(tdir)
        ok, f, a, st = kernel.active_set_solve(A_, b, status, mu, cons_tol, k + 2, tdir_, c.slide)
        if not ok:
            ok, f, a, st = kernel.active_set_retry(A_, b, status, mu, cons_tol, k + 2, tdir_, c.slide, c.stab)
        if ok:
            self.stats.lcp_fast_path += 1
        else:
            f = self._full_resting(A, b, c)
            a = dense.matvec(np.ascontiguousarray(A), f) + b
            F = f.reshape(k, 3)
            # a sticking contact whose friction is at the static cone (impending slip) is
            # guessed as such by the next solve, its friction's direction from this one
            at_cone = np.hypot(F[:, 1], F[:, 2]) >= self.mu_s * F[:, 0] * (1.0 - SLIP_GUESS_RTOL)
            st = np.where(F[:, 0] > 0, np.where(c.slide, 2, np.where(at_cone & (self.mu_s > 0), 3, 1)), 0)
        self._active[c.idx] = st
        if diag:
            self._record_residuals(f, a, c.slide, c.any_slide)
        self._prev_force[c.idx] = f.reshape(k, 3)
        self.stats.lcp_time += time.perf_counter() - t0
        return f

    def _record_residuals(self, f: np.ndarray, a: np.ndarray, slide: np.ndarray, c_any_slide: bool) -> None:
        """Record the eq. 3.6–3.7 residuals kept in the statistics (Signorini on f and a,
        complementarity, cone; μ = 0 for sliding contacts, whose tangential force rides on
        the normal one)."""
        fn, ft1, ft2 = f[0::3], f[1::3], f[2::3]
        an = a[0::3]
        ft_norm = np.sqrt(ft1 * ft1 + ft2 * ft2)
        mu_fn = self.mu_s * fn
        if c_any_slide:
            mu_fn = np.where(slide, 0.0 * fn, mu_fn)
        self.stats.record_residuals(
            {
                "signorini_f": max(0.0, -float(fn.min())),
                "signorini_a": max(0.0, -float(an.min())),
                "complementarity": float(np.abs(fn * an).max()),
                "cone": max(0.0, float((ft_norm - mu_fn).max())),
            }
        )

    def _full_resting(self, A: np.ndarray, b: np.ndarray, c: _Contacts) -> np.ndarray:
        """The general resting solve when no active-set guess verifies (rare)."""
        k = c.idx.size
        self.stats.full_solves += 1
        if np.all(c.slide):
            # all contacts sliding: normal-only LCP with the non-symmetric A' (eq. 3.6 + μ_d)
            An = A[0::3, 0::3]
            lres = pivoting.solve_lcp(An, b[0::3], method=self.method)
            self.stats.lcp_pivots += lres.pivots
            if not lres.ok:
                self.stats.lcp_failures += 1
            f = np.zeros(3 * k)
            f[0::3] = lres.z
            return f
        mu = np.where(c.slide, 0.0, self.mu_s)
        warm = self._prev_force[c.idx].reshape(-1)
        res = cone.solve_friction_cone(A, b, mu, tol=1e-12, max_iter=60, restart_after=30, warm_start=warm)
        self.stats.pgs_sweeps += res.iterations
        if not res.converged:
            # fall back to pivoting on a 16-facet friction pyramid (Lemke), exact for
            # sticking contacts
            pyr = cone.solve_friction_pyramid(A, b, mu, n_facets=16)
            self.stats.cone_fallbacks += 1
            if pyr.ok:
                res = pyr
            else:
                self.stats.lcp_failures += 1
        f = res.f.copy()
        f.reshape(k, 3)[c.slide, 1:] = 0.0
        return f

    # ------------------------------------------------------------------ collisions (eq. 3.5)
    def resolve_impacts(self, s: State, t: float, dt: float) -> tuple[State, dict[str, Any] | None]:
        """Apply eq. 3.5 impulses when an in-band contact approaches faster than ``impact_velocity``."""
        # the kinematics of the candidate nodes only (the in-band nodes are among them, see
        # :meth:`candidates`), computed as :meth:`impact_pending` does
        d, vped, _ = self.ped.motion(t)
        prm = self._prm
        cand = self.candidates(s, self._dt_hint)
        r_all, gaps, vel, w = kernel.kinematics(
            s.buf,
            self.body.inertia_inv,
            self.body.nodes,
            cand,
            d,
            vped,
            int(prm[kernel.P_PED_KIND]),
            prm[kernel.P_HX],
            prm[kernel.P_HY],
        )
        inband = cand[gaps[cand] <= self.eps]
        if inband.size == 0:
            return s, None
        vn = vel[inband, 0]
        if not (vn < -self.v_imp).any():
            return s, None
        t0 = time.perf_counter()
        idx = inband
        if self.reduce and self.e == 0.0 and idx.size > 3:
            # exact for e = 0: the post-impact velocity is affine in the contact position
            idx = kernel.support_hull(self.body.nodes, idx, 1e-9 * self._size)
        r = r_all[idx]
        k = idx.size
        vn = vel[idx, 0]
        bvel = np.ascontiguousarray(vel[idx].reshape(-1))
        prev = self._prev_force[idx].reshape(-1) * dt
        # A = G M⁻¹ Gᵀ, q = v⁻ + e v_n⁻ (restitution: w = v⁺ + e v⁻ ≥ 0 for approaching
        # contacts); the impact cone (velocity form of eqs. 3.6–3.7 with μ_s) by the active-set
        # guess "approaching contacts stick, the others separate" (impending slip found by its
        # corrections), verified; eq. 3.5 on the normal impulses, tangential impulses held
        # fixed, when its solution is unique (compiled; the other stages below)
        ref = prev[0::3].copy() if self.selection == "closest_to_previous" else np.zeros(k)
        stage, A, q, j = kernel.impact_impulses(
            s.R, self.body.inertia_inv, self.body.mass, np.ascontiguousarray(r), bvel, self.e, self.mu_s, ref
        )
        if stage == kernel.IMPACT_CONE:
            # the iterative cone solver
            res = cone.solve_friction_cone(A, q, self.mu_s, tol=1e-13, max_iter=20000, warm_start=prev)
            self.stats.pgs_sweeps += res.iterations
            if not res.converged:
                self.stats.lcp_failures += 1
            j = res.f.copy()
        elif stage == kernel.IMPACT_REVERTED:
            self.stats.selection_reverted += 1
        if stage in (kernel.IMPACT_CONE, kernel.IMPACT_SELECT):
            self._impact_normals(A, q, j, prev)
        jt = j.reshape(k, 3)
        # velocity jump: Δu̇_cm = Σ J / m, Δl = Σ r × J (compiled)
        v2, l2, nw2, vn_after, wres = kernel.impact_finish(
            s.R, self.body.inertia_inv, self.body.mass, np.ascontiguousarray(r), A, q, bvel, j, s.v, s.l
        )
        res6 = cone._residuals(j, wres, np.full(k, self.mu_s))
        st = self.stats
        st.signorini_f.append(float(res6[0]))
        st.signorini_a.append(float(res6[1]))
        st.complementarity.append(float(res6[2]))
        st.cone.append(float(res6[3]))
        self._pred[0] = 0.0
        s2 = s.copy()
        s2.v = v2
        s2.l = l2
        self._prev_force[inband] = 0.0
        self._prev_force[idx] = jt / max(dt, 1e-300)
        self._active[inband] = 0
        self._active[idx] = np.where(jt[:, 0] > 0, 1, 0)
        self.stats.lcp_time += time.perf_counter() - t0
        vmin = float(vn.min())
        nw = norm3(w)
        info = {
            "v_n_min": vmin,
            "nodes": int(inband.size),
            "hull_nodes": int(k),
            "impulse_nodes": int(np.sum(jt[:, 0] > 0)),
            "omega_before": nw,
            "omega_after": nw2,
            "ratio": nw2 / nw if nw > 0 else float("nan"),
            "v_n_after_min": float(vn_after),
        }
        return s2, info

    def _impact_normals(self, A: np.ndarray, q: np.ndarray, j: np.ndarray, prev: np.ndarray) -> None:
        """Eq. 3.5 on the normal impulses of ``j`` (written), its tangential impulses held fixed,
        when :func:`kernel.impact_impulses` did not answer: selection among the (for e = 0 and
        redundant contacts) non-unique solutions."""
        # a positive definite, well-conditioned A_nn (at most three non-collinear hull
        # contacts, the common case) has one solution: no selection to make, and the
        # enumeration of its principal subsets finds it faster than pivoting (compiled, the
        # arithmetic of the kernel's in-block impacts)
        unique, reverted, qn, Ann = kernel.impact_cone_normals(A, q, j, float(self.mu_s))
        if unique:
            if reverted:
                self.stats.selection_reverted += 1
            return
        ref = prev[0::3] if self.selection == "closest_to_previous" else None
        resn = selection.solve_lcp_min_norm(Ann, qn, reference=ref, method=self.method)
        self.stats.lcp_pivots += resn.pivots
        res_ok, zn = resn.ok, resn.z
        jn_cone = j[0::3].copy()
        if res_ok:
            j[0::3] = zn
            # the re-selection moves normal impulse only within null(A_nn) (no change of
            # motion); keep it only if every tangential impulse stays inside its cone (the
            # check of the compiled stages, kernel._outside_cone)
            zc = np.ascontiguousarray(zn, dtype=float)
            if self.mu_s > 0 and kernel._outside_cone(j, zc, float(self.mu_s)):
                j[0::3] = jn_cone
                self.stats.selection_reverted += 1
        else:
            self.stats.lcp_failures += 1
            if self.mu_s == 0:
                j[0::3] = np.maximum(zn, 0.0)

    @staticmethod
    def _jacobians(r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Contact Jacobian rows (3k, 6) = [d, r × d] per (n, x, y) = (ez, ex, ey)."""
        k = r.shape[0]
        gm = np.zeros((k, 3, 6))
        gm[:, 0, 2] = 1.0
        gm[:, 1, 0] = 1.0
        gm[:, 2, 1] = 1.0
        rx, ry, rz = r[:, 0], r[:, 1], r[:, 2]
        gm[:, 0, 3], gm[:, 0, 4] = ry, -rx
        gm[:, 1, 4], gm[:, 1, 5] = rz, -ry
        gm[:, 2, 3], gm[:, 2, 5] = -rz, rx
        rows = gm.reshape(3 * k, 6)
        return rows, rows

    def _inv_mass(self, R: np.ndarray) -> np.ndarray:
        """M⁻¹ = diag(I₃/m, I_world⁻¹) (6, 6)."""
        w = np.zeros((6, 6))
        w[:3, :3] = np.eye(3) / self.body.mass
        w[3:, 3:] = self.inv_inertia_world(R)
        return w

    # ------------------------------------------------------------------ one step
    def _contacts(self, s: State, t: float, dt: float) -> _Contacts:
        _, gaps, vel, _ = self.node_kinematics(s, t)
        idx, slide, sdir, stab = kernel.contact_set(
            gaps,
            vel,
            self.body.nodes,
            self._all,
            self.eps,
            self.v_sep,
            self.v_slip,
            self.mu_d,
            dt,
            self.reduce,
        )
        return _Contacts(
            idx=idx,
            slide=slide,
            sdir=sdir,
            stab=stab,
            nodes=self.body.nodes[idx],
            any_slide=bool(slide.any()),
        )

    def step(self, s0: State, t0: float, dt: float, impact_check: bool = False) -> tuple[State, int]:
        """Constant-average-acceleration step t0 → t0 + dt with direct iteration.

        Runs :func:`kernel.step` (``compiled``); when it reports that an active-set guess
        failed, the step is repeated here with the general resting solver.
        ``impact_check`` (compiled only): first the :meth:`impact_pending` test, made by the
        kernel on the kinematics it computes anyway.

        Raises
        ------
        StepRejected
            if a node ends the step deeper than ε below the pedestal surface (unless
            ``accept_any`` is set).
        ImpactPending
            with ``impact_check``, if :meth:`impact_pending` holds at the start (nothing
            else was done).
        """
        t1 = t0 + dt
        tl0 = t0 + 1e-9 * dt  # one-sided load values at the step ends (pulse jumps)
        tl1 = t1 - 1e-9 * dt
        if self.compiled:
            prm = self._prm
            prm[kernel.P_T0] = t0
            prm[kernel.P_DT] = dt
            prm[kernel.P_NO_PEN] = 1.0 if self.accept_any else 0.0
            prm[kernel.P_IMPACT] = 1.0 if impact_check else 0.0
            ext = self._ext
            ext[0] = self._load(tl0)
            ext[1] = self._load(tl1)
            if self.ped.kinematics is not None:
                ext[2], ext[3], _ = self.ped.motion(t0)
                ext[4] = self.ped.motion(tl0)[2]
                ext[5] = self.ped.motion(tl1)[2]
                ext[6] = self.ped.motion(t1)[0]
            out = np.empty(18)
            gaps = np.empty(self.body.nodes.shape[0])
            info = self._info
            cand = self.candidates(s0, dt)
            t_lcp = time.perf_counter()
            code = kernel.step(
                s0.buf,
                prm,
                ext,
                self.body.inertia_inv,
                self.body.nodes,
                cand,
                self._active,
                self._prev_force,
                self._pred,
                self._pred_idx,
                out,
                gaps,
                info,
            )
            if code == kernel.STEP_IMPACT:
                raise ImpactPending()
            st = self.stats
            if code != kernel.STEP_GENERAL:
                st.kernel_time += time.perf_counter() - t_lcp
                its, conv, solves, fast, cay, ncont, gmin, f0, f1, f2, q0, q1, q2, *_rest = info.tolist()
                its = int(its)
                st.kernel_steps += 1
                st.lcp_solves += int(solves)
                st.lcp_fast_path += int(fast)
                st.cayley_projections += int(cay)
                st.iterations_total += its
                if its > st.iterations_max:
                    st.iterations_max = its
                if not conv:
                    st.iteration_nonconverged += 1
                if info[kernel.I_NRES]:
                    st.signorini_f.append(info[kernel.I_SIG_F])
                    st.signorini_a.append(info[kernel.I_SIG_A])
                    st.complementarity.append(info[kernel.I_COMPL])
                    st.cone.append(max(0.0, info[kernel.I_CONE]))
                self.last_gaps = gaps
                self.last_gmin = gmin
                self.last_ncontacts = int(ncont)
                self.last_force = np.array((f0, f1, f2))
                self.last_torque = np.array((q0, q1, q2))
                self.last_omega = _rest[:3]
                if code == kernel.STEP_REJECTED and gmin < -self.eps * (1.0 + BAND_TOLERANCE):
                    raise StepRejected(gmin)
                return State.from_buf(out), its
            st.general_steps += 1
        return self._step_general(s0, t0, dt, tl0, tl1)

    def step_block(
        self, s0: State, steps: list[tuple[float, float]], loads: np.ndarray, rest: np.ndarray
    ) -> tuple[int, int, np.ndarray, np.ndarray, np.ndarray, dict[str, Any] | None]:
        """:func:`kernel.step_block`: the steps ``steps`` [(t0, Δt), …] from ``s0`` with the
        loads ``loads`` (n, 2, 3) (at t0⁺, t1⁻), as many as need no Python path; inertial
        ground motion, compiled only. An eq. 3.5 impact at the first step is resolved in the
        kernel when its compiled stages answer; its statistics are counted here and its event
        data (the ``info`` of :meth:`resolve_impacts`) returned. The statistics of the steps
        and the ``last_*`` attributes are updated by :meth:`account_block`.

        Returns (steps done, exit code, states (done, 18), infos (done, N_INFO), band
        projections (done,) m, the impact's event data or None).
        """
        n = len(steps)
        t0s = np.array([a for a, _ in steps])
        hs = np.array([b for _, b in steps])
        done, code, rows_sv, rows_info, rows_lift, _, _, rows_imp = self._kernel_block(
            s0, rest, n, 1, loads, t0s, hs, (_NO_EXC, _NO_EXC), _NO_EXC, _NO_EXC
        )
        info = None
        if done > 0 and rows_imp[0, kernel.J_FLAG]:
            info = self._block_impact_info(rows_imp[0])
        return done, code, rows_sv[:done], rows_info[:done], rows_lift[:done], info

    def step_block_own(
        self,
        s0: State,
        exc: tuple[np.ndarray, np.ndarray],
        grid: np.ndarray,
        bps: np.ndarray,
        rest: np.ndarray,
    ) -> tuple[int, int, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """:func:`kernel.step_block` with the excitation evaluated in the kernel: the steps
        from ``grid[0]`` (s) on the engine's time grid (``grid``: start, nominal Δt, duration,
        step-back limit, minimum Δt, at most this many accepted steps; ``bps`` the
        breakpoints, s), with the step-backs made in the kernel. ``exc`` is
        ``adapter.compiled_excitation``'s (layout, samples).

        Returns (rows done, exit code, states (done, 18), infos (done, N_INFO), band
        projections (done,) m, times after the steps (done,) s, accepted (done,) bool — the
        rejected attempts of step-backs are rows too — and the impacts resolved at the rows'
        starts (done, N_IMP), layout ``J_*``: the caller counts the kept ones in order with
        :meth:`account_block` and :meth:`_block_impact_info`).
        """
        cap = 2 * int(grid[5]) + int(grid[3]) + 1
        done, code, rows_sv, rows_info, rows_lift, rows_t, rows_acc, rows_imp = self._kernel_block(
            s0, rest, cap, cap, _NO_LOADS, _NO_EXC, _NO_EXC, exc, grid, bps
        )
        return (
            done,
            code,
            rows_sv[:done],
            rows_info[:done],
            rows_lift[:done],
            rows_t[:done],
            rows_acc[:done] != 0,
            rows_imp[:done],
        )

    def _kernel_block(
        self,
        s0: State,
        rest: np.ndarray,
        n_rows: int,
        n_imp: int,
        loads: np.ndarray,
        t0s: np.ndarray,
        hs: np.ndarray,
        exc: tuple[np.ndarray, np.ndarray],
        grid: np.ndarray,
        bps: np.ndarray,
    ) -> tuple[int, int, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """One :func:`kernel.step_block` call with fresh output rows — ``n_rows`` rows of states,
        infos, band projections, times and acceptance, ``n_imp`` impact rows — either on planned
        steps (``loads``, ``t0s``, ``hs``; ``exc``, ``grid``, ``bps`` empty) or on the kernel's
        own grid (``exc``, ``grid``, ``bps``; the planned ones empty). Returns (done, code,
        rows_sv, rows_info, rows_lift, rows_t, rows_acc, rows_imp), the rows untrimmed."""
        rows_sv = np.empty((n_rows, 18))
        rows_info = np.zeros((n_rows, kernel.N_INFO))
        rows_lift = np.zeros(n_rows)
        rows_t = np.zeros(n_rows)
        rows_acc = np.zeros(n_rows)
        rows_imp = np.zeros((n_imp, kernel.N_IMP))
        gaps = np.empty(self.body.nodes.shape[0])
        cull_lim = self._cull_lim_id if self._cull else np.zeros(0)
        self._cand_key = (math.nan, 0.0)  # the kernel sets P_COS_CAND: recompute next time
        done, code = kernel.step_block(
            s0.buf,
            self._prm,
            loads,
            t0s,
            hs,
            self.body.inertia_inv,
            self.body.nodes,
            self._cull,
            cull_lim,
            self._inv_lmin,
            BAND_TOLERANCE,
            rest,
            self._active,
            self._prev_force,
            self._pred,
            self._pred_idx,
            gaps,
            rows_sv,
            rows_info,
            rows_lift,
            self._imp,
            rows_imp,
            exc[0],
            exc[1],
            grid,
            bps,
            rows_t,
            rows_acc,
        )
        return int(done), int(code), rows_sv, rows_info, rows_lift, rows_t, rows_acc, rows_imp

    def _block_impact_info(self, row: np.ndarray) -> dict[str, Any]:
        """Statistics and event data of an impact resolved by :func:`kernel.step_block`
        (its row ``row``, layout ``J_*``), as :meth:`resolve_impacts` records them."""
        st = self.stats
        v = row.tolist()  # the row's values as Python floats (float(row[j]), one call)
        st.signorini_f.append(v[kernel.J_SIGF])
        st.signorini_a.append(v[kernel.J_SIGA])
        st.complementarity.append(v[kernel.J_COMPL])
        st.cone.append(v[kernel.J_CONE])
        if v[kernel.J_REVERTED]:
            st.selection_reverted += 1
        st.pgs_sweeps += int(v[kernel.J_SWEEPS])
        w = row[kernel.J_W0 : kernel.J_W0 + 3].copy()
        nw = norm3(w)
        nw2 = v[kernel.J_W1]
        return {
            "v_n_min": v[kernel.J_VNMIN],
            "nodes": int(v[kernel.J_NODES]),
            "hull_nodes": int(v[kernel.J_HULL]),
            "impulse_nodes": int(v[kernel.J_IMPULSE]),
            "omega_before": nw,
            "omega_after": nw2,
            "ratio": nw2 / nw if nw > 0 else float("nan"),
            "v_n_after_min": v[kernel.J_VNAFTER],
        }

    def account_block(self, info: np.ndarray) -> None:
        """Statistics and ``last_*`` of the steps of :meth:`step_block` (rows ``info``) that
        the run keeps, as :meth:`step` records them step by step."""
        self.account_block_impacts(info, None)

    def account_block_impacts(self, info: np.ndarray, imps: np.ndarray | None) -> list[dict[str, Any]]:
        """:meth:`account_block` of the rows ``info`` (m, N_INFO) of a block and
        :meth:`_block_impact_info` of the impacts it resolved (``imps`` (m, N_IMP), flagged
        rows, layout ``J_*``; None: no impact), the residual lists in the step-by-step order (an impact's before
        the rows from its step on); returns the impacts' event data, in order.

        The same lists and counts as :meth:`account_block` called on each segment between
        impacts and :meth:`_block_impact_info` on each impact, in one pass: the counts are
        sums of small integers (exact in any order) and maxima."""
        m = info.shape[0]
        if m == 0:
            return []
        flagged: list[int] = []
        rows_imp = np.zeros((0, kernel.N_IMP))
        if imps is not None:
            flagged = np.flatnonzero(imps[:, kernel.J_FLAG]).tolist()
            rows_imp = imps
        st = self.stats
        # the counts' column sums in one reduction (small integers: exact in any order)
        tot = info[:, _COUNT_COLS].sum(axis=0).tolist()
        st.kernel_steps += m
        st.lcp_solves += int(tot[0])
        st.lcp_fast_path += int(tot[1])
        st.cayley_projections += int(tot[2])
        st.iterations_total += int(tot[3])
        st.iterations_max = max(st.iterations_max, int(info[:, kernel.I_ITS].max()))
        st.iteration_nonconverged += m - int(tot[4])
        has = info[:, kernel.I_NRES] != 0
        res = info[has]
        cols = (
            res[:, kernel.I_SIG_F].tolist(),
            res[:, kernel.I_SIG_A].tolist(),
            res[:, kernel.I_COMPL].tolist(),
            np.maximum(0.0, res[:, kernel.I_CONE]).tolist(),
        )
        lists = (st.signorini_f, st.signorini_a, st.complementarity, st.cone)
        # residual rows before each impact's row (a cumulative count)
        before = np.concatenate(([0], np.cumsum(has))).tolist()
        out = []
        a = 0
        for j in flagged:
            b = before[j]
            if b > a:
                for lst, col in zip(lists, cols, strict=True):
                    lst.extend(col[a:b])
            a = b
            out.append(self._block_impact_info(rows_imp[j]))
        if len(cols[0]) > a:
            for lst, col in zip(lists, cols, strict=True):
                lst.extend(col[a:])
        last = info[-1]
        self.last_gmin = float(last[kernel.I_GMIN])
        self.last_ncontacts = int(last[kernel.I_NCONT])
        self.last_force = last[kernel.I_F1 : kernel.I_F1 + 3].copy()
        self.last_torque = last[kernel.I_TAU1 : kernel.I_TAU1 + 3].copy()
        self.last_omega = last[kernel.I_OMEGA : kernel.I_OMEGA + 3].tolist()
        return out

    def _step_general(self, s0: State, t0: float, dt: float, tl0: float, tl1: float) -> tuple[State, int]:
        """:meth:`step` in NumPy with the general resting solver (same arithmetic as
        :func:`kernel.step`)."""
        m = self.body.mass
        t1 = t0 + dt
        c = self._contacts(s0, t0, dt)
        F0, tau0, _ = self.contact_forces(s0, tl0, c, diag=True)
        w0 = self.omega(s0)
        W0R0 = kernel._mm(skew(w0), s0.R)
        # predictor: trapezoid with the end forces extrapolated linearly from the previous
        # step (explicit Euler after an impact, a breakpoint or a change of step)
        Fp, taup = F0, tau0
        pr, pidx = self._pred, self._pred_idx
        k = c.idx.size
        if pr[0] > 0 and pr[1] == t0 and pr[2] == dt and pidx[0] == k and _same(pidx[1 : 1 + k], c.idx):
            Fp, taup = 2.0 * F0 - pr[3:6], 2.0 * tau0 - pr[6:9]
        vp = s0.v + 0.5 * dt * (F0 + Fp) / m
        lp = s0.l + 0.5 * dt * (tau0 + taup)
        s1 = State(s0.x + 0.5 * dt * (s0.v + vp), vp, kernel._mm(cayley(dt * w0), s0.R), lp)
        its = 0
        converged = False
        # convergence scales: the current momentum, or what the loads (≈ g) give in one step
        a0 = self._load(tl0)
        vscale = max(norm3(s0.v), norm3(a0) * dt, 1e-300)
        lscale = max(norm3(s0.l), self._lref * vscale, 1e-300)
        F1, tau1 = F0, tau0
        for it in range(1, self.iterations + 1):
            its = it
            F1, tau1, _ = self.contact_forces(s1, tl1, c)
            v1 = s0.v + 0.5 * dt * (F0 + F1) / m  # eq. 3.2, constant average acceleration
            x1 = s0.x + 0.5 * dt * (s0.v + v1)  # eq. 3.1
            l1 = s0.l + 0.5 * dt * (tau0 + tau1)  # eq. 3.4
            w1 = kernel._omega(s1.R, self.body.inertia_inv, l1)  # ω = I⁻¹ l at the current R estimate
            R1 = s0.R + 0.5 * dt * (W0R0 + kernel._mm(skew(w1), s1.R))  # eq. 3.3, trapezoidal
            # det R = 1 and RᵀR = I check; Cayley projection back onto SO(3)
            if (
                abs(kernel._det3(R1) - 1.0) > self.orth_tol
                or abs(kernel._mm(np.ascontiguousarray(R1.T), R1) - _EYE3).max() > self.orth_tol
            ):
                R1 = cayley_project(R1, s0.R)
                self.stats.cayley_projections += 1
            ddv, ddl = v1 - s1.v, l1 - s1.l
            dv = norm3(ddv) / vscale
            dl = norm3(ddl) / lscale
            dR = float(abs(R1 - s1.R).max())
            s1 = State(x1, v1, R1, l1)
            if max(dv, dl, dR) <= self.itol:
                converged = True
                break
        self.last_force, self.last_torque = F1, tau1
        self.stats.iterations_total += its
        self.stats.iterations_max = max(self.stats.iterations_max, its)
        if not converged:
            self.stats.iteration_nonconverged += 1
        pr[0], pr[1], pr[2] = 1.0, t1, dt
        pr[3:6], pr[6:9] = F0, tau0
        pidx[0] = k
        pidx[1 : 1 + k] = c.idx
        # penetration check at the end of the step
        r = kernel._points_mt(self.body.nodes, s1.R)
        d, _, _ = self.ped.motion(t1)
        gaps = self.ped.gaps(s1.x + r, d)
        gmin = float(gaps.min())
        self.last_gaps = gaps
        self.last_gmin = gmin
        self.last_ncontacts = int(np.sum(gaps <= self.eps))
        self.last_omega = self.omega(s1)
        if gmin < -self.eps * (1.0 + BAND_TOLERANCE) and not self.accept_any:
            raise StepRejected(gmin)
        return s1, its

    def penetration(self, s: State, t: float) -> float:
        r = kernel._points_mt(self.body.nodes, np.ascontiguousarray(s.R))
        d, _, _ = self.ped.motion(t)
        g = self.ped.gaps(s.x + r, d)
        return max(0.0, -float(np.min(g)))
