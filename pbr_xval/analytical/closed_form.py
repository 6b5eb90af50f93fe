"""Closed-form results for the rectangular rocking block (Housner 1963; Makris & Roussos 2000).

References are to ``/work/shared/notes/science.md`` §1. All quantities SI: α in rad, p and ω in rad/s,
accelerations in m/s², times in s.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import brentq

__all__ = [
    "free_rocking_period",
    "housner1963_halfsine",
    "housner_amplitude_sequence",
    "makris_roussos_halfsine",
    "rectangle_restitution",
    "rectangular_pulse_threshold",
]


def housner1963_halfsine(alpha: float, p: float, omega: float, g: float = 9.81) -> float:
    """Housner (1963) eq. 12 overturning amplitude of a half-sine pulse, a = g α sqrt(1 + (ω/p)²) (m/s²).

    Unconservative (the block overturns in the free phase after the pulse; Makris & Roussos 2000).

    Parameters
    ----------
    alpha : float
        Slenderness angle α (rad).
    p : float
        Frequency parameter p (rad/s).
    omega : float
        Pulse circular frequency ω (rad/s); the pulse lasts (π − ψ)/ω.
    g : float
        Gravity (m/s²).
    """
    return g * alpha * math.sqrt(1.0 + (omega / p) ** 2)


def makris_roussos_halfsine(alpha: float, p: float, omega: float, g: float = 9.81) -> float:
    """Minimum overturning amplitude of a half-sine pulse, linearised theory (Makris & Roussos 2000 eq. 27), m/s².

    Solves (ω/p) sin ψ − cos ψ = exp[−(p/ω)(π − ψ)] for ψ ∈ (0, π/2] and returns α g / sin ψ.

    Raises
    ------
    ValueError
        If the equation has no root with ψ ≤ π/2 (very low ω/p).
    """
    wp = omega / p

    def f(psi: float) -> float:
        return wp * math.sin(psi) - math.cos(psi) - math.exp(-(math.pi - psi) / wp)

    lo, hi = 1e-12, 0.5 * math.pi
    if f(lo) * f(hi) > 0:
        raise ValueError(f"no root of Makris & Roussos eq. 27 with psi <= pi/2 for omega/p = {wp}")
    psi = brentq(f, lo, hi, xtol=1e-15, rtol=4 * np.finfo(float).eps)
    return alpha * g / math.sin(psi)


def rectangular_pulse_threshold(alpha: float, p: float, t1: float, g: float = 9.81) -> float:
    """Overturning amplitude (m/s²) of a rectangular acceleration pulse of duration ``t1`` (s), linearised.

    a / (g α) = 1 / (1 − exp(−p t1))  (Housner 1963 eqs. 7–9, closed form of cosh p t1 = 1 + α²/[2(a/g)(a/g − α)]).
    """
    return g * alpha / (1.0 - math.exp(-p * t1))


def free_rocking_period(alpha: float, p: float, theta0: float) -> float:
    """Full free-rocking period (s) without energy loss, linearised: T = (4/p) acosh[1/(1 − θ0/α)].

    ``theta0`` (rad) is the release angle from rest, 0 < θ0 < α.
    """
    return 4.0 / p * math.acosh(1.0 / (1.0 - theta0 / alpha))


def housner_amplitude_sequence(phi0: float, r_energy: float, n: int) -> np.ndarray:
    """Normalised amplitudes φ_1..φ_n (-) of linearised free rocking after each impact, shape (n,).

    φ_k = 1 − sqrt(1 − r^k [1 − (1 − φ0)²]), φ = θ_max/α, ``r_energy`` = (θ̇₊/θ̇₋)² (Housner 1963).
    """
    k = np.arange(1, n + 1, dtype=float)
    return 1.0 - np.sqrt(1.0 - r_energy**k * (1.0 - (1.0 - phi0) ** 2))


def rectangle_restitution(alpha: float) -> float:
    """Housner's velocity ratio θ̇₊/θ̇₋ = 1 − 1.5 sin²α (-) for a rectangular block, α in rad."""
    return 1.0 - 1.5 * math.sin(alpha) ** 2
