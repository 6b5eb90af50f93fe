"""Curved-base (rolling) block: the seed's Echo-Cliff-like case as pbr-xval reads it (science.md §8).

Project interpretation (not the paper's confirmed geometry): a uniform 2-D lamina, extruded by ``depth`` along y,
that is a rectangle of height H and width W = h + 2r whose two bottom corners are rounded into quarter circles of
radius r. The base is a flat of length h tangent at each end to an arc of radius r. Body frame: origin at the middle
of the flat, x to the right, z up; the arc centres are at (±h/2, r).

Motion (x–z plane, z up, θ > 0 about +y = top toward +x, as in :mod:`pbr_xval.analytical.rocking`):

- at rest on the flat until |a_g| > g_eff (h/2)/y_G0 (rolls onto the right arc, θ > 0, when a_g < −that);
- rolls without slip on the arc (0 < |θ| < 90°); with ψ = |θ| and d = y_G0 − r, relative to the ground::

      x_G = s [h/2 + r ψ − (h/2) cos ψ + d sin ψ],   z_G = r + (h/2) sin ψ + d cos ψ
      I(ψ) = I_G + m [(h/2)² + d² + r² + r h sin ψ + 2 r d cos ψ]        (inertia about the contact point)
      I θ̈ + ½ I′(θ) θ̇² = −m g_eff z_G′(θ) − m a_g x_G′(θ)               (science.md §2.1)

- back through θ = 0 the contact jumps between the ends of the flat; angular momentum about the new contact is
  conserved: θ̇₊/θ̇₋ = [I_G + m (y_G0² − h²/4)] / [I_G + m (y_G0² + h²/4)] (→ 1 − 1.5 sin²α as r → 0);
- toppled when |θ| ≥ θ*, tan θ* = (h/2)/(y_G0 − r) (COM above the contact point), capped at 90° (end of the arc).

All quantities SI (m, kg, kg·m², s, rad, rad/s, m/s²).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import Literal

import numpy as np

from pbr_xval.analytical.rocking import HybridModel, RockingSolution, solve_hybrid

__all__ = [
    "CurvedBaseLamina",
    "CurvedBaseSolution",
    "curved_base_rhs",
    "energy",
    "simulate_curved_base",
]

AccelFn = Callable[[float], float]


@dataclass(frozen=True)
class CurvedBaseLamina:
    """Rectangle H × (h + 2r) with both bottom corners rounded to radius r; uniform lamina extruded by ``depth``.

    Parameters
    ----------
    H : float
        Height (m).
    r : float
        Corner radius (m), ≥ 0 (r = 0 is a plain rectangle rocking on its corners).
    h : float
        Length of the flat part of the base (m), ≥ 0 (h = 0: no flat, no uplift threshold).
    depth : float
        Extrusion length along y (m).
    density : float
        Density (kg/m³).
    """

    H: float
    r: float
    h: float
    depth: float = 1.0
    density: float = 2700.0

    def __post_init__(self) -> None:
        if self.r < 0 or self.h < 0 or self.H <= 0 or self.depth <= 0 or self.density <= 0:
            raise ValueError("need H, depth, density > 0 and r, h >= 0")
        if self.r > self.H:
            raise ValueError("corner radius r must not exceed the height H")
        if self.h + 2 * self.r <= 0:
            raise ValueError("width h + 2r must be positive")

    # -- exact area properties (rectangle minus two corner pieces = square r×r minus quarter disc) ------------
    @property
    def W(self) -> float:
        """Width h + 2r (m)."""
        return self.h + 2.0 * self.r

    @cached_property
    def _moments(self) -> tuple[float, float, float]:
        """(area m², first moment ∫z dA m³, polar moment about the frame origin ∫(x²+z²) dA m⁴)."""
        W, H, r, c = self.W, self.H, self.r, 0.5 * self.h
        pi = math.pi
        A_rect, Sz_rect = W * H, W * H * H / 2.0
        J_rect = H * W**3 / 12.0 + W * H**3 / 3.0
        # one corner piece (right; the left one is its mirror image with the same moments)
        A_sq, Sz_sq = r * r, r**3 / 2.0
        J_sq = r * ((c + r) ** 3 - c**3) / 3.0 + r**4 / 3.0
        A_qd = pi * r * r / 4.0
        Sz_qd = A_qd * (r - 4.0 * r / (3.0 * pi))
        Jx_qd = c * c * A_qd + 2.0 * c * r**3 / 3.0 + pi * r**4 / 16.0
        Jz_qd = r * r * A_qd - 2.0 * r * r**3 / 3.0 + pi * r**4 / 16.0
        A = A_rect - 2.0 * (A_sq - A_qd)
        Sz = Sz_rect - 2.0 * (Sz_sq - Sz_qd)
        J = J_rect - 2.0 * (J_sq - Jx_qd - Jz_qd)
        return A, Sz, J

    @property
    def area(self) -> float:
        """Profile area (m²)."""
        return self._moments[0]

    @property
    def y_G0(self) -> float:
        """Centroid height above the flat at rest (m)."""
        A, Sz, _ = self._moments
        return Sz / A

    @property
    def polar_moment_area(self) -> float:
        """Polar second moment of area about the centroid (m⁴)."""
        A, _, J = self._moments
        return J - A * self.y_G0**2

    @property
    def mass(self) -> float:
        """Mass density·depth·area (kg)."""
        return self.density * self.depth * self.area

    @property
    def I_G(self) -> float:
        """Moment of inertia about the y axis through the centroid (kg·m²)."""
        return self.density * self.depth * self.polar_moment_area

    @property
    def d(self) -> float:
        """Height of the centroid above the arc centres, y_G0 − r (m)."""
        return self.y_G0 - self.r

    @property
    def critical_angle(self) -> float:
        """Toppling angle θ* (rad), tan θ* = (h/2)/(y_G0 − r); at most π/2 (end of the arc)."""
        return min(math.atan2(0.5 * self.h, self.d), 0.5 * math.pi)

    def uplift_accel(self, g: float = 9.81) -> float:
        """Static uplift acceleration g (h/2)/y_G0 (m/s², magnitude); 0 when h = 0."""
        return g * 0.5 * self.h / self.y_G0

    def impact_ratio(self) -> float:
        """θ̇₊/θ̇₋ (-) when the contact jumps from one end of the flat to the other at θ = 0."""
        m, c, y = self.mass, 0.5 * self.h, self.y_G0
        return (self.I_G + m * (y * y - c * c)) / (self.I_G + m * (y * y + c * c))

    # -- kinematics --------------------------------------------------------------------------------------------
    def x_com(self, theta: np.ndarray | float) -> np.ndarray:
        """COM horizontal position relative to the ground, x_G(θ) − x_G(0) (m), same shape as ``theta``."""
        th = np.asarray(theta, dtype=float)
        s, psi = np.sign(th), np.abs(th)
        c = 0.5 * self.h
        return s * (c + self.r * psi - c * np.cos(psi) + self.d * np.sin(psi))

    def z_com(self, theta: np.ndarray | float) -> np.ndarray:
        """COM height above the ground (m), same shape as ``theta``."""
        psi = np.abs(np.asarray(theta, dtype=float))
        return self.r + 0.5 * self.h * np.sin(psi) + self.d * np.cos(psi)

    def inertia_contact(self, theta: np.ndarray | float) -> np.ndarray:
        """Moment of inertia about the contact point, I_G + m|r_G − r_C|² (kg·m²)."""
        psi = np.abs(np.asarray(theta, dtype=float))
        c, r, d = 0.5 * self.h, self.r, self.d
        return self.I_G + self.mass * (
            c * c + d * d + r * r + 2 * r * c * np.sin(psi) + 2 * r * d * np.cos(psi)
        )

    def outline(self, n: int = 32, *, closed: bool = True) -> np.ndarray:
        """Counter-clockwise profile polygon in the body frame (x, z) (m), shape (k, 2).

        ``n`` points per quarter-circle arc. With ``closed`` the first vertex is repeated at the end.
        """
        c, r, W, H = 0.5 * self.h, self.r, 0.5 * self.W, self.H
        pts: list[tuple[float, float]] = [(-c, 0.0)]
        if c > 0:
            pts.append((c, 0.0))
        if r > 0:
            a = np.linspace(-0.5 * np.pi, 0.0, n + 1)[1:]
            pts += [(c + r * np.cos(t), r + r * np.sin(t)) for t in a]
        pts += [(W, H), (-W, H)]
        if r > 0:
            a = np.linspace(np.pi, 1.5 * np.pi, n + 1)[:-1]
            pts += [(-c + r * np.cos(t), r + r * np.sin(t)) for t in a]
        poly = np.array(pts, dtype=float)
        # drop consecutive duplicates (r = 0 or h = 0)
        keep = np.ones(len(poly), dtype=bool)
        keep[1:] = np.any(np.abs(np.diff(poly, axis=0)) > 1e-15, axis=1)
        poly = poly[keep]
        if np.allclose(poly[-1], poly[0]):
            poly = poly[:-1]
        return np.vstack([poly, poly[:1]]) if closed else poly


def curved_base_rhs(
    body: CurvedBaseLamina,
    theta: float,
    omega: float,
    a_g: float,
    g_eff: float = 9.81,
    side: int | None = None,
) -> float:
    """Angular acceleration θ̈ (rad/s²) while rolling on one arc.

    Parameters
    ----------
    theta, omega : float
        State (rad, rad/s).
    a_g : float
        Horizontal ground acceleration (m/s², +x).
    g_eff : float
        Effective gravity g + a_v (m/s²).
    side : int or None
        +1 right arc, −1 left arc; default sgn θ (+1 at θ = 0).
    """
    s = side if side is not None else (1 if theta >= 0 else -1)
    psi, dpsi = s * theta, s * omega
    m, c, r, d = body.mass, 0.5 * body.h, body.r, body.d
    sp, cp = math.sin(psi), math.cos(psi)
    J = body.I_G + m * (c * c + d * d + r * r + 2 * r * c * sp + 2 * r * d * cp)
    dJ = m * (2 * r * c * cp - 2 * r * d * sp)
    dZ = c * cp - d * sp
    dX = r + c * sp + d * cp
    psi_dd = (-0.5 * dJ * dpsi * dpsi - m * g_eff * dZ - m * a_g * s * dX) / J
    return s * psi_dd


def energy(
    body: CurvedBaseLamina, theta: np.ndarray | float, omega: np.ndarray | float, g: float = 9.81
) -> np.ndarray:
    """Mechanical energy ½ I(θ) θ̇² + m g z_G(θ) (J), same shape as ``theta``."""
    om = np.asarray(omega, dtype=float)
    return 0.5 * body.inertia_contact(theta) * om * om + body.mass * g * body.z_com(theta)


@dataclass(frozen=True)
class CurvedBaseSolution(RockingSolution):
    """Result of :func:`simulate_curved_base`; the fields of :class:`RockingSolution` plus:

    Attributes
    ----------
    x_com : ndarray, shape (n,)
        COM horizontal displacement relative to the ground, x_G(t) − x_G(0) (m).
    z_com : ndarray, shape (n,)
        COM height above the ground (m).
    peak_com_disp : float
        max |x_G − x_G(0)| (m), clamped at ``clamp``; toppled runs report ``clamp``.

    Notes
    -----
    ``peak_theta_ratio`` is max |θ|/θ*; ``toppled`` means |θ| reached θ* (or the ``topple_angle`` override).
    """

    x_com: np.ndarray
    z_com: np.ndarray
    peak_com_disp: float


def simulate_curved_base(
    body: CurvedBaseLamina,
    accel: AccelFn,
    t_end: float,
    *,
    g: float = 9.81,
    accel_v: AccelFn | None = None,
    breakpoints: Sequence[float] = (),
    theta0: float = 0.0,
    omega0: float = 0.0,
    rtol: float = 1e-11,
    atol: float = 1e-13,
    max_step: float = np.inf,
    dense_dt: float = 1e-3,
    clamp: float = 5.0,
    topple_angle: float | None = None,
    omega_rest: float = 1e-8,
    zeno_dt: float = 1e-9,
    max_impacts: int = 10_000,
    decision: Literal["first_crossing", "physical"] = "first_crossing",
    free_after: float | None = None,
    impact_ratio: float | None = None,
) -> CurvedBaseSolution:
    """Simulate the curved-base block under ground acceleration (rest, rolling, flat slap, toppling).

    Parameters
    ----------
    body : CurvedBaseLamina
        Geometry and mass properties.
    accel : callable
        Horizontal ground acceleration a_g(t) (m/s², +x).
    t_end : float
        End time (s).
    g : float
        Gravity (m/s²).
    accel_v : callable or None
        Vertical ground acceleration (m/s², +z); g_eff = g + a_v(t).
    breakpoints : sequence of float
        Times (s) where the excitation is non-smooth; integration restarts there.
    theta0, omega0 : float
        Initial state (rad, rad/s); (0, 0) = at rest on the flat.
    rtol, atol, max_step : float
        solve_ivp (DOP853) settings.
    dense_dt : float
        Output grid spacing and uplift-scan step (s).
    clamp : float
        Clamp for ``peak_com_disp`` (m); the seed's fragility-map convention is 5 m.
    topple_angle : float or None
        Override of the toppling angle (rad); default ``body.critical_angle``. With h = 0 and y_G0 > r the
        default is 0 (unstable equilibrium: any rolling counts as toppling) — pass e.g. π/2 to follow the roll.
    omega_rest, zeno_dt, max_impacts
        Return-to-rest rules at θ = 0, as in :func:`pbr_xval.analytical.rocking.simulate_rocking`.
    decision : {"first_crossing", "physical"}
        ``first_crossing``: toppled when |θ| first reaches the toppling angle. ``physical``: toppled when
        the block cannot return — it reaches the end of its arc (|θ| = 90°, down) at any time, or after
        ``free_after`` it is past θ* and not rolling back (see :class:`pbr_xval.scenario.Toppling`).
    free_after : float or None
        Physical rule: end of the excitation (s); None: the last breakpoint.
    impact_ratio : float or None
        Velocity ratio η = θ̇₊/θ̇₋ at the flat slap (-); None: angular momentum about the new contact point.

    Returns
    -------
    CurvedBaseSolution
    """
    a_v = accel_v if accel_v is not None else (lambda _t: 0.0)
    th_top = body.critical_angle if topple_angle is None else float(topple_angle)
    norm = th_top if th_top > 0 else 0.5 * math.pi
    thr = 0.5 * body.h / body.y_G0
    if impact_ratio is not None and not (0.0 <= impact_ratio <= 1.0):
        raise ValueError(f"impact_ratio (velocity ratio η) must be in [0, 1], got {impact_ratio}")
    ratio = body.impact_ratio() if impact_ratio is None else float(impact_ratio)
    physical = decision == "physical"

    m, c, r, d, IG = body.mass, 0.5 * body.h, body.r, body.d, body.I_G
    q = IG + m * (c * c + d * d + r * r)

    def rhs(t: float, th: float, om: float, s: int) -> float:
        psi = s * th
        sp, cp = math.sin(psi), math.cos(psi)
        J = q + m * (2 * r * c * sp + 2 * r * d * cp)
        dJ = m * (2 * r * c * cp - 2 * r * d * sp)
        psi_dd = (
            -0.5 * dJ * om * om
            - m * (g + a_v(t)) * (c * cp - d * sp)
            - m * accel(t) * s * (r + c * sp + d * cp)
        ) / J
        return s * psi_dd

    def margin(t: float, s: int) -> float:
        return -s * accel(t) - (g + a_v(t)) * thr

    model = HybridModel(
        rhs=rhs,
        uplift_margin=margin,
        ratio=lambda _s: ratio,
        topple_angle=(lambda _s: 0.5 * math.pi) if physical else (lambda _s: th_top),
        norm_angle=lambda _s: norm,
        critical_angle=lambda _s: th_top,
    )
    res = solve_hybrid(
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
    x = body.x_com(res["theta"])
    z = body.z_com(res["theta"])
    peak = clamp if res["toppled"] else min(float(np.max(np.abs(x))) if x.size else 0.0, clamp)
    return CurvedBaseSolution(**res, x_com=x, z_com=z, peak_com_disp=peak)
