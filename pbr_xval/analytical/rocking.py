"""Two-pivot rocking block: Housner's equation generalised to any planar body on two corners.

The block rocks in the x–z plane (z up) on a rigid ground that translates horizontally with acceleration
``a_g(t)`` (m/s², +x) and optionally vertically with ``a_v(t)`` (m/s², +z), which enters as g → g + a_v(t).
No sliding, no bouncing; impacts are perfectly plastic and conserve angular momentum about the new pivot.

Sign convention (``/work/shared/notes/science.md`` §1.2): θ > 0 is a rotation about +y (the top moves toward +x)
about the RIGHT (+x) pivot, θ < 0 about the LEFT pivot. A positive ``a_g`` drives θ negative first.

Equation of motion on side s = sgn θ (exact variant; Makris & Roussos 2000 eqs. 1–3 generalised)::

    I_O,s θ̈ = −m R_s [ g_eff sin(α_s s − θ) + a_g cos(α_s s − θ) ]

and the Zhang & Makris (2001, eq. 50) linearisation (variant ``"linearized"``)::

    θ̈ = −p_s² [ (g_eff/g) (α_s s − θ) + a_g/g ],        p_s² = m g R_s / I_O,s

Impact at θ = 0 (angular momentum about the new pivot P, old pivot C)::

    θ̇₊/θ̇₋ = [I_G + m (r_G − r_P)·(r_G − r_C)] / [I_G + m |r_G − r_P|²]

which is 1 − 1.5 sin²α for a rectangle (Housner 1963 eq. 4).

All quantities are SI: m, kg, kg·m², s, rad, rad/s, m/s².
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, fields
from typing import Any, Literal

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

__all__ = [
    "HybridModel",
    "RockingSolution",
    "TwoPivotBody",
    "rocking_rhs",
    "simulate_rocking",
    "theta_ratio",
    "two_pivot_rebound",
]

Side = Literal["left", "right"]
AccelFn = Callable[[float], float]


def _side_sign(side: Side | int) -> int:
    """Map ``"right"``/``+1`` → +1 and ``"left"``/``-1`` → −1."""
    if side in ("right", 1):
        return 1
    if side in ("left", -1):
        return -1
    raise ValueError(f"side must be 'left', 'right', +1 or -1, got {side!r}")


def _side_name(s: int) -> Side:
    return "right" if s > 0 else "left"


def two_pivot_rebound(inertia: float, mass: float, r_old: Any, r_new: Any) -> float:
    """ω⁺/ω⁻ at a perfectly inelastic impact that moves the pivot from P1 to P2 (no slip, no bounce).

    Angular momentum about the new pivot is conserved (Housner 1963, for any two pivots).

    Parameters
    ----------
    inertia : I_G about the rocking axis through the COM, kg·m².
    mass : kg.
    r_old, r_new : (2,) or (3,) m, the vectors G − P1 and G − P2 (from each pivot to the COM)
        in the rocking plane (components along the rocking axis must be removed by the caller);
        the pivots' positions relative to the COM (both signs flipped) give the same value.

    Returns
    -------
    float: (I_G + m r₁·r₂) / (I_G + m |r₂|²). Negative when the new pivot would make the rock
    rotate backwards (it then does not transfer to P2).
    """
    r1, r2 = np.asarray(r_old, dtype=float), np.asarray(r_new, dtype=float)
    return float((inertia + mass * r2 @ r1) / (inertia + mass * r2 @ r2))  # (m r₂)·r₁, (m r₂)·r₂


# ---------------------------------------------------------------------------------------------------------------
# Body
# ---------------------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class TwoPivotBody:
    """Planar rigid body that rocks on two pivots (corners).

    Parameters
    ----------
    mass : float
        Mass m (kg).
    inertia_com : float
        Moment of inertia I_G about the axis perpendicular to the rocking plane through the centre of mass (kg·m²).
    left, right : tuple of float
        Pivot positions (x, z) relative to the centre of mass (m), shape (2,) each. ``left`` has x < 0,
        ``right`` has x > 0, both have z < 0.
    """

    mass: float
    inertia_com: float
    left: tuple[float, float]
    right: tuple[float, float]

    def __post_init__(self) -> None:
        if not (self.mass > 0 and self.inertia_com > 0):
            raise ValueError("mass and inertia_com must be positive")
        if not (self.left[0] < 0 < self.right[0]):
            raise ValueError("need left pivot x < 0 < right pivot x (relative to the COM)")
        if not (self.left[1] < 0 and self.right[1] < 0):
            raise ValueError("pivots must lie below the centre of mass (z < 0)")

    # -- constructors ----------------------------------------------------------------------------------------
    @classmethod
    def rectangle(cls, b: float, h: float, mass: float = 1.0) -> TwoPivotBody:
        """Uniform rectangle (lamina or prism) of half-width ``b`` (m) and half-height ``h`` (m).

        I_G = m((2b)² + (2h)²)/12 = m(b² + h²)/3 (kg·m²); pivots at (±b, −h).
        """
        return cls(mass=mass, inertia_com=mass * (b * b + h * h) / 3.0, left=(-b, -h), right=(b, -h))

    # -- per-side geometry ------------------------------------------------------------------------------------
    def pivot(self, side: Side | int) -> np.ndarray:
        """Pivot position relative to the COM, (x, z) in m, shape (2,)."""
        return np.asarray(self.right if _side_sign(side) > 0 else self.left, dtype=float)

    def R(self, side: Side | int) -> float:
        """Distance COM–pivot R_s (m)."""
        return float(np.hypot(*self.pivot(side)))

    def alpha(self, side: Side | int) -> float:
        """Angle α_s between the vertical and the COM–pivot line (rad), > 0 on both sides."""
        x, z = self.pivot(side)
        return float(math.atan2(abs(x), -z))

    def I_O(self, side: Side | int) -> float:
        """Moment of inertia about the pivot, I_G + m R_s² (kg·m²)."""
        return self.inertia_com + self.mass * self.R(side) ** 2

    def p(self, side: Side | int, g: float = 9.81) -> float:
        """Frequency parameter p_s = sqrt(m g R_s / I_O,s) (rad/s)."""
        return math.sqrt(self.mass * g * self.R(side) / self.I_O(side))

    def uplift_accel(self, side: Side | int, g: float = 9.81) -> float:
        """Exact static uplift acceleration g·tan α_s (m/s², magnitude) for rocking onto ``side``."""
        return g * math.tan(self.alpha(side))

    def impact_ratio(self, landing_side: Side | int) -> float:
        """Angular-velocity ratio θ̇₊/θ̇₋ (-) when the body lands on ``landing_side`` at θ = 0.

        The old pivot is the other side. Angular momentum about the new pivot P is conserved:
        [I_G + m (r_G − r_P)·(r_G − r_C)] / [I_G + m |r_G − r_P|²] with r_G − r_P = −P, r_G − r_C = −C.
        """
        s = _side_sign(landing_side)
        return two_pivot_rebound(self.inertia_com, self.mass, self.pivot(-s), self.pivot(s))


def theta_ratio(body: TwoPivotBody, theta: np.ndarray | float) -> np.ndarray:
    """|θ| / α_side, using α of the side given by sgn θ (-), same shape as ``theta``."""
    th = np.asarray(theta, dtype=float)
    return np.where(th >= 0.0, th / body.alpha("right"), -th / body.alpha("left"))


def rocking_rhs(
    body: TwoPivotBody,
    theta: float,
    side: Side | int,
    a_g: float,
    g_eff: float,
    *,
    g: float = 9.81,
    variant: Literal["exact", "linearized"] = "exact",
) -> float:
    """Angular acceleration θ̈ (rad/s²) while rocking on ``side``.

    Parameters
    ----------
    theta : float
        Rotation θ (rad).
    side : {"left", "right"} or ±1
        Active pivot (σ = +1 right, −1 left); normally sgn θ.
    a_g : float
        Horizontal ground acceleration (m/s², +x).
    g_eff : float
        Effective gravity g + a_v (m/s²).
    g : float
        Nominal gravity used in p² for the linearised variant (m/s²).
    """
    s = _side_sign(side)
    al = body.alpha(s)
    if variant == "exact":
        ang = al * s - theta
        return -body.mass * body.R(s) / body.I_O(s) * (g_eff * math.sin(ang) + a_g * math.cos(ang))
    if variant == "linearized":
        p2 = body.p(s, g) ** 2
        return -p2 * ((g_eff / g) * (al * s - theta) + a_g / g)
    raise ValueError(f"unknown variant {variant!r}")


# ---------------------------------------------------------------------------------------------------------------
# Generic hybrid (rest / one-sided motion / impact at θ = 0 / topple) integrator, shared with curved_base.py
# ---------------------------------------------------------------------------------------------------------------


@dataclass
class HybridModel:
    """A one-degree-of-freedom body that rests at θ = 0 and moves on one of two sides.

    Attributes
    ----------
    rhs : callable
        ``rhs(t, theta, omega, side) -> theta_ddot`` (s, rad, rad/s, ±1 → rad/s²).
    uplift_margin : callable
        ``uplift_margin(t, side) -> float``; strictly positive when, at rest, motion onto ``side`` starts (m/s²).
    ratio : callable
        ``ratio(landing_side) -> float`` velocity ratio θ̇₊/θ̇₋ at θ = 0 (-).
    topple_angle : callable
        ``topple_angle(side) -> float`` |θ| (rad) at which the body is declared toppled (terminal) by
        the first-crossing rule, or down (whatever the ground does) by the physical rule.
    norm_angle : callable
        ``norm_angle(side) -> float`` angle (rad) used to normalise ``peak_theta_ratio``.
    critical_angle : callable or None
        ``critical_angle(side) -> float`` |θ| (rad) beyond which gravity has no restoring moment left
        (physical rule only; default ``norm_angle``).
    """

    rhs: Callable[[float, float, float, int], float]
    uplift_margin: Callable[[float, int], float]
    ratio: Callable[[int], float]
    topple_angle: Callable[[int], float]
    norm_angle: Callable[[int], float]
    critical_angle: Callable[[int], float] | None = None


@dataclass
class _HybridResult:
    t: np.ndarray
    theta: np.ndarray
    omega: np.ndarray
    events: list[dict[str, Any]]
    peaks: np.ndarray
    toppled: bool
    toppled_at: float | None
    peak_theta_ratio: float
    n_impacts: int
    rhs_evals: int
    segments: list[tuple[float, float, int, Any]] = field(default_factory=list)
    undecided: bool = False


def _find_uplift(model: HybridModel, t0: float, t1: float, scan_dt: float) -> tuple[float, int] | None:
    """First time in [t0, t1] at which motion onto a side starts, with that side (+1 right, −1 left).

    The start needs a strictly positive uplift margin AND a strictly positive s·θ̈ at θ = θ̇ = 0, so that the
    static condition and the equation of motion agree even where rounding makes them differ by one ulp.
    """

    def ok(t: float, s: int) -> bool:
        return model.uplift_margin(t, s) > 0.0 and s * model.rhs(t, 0.0, 0.0, s) > 0.0

    def settle(x: float, hi: float, s: int) -> float | None:
        # nudge forward (doubling steps) until both conditions hold; None if they never do before ``hi``
        step = max(abs(x), 1.0) * 1e-15
        while not ok(x, s):
            if x >= hi:
                return None
            x = min(x + step, hi)
            step *= 2.0
        return x

    starts = [
        (x, s)
        for s in (1, -1)
        if model.uplift_margin(t0, s) > 0.0
        for x in [settle(t0, t1, s)]
        if x is not None
    ]
    if starts and min(starts)[0] == t0:
        return min(starts)
    n = max(1, math.ceil((t1 - t0) / scan_dt))
    ts = np.linspace(t0, t1, n + 1)
    prev = t0
    for tk in ts[1:]:
        tk = float(tk)
        roots = []
        for s in (1, -1):
            if model.uplift_margin(tk, s) <= 0.0:
                continue

            def f(t: float, s: int = s) -> float:
                return model.uplift_margin(t, s)

            x = prev if f(prev) > 0 else brentq(f, prev, tk, xtol=1e-15, rtol=4 * np.finfo(float).eps)
            x = settle(x, tk, s)
            if x is not None:
                roots.append((x, s))
        if roots:
            return min(roots)
        prev = tk
    return None


def _integrate_hybrid(
    model: HybridModel,
    t_end: float,
    *,
    breakpoints: Sequence[float] = (),
    theta0: float = 0.0,
    omega0: float = 0.0,
    rtol: float = 1e-10,
    atol: float = 1e-12,
    max_step: float = np.inf,
    dense_dt: float = 1e-3,
    omega_rest: float = 1e-8,
    zeno_dt: float = 1e-9,
    max_impacts: int = 10_000,
    keep_segments: bool = False,
    physical: bool = False,
    free_after: float = 0.0,
) -> _HybridResult:
    """Integrate the hybrid rest / rock / impact / topple dynamics of ``model`` from t = 0 to ``t_end``.

    Motion on a side is split in stages so that every event function starts strictly away from zero:
    ``rise`` (s·θ̇ > 0, ends at a peak s·θ̇ = 0↓) and ``fall`` (s·θ̇ < 0, ends at an impact s·θ = 0↓ or at a
    re-rise s·θ̇ = 0↑). Integration restarts at each breakpoint.

    Toppling: by default the first crossing of ``model.topple_angle``. With ``physical=True`` (the
    physical decision of :class:`pbr_xval.scenario.Toppling`) ``topple_angle`` is the *down* angle
    (toppled whatever the ground does), and after ``free_after`` (s, the end of the excitation) the
    body has toppled once it is past ``critical_angle`` and not moving back (no restoring moment and
    nothing to reverse the motion). The toppled event's ``t`` is the last outward crossing of the
    critical angle; ``decided_at`` and ``rule`` say when and why.

    Long on purpose: one event-driven state machine (rest → rise → fall → impact/re-rise →
    topple, restarted at each breakpoint) whose state — side, stage, t, θ, θ̇, the output pieces,
    the counters — every branch reads and writes; split into functions it would pass that state
    in and out of each one, and the loop is where the analytical reference's bit-exact results
    come from.
    """
    if t_end <= 0:
        raise ValueError("t_end must be positive")
    crit_angle = model.critical_angle or model.norm_angle
    extra = (float(free_after),) if physical and 0.0 < free_after < t_end else ()
    bps = sorted({float(b) for b in (*breakpoints, *extra) if 0.0 < b < t_end})
    bounds = [*bps, float(t_end)]
    scan_dt = min(dense_dt, max_step)
    grid = np.arange(0.0, t_end, dense_dt)
    grid = np.append(grid, t_end)

    pieces_t: list[np.ndarray] = []
    pieces_th: list[np.ndarray] = []
    pieces_om: list[np.ndarray] = []
    events: list[dict[str, Any]] = []
    peaks: list[tuple[float, float]] = []
    segments: list[tuple[float, float, int, Any]] = []
    rhs_evals = 0
    n_impacts = 0
    last_impact_t = -np.inf
    toppled = False
    toppled_at: float | None = None
    t_cross: float | None = None  # last outward crossing of the critical angle (physical rule)

    def add_grid(ta: float, tb: float, fn: Callable[[np.ndarray], np.ndarray] | None) -> None:
        tt = grid[(grid >= ta) & (grid <= tb)]
        tt = np.unique(np.concatenate(([ta], tt, [tb])))
        if fn is None:
            y = np.zeros((2, tt.size))
        else:
            y = fn(tt)
        pieces_t.append(tt)
        pieces_th.append(y[0])
        pieces_om.append(y[1])

    t = 0.0
    th, om = float(theta0), float(omega0)
    if th == 0.0 and om == 0.0:
        mode, side, stage = "rest", 1, "rise"
    else:
        mode = "rock"
        side = int(np.sign(th)) if th != 0.0 else int(np.sign(om))
        stage = "rise" if side * om > 0.0 else "fall"

    stalled, t_last = 0, -1.0
    while t < t_end and not toppled:
        stalled = stalled + 1 if t <= t_last else 0
        t_last = t
        if stalled > 1000:
            raise RuntimeError(f"hybrid integrator stalled at t={t} (event loop without time progress)")
        b = next(x for x in bounds if x > t) if any(x > t for x in bounds) else t_end
        if mode == "rest":
            up = _find_uplift(model, t, b, scan_dt)
            t_stop = b if up is None else up[0]
            add_grid(t, t_stop, None)
            if up is None:
                t = b
                continue
            t, side = up
            events.append({"kind": "uplift", "t": t, "side": _side_name(side)})
            mode, stage, th, om = "rock", "rise", 0.0, 0.0
            continue

        s = side
        free = physical and t >= free_after
        top = crit_angle(s) if free else model.topple_angle(s)
        rule = (
            "past the critical tilt and tilting outward after the excitation ended"
            if free
            else ("down: tilt reached the down angle" if physical else "first crossing")
        )
        if s * th >= top and (not free or s * om >= 0.0):  # past the toppling angle at a segment start
            toppled, toppled_at = True, (t_cross if t_cross is not None else t)
            events.append(
                {"kind": "toppled", "t": toppled_at, "decided_at": t, "rule": rule}
                | {"side": _side_name(s), "theta": th, "omega": om}
            )
            pieces_t.append(np.array([t]))
            pieces_th.append(np.array([th]))
            pieces_om.append(np.array([om]))
            break
        crit_s = crit_angle(s)

        def f(tt: float, y: np.ndarray, s: int = s) -> list[float]:
            return [y[1], model.rhs(tt, y[0], y[1], s)]

        def ev_topple(tt: float, y: np.ndarray, s: int = s, top: float = top) -> float:
            return s * y[0] - top

        ev_topple.terminal = True  # type: ignore[attr-defined]
        ev_topple.direction = 1  # type: ignore[attr-defined]

        def ev_omega(tt: float, y: np.ndarray, s: int = s) -> float:
            return s * y[1]

        ev_omega.terminal = True  # type: ignore[attr-defined]
        ev_omega.direction = -1 if stage == "rise" else 1  # type: ignore[attr-defined]
        evs: list[Any] = [ev_topple, ev_omega]
        if physical and not free:

            def ev_alpha(tt: float, y: np.ndarray, s: int = s, a: float = crit_s) -> float:
                return s * y[0] - a

            ev_alpha.terminal = False  # type: ignore[attr-defined]
            ev_alpha.direction = 1  # type: ignore[attr-defined]
            evs.append(ev_alpha)
        if stage == "fall":

            def ev_impact(tt: float, y: np.ndarray, s: int = s) -> float:
                return s * y[0]

            ev_impact.terminal = True  # type: ignore[attr-defined]
            ev_impact.direction = -1  # type: ignore[attr-defined]
            evs.append(ev_impact)

        if b - t <= 1e-14 * max(1.0, abs(t)):
            t = b
            continue
        sol = solve_ivp(
            f,
            (t, b),
            [th, om],
            method="DOP853",
            rtol=rtol,
            atol=atol,
            max_step=max_step,
            events=evs,
            dense_output=True,
        )
        if sol.status == -1:
            raise RuntimeError(f"solve_ivp failed at t={t}: {sol.message}")
        rhs_evals += int(sol.nfev)
        if physical and not free and sol.t_events[2].size:
            t_cross = float(sol.t_events[2][-1])
        t_new = float(sol.t[-1])
        th_new, om_new = float(sol.y[0, -1]), float(sol.y[1, -1])
        add_grid(t, t_new, sol.sol)
        if keep_segments:
            segments.append((t, t_new, s, sol.sol))
        t, th, om = t_new, th_new, om_new
        if sol.status != 1:  # reached the boundary
            continue
        # which terminal event fired (topple has priority)
        terminal = [
            te if getattr(fn, "terminal", False) else np.zeros(0)
            for te, fn in zip(sol.t_events, evs, strict=True)
        ]
        fired = [k for k, te in enumerate(terminal) if te.size and te[-1] == t_new]
        if not fired:
            fired = [int(np.argmax([te[-1] if te.size else -np.inf for te in terminal]))]
        k = 0 if 0 in fired else fired[0]
        if k == 0:
            if free:
                t_cross = t
            toppled, toppled_at = True, (t_cross if (physical and t_cross is not None) else t)
            events.append(
                {"kind": "toppled", "t": toppled_at, "decided_at": t, "rule": rule}
                | {"side": _side_name(s), "theta": th, "omega": om}
            )
            break
        if k == 1:
            if stage == "rise":
                peaks.append((t, th))
                stage = "fall"
            else:
                stage = "rise"
            continue
        # impact at θ = 0
        th = 0.0
        new = -s
        ratio = model.ratio(new)
        om_plus = ratio * om
        n_impacts += 1
        events.append(
            {
                "kind": "impact",
                "t": t,
                "omega_minus": om,
                "omega_plus": om_plus,
                "ratio": ratio,
                "from_side": _side_name(s),
                "to_side": _side_name(new),
            }
        )
        reason = None
        if abs(om_plus) < omega_rest:
            reason = "small velocity"
        elif t - last_impact_t < zeno_dt:
            reason = "impact accumulation (Zeno)"
        elif n_impacts >= max_impacts:
            reason = "max_impacts reached"
        last_impact_t = t
        if reason is not None or new * om_plus <= 0.0:
            events.append({"kind": "rest", "t": t, "reason": reason or "no rebound"})
            mode, th, om = "rest", 0.0, 0.0
            pieces_t.append(np.array([t]))
            pieces_th.append(np.array([0.0]))
            pieces_om.append(np.array([0.0]))
            continue
        side, stage, om = new, "rise", om_plus
        pieces_t.append(np.array([t]))
        pieces_th.append(np.array([0.0]))
        pieces_om.append(np.array([om_plus]))

    undecided = False
    if physical and not toppled and mode == "rock" and side * th >= crit_angle(side):
        if side * om >= 0.0:
            toppled, toppled_at = True, (t_cross if t_cross is not None else t)
            events.append(
                {"kind": "toppled", "t": toppled_at, "decided_at": t}
                | {"rule": "past the critical tilt and not tilting back at the end of the run"}
                | {"side": _side_name(side), "theta": th, "omega": om}
            )
        else:
            undecided = True
    tt = np.concatenate(pieces_t)
    yth = np.concatenate(pieces_th)
    yom = np.concatenate(pieces_om)
    order = np.argsort(tt, kind="stable")
    tt, yth, yom = tt[order], yth[order], yom[order]
    # keep the last sample of each group of equal times (the post-event state)
    keep = np.ones(tt.size, dtype=bool)
    keep[:-1] = np.diff(tt) > 1e-13 * max(1.0, t_end)
    tt, yth, yom = tt[keep], yth[keep], yom[keep]

    def ratio_of(th_arr: np.ndarray) -> np.ndarray:
        return np.where(th_arr >= 0, th_arr / model.norm_angle(1), -th_arr / model.norm_angle(-1))

    cand = [float(np.max(ratio_of(yth))) if yth.size else 0.0]
    if peaks:
        cand.append(float(np.max(ratio_of(np.array([p[1] for p in peaks])))))
    return _HybridResult(
        t=tt,
        theta=yth,
        omega=yom,
        events=events,
        peaks=np.array(peaks, dtype=float).reshape(-1, 2),
        toppled=toppled,
        toppled_at=toppled_at,
        peak_theta_ratio=max(cand),
        n_impacts=n_impacts,
        rhs_evals=rhs_evals,
        segments=segments,
        undecided=undecided,
    )


def solve_hybrid(model: HybridModel, t_end: float, free_after: float | None, **kw: Any) -> dict[str, Any]:
    """:func:`_integrate_hybrid` as both solvers call it; the fields of a :class:`RockingSolution`.

    ``free_after`` None means the last breakpoint (the end of the excitation); ``kw`` are the
    other keywords of :func:`_integrate_hybrid`.
    """
    if free_after is None:
        free_after = max(kw.get("breakpoints", ()), default=0.0)
    r = _integrate_hybrid(model, t_end, free_after=float(free_after), **kw)
    return {f.name: getattr(r, f.name) for f in fields(RockingSolution)}


# ---------------------------------------------------------------------------------------------------------------
# Public solver
# ---------------------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class RockingSolution:
    """Result of :func:`simulate_rocking`.

    Attributes
    ----------
    t : ndarray, shape (n,)
        Output times (s), strictly increasing: the uniform grid of spacing ``dense_dt`` plus every segment
        boundary and event time. At an event time the stored state is the post-event state. Ends at
        ``toppled_at`` if the block toppled.
    theta : ndarray, shape (n,)
        Rotation θ (rad).
    omega : ndarray, shape (n,)
        Angular velocity θ̇ (rad/s).
    events : list of dict
        Chronological events, each with ``"kind"`` in {"uplift", "impact", "rest", "toppled"} and ``"t"`` (s).
        uplift: ``side``; impact: ``omega_minus``, ``omega_plus`` (rad/s), ``ratio``, ``from_side``,
        ``to_side``; rest: ``reason``; toppled: ``side``, ``theta``, ``omega``.
    toppled : bool
        Whether |θ| reached ``topple_factor``·α_side.
    toppled_at : float or None
        Toppling time (s).
    peak_theta_ratio : float
        max |θ|/α_side over the run (-), using the exact peaks (θ̇ = 0 events) and the output grid.
    n_impacts : int
        Number of impacts at θ = 0.
    rhs_evals : int
        Right-hand-side evaluations of all solve_ivp calls.
    peaks : ndarray, shape (k, 2)
        Exact local extrema of |θ| (θ̇ = 0 events): columns (t in s, θ in rad).
    """

    t: np.ndarray
    theta: np.ndarray
    omega: np.ndarray
    events: list[dict[str, Any]]
    toppled: bool
    toppled_at: float | None
    peak_theta_ratio: float
    n_impacts: int
    rhs_evals: int
    peaks: np.ndarray
    #: physical rule: the run ended with the block past α but rocking back (no verdict possible)
    undecided: bool


def simulate_rocking(
    body: TwoPivotBody,
    accel: AccelFn,
    t_end: float,
    *,
    g: float = 9.81,
    accel_v: AccelFn | None = None,
    breakpoints: Sequence[float] = (),
    variant: Literal["exact", "linearized"] = "exact",
    theta0: float = 0.0,
    omega0: float = 0.0,
    rtol: float = 1e-10,
    atol: float = 1e-12,
    max_step: float = np.inf,
    dense_dt: float = 1e-3,
    topple_factor: float = 1.0,
    omega_rest: float = 1e-8,
    zeno_dt: float = 1e-9,
    max_impacts: int = 10_000,
    decision: Literal["first_crossing", "physical"] = "first_crossing",
    down_angle: float = 0.5 * math.pi,
    free_after: float | None = None,
    impact_ratio: float | None = None,
) -> RockingSolution:
    """Simulate a two-pivot rocking block under horizontal (and optional vertical) ground acceleration.

    Parameters
    ----------
    body : TwoPivotBody
        Mass properties and pivots.
    accel : callable
        Horizontal ground acceleration a_g(t) (m/s², +x), t in s.
    t_end : float
        End time (s); the run starts at t = 0.
    g : float
        Gravity (m/s²).
    accel_v : callable or None
        Vertical ground acceleration a_v(t) (m/s², +z); g_eff = g + a_v(t).
    breakpoints : sequence of float
        Times (s) where a_g or a_v is non-smooth; no integration step straddles them.
    variant : {"exact", "linearized"}
        Nonlinear equation or the Zhang & Makris linearisation (uplift at g_eff·α instead of g_eff·tan α).
    theta0, omega0 : float
        Initial state (rad, rad/s). (0, 0) means at rest on both pivots.
    rtol, atol, max_step : float
        solve_ivp (DOP853) tolerances and maximum step (s).
    dense_dt : float
        Output grid spacing (s); also the scan step for the uplift condition while at rest.
    topple_factor : float
        First-crossing rule: toppled when |θ| ≥ topple_factor·α_side (-).
    omega_rest : float
        Post-impact |θ̇| (rad/s) below which the block is put back to rest.
    zeno_dt : float
        Two impacts closer than this (s) put the block back to rest (impact accumulation).
    max_impacts : int
        Impact count after which the block is put to rest.
    decision : {"first_crossing", "physical"}
        ``first_crossing``: toppled at the first crossing of topple_factor·α_side. ``physical``: toppled
        when the block cannot return — |θ| reaches ``down_angle`` at any time, or, after ``free_after``,
        |θ| ≥ α_side while not rocking back (see :class:`pbr_xval.scenario.Toppling`).
    down_angle : float
        Physical rule: |θ| (rad) at which the block is down (90°: it lies on its side).
    free_after : float or None
        Physical rule: time (s) after which the ground no longer accelerates (end of the excitation);
        None: the last breakpoint, or 0 without breakpoints.
    impact_ratio : float or None
        Impact velocity ratio η = θ̇₊/θ̇₋ at every impact (-), the "coefficient of restitution" in the
        velocity sense (Yim et al. 1980; Zhang & Makris 2001 eq. 42). None: the angular-momentum value
        of each landing side (Housner 1963: 1 − 1.5 sin²α for a rectangle). Housner and Makris call the
        *energy* ratio r = η² the coefficient of restitution: do not pass r here.

    Returns
    -------
    RockingSolution
    """
    if variant not in ("exact", "linearized"):
        raise ValueError(f"unknown variant {variant!r}")
    a_v = accel_v if accel_v is not None else (lambda _t: 0.0)
    exact = variant == "exact"
    # cache per-side constants
    al = {1: body.alpha(1), -1: body.alpha(-1)}
    mR_I = {s: body.mass * body.R(s) / body.I_O(s) for s in (1, -1)}
    p2 = {s: body.p(s, g) ** 2 for s in (1, -1)}
    thr = {s: (math.tan(al[s]) if exact else al[s]) for s in (1, -1)}
    if impact_ratio is not None and not (0.0 <= impact_ratio <= 1.0):
        raise ValueError(f"impact_ratio (velocity ratio η) must be in [0, 1], got {impact_ratio}")
    ratios = {s: (body.impact_ratio(s) if impact_ratio is None else float(impact_ratio)) for s in (1, -1)}
    physical = decision == "physical"

    if exact:

        def rhs(t: float, th: float, om: float, s: int) -> float:
            ang = al[s] * s - th
            return -mR_I[s] * ((g + a_v(t)) * math.sin(ang) + accel(t) * math.cos(ang))

    else:

        def rhs(t: float, th: float, om: float, s: int) -> float:
            return -p2[s] * ((g + a_v(t)) / g * (al[s] * s - th) + accel(t) / g)

    def margin(t: float, s: int) -> float:
        # right (s=+1) uplifts when a_g < −g_eff thr; left when a_g > g_eff thr
        return -s * accel(t) - (g + a_v(t)) * thr[s]

    model = HybridModel(
        rhs=rhs,
        uplift_margin=margin,
        ratio=lambda s: ratios[s],
        topple_angle=(lambda s: down_angle) if physical else (lambda s: topple_factor * al[s]),
        norm_angle=lambda s: al[s],
        critical_angle=lambda s: al[s],
    )
    return RockingSolution(
        **solve_hybrid(
            model,
            t_end,
            free_after,
            breakpoints=breakpoints,
            theta0=theta0,
            omega0=omega0,
            rtol=rtol,
            atol=atol,
            max_step=max_step,
            dense_dt=dense_dt,
            omega_rest=omega_rest,
            zeno_dt=zeno_dt,
            max_impacts=max_impacts,
            physical=physical,
        )
    )
