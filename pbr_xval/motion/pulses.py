"""Analytic acceleration pulses (SI units).

Every pulse starts at ``t = 0`` with zero ground velocity and displacement;
a, v and d are exact closed forms.  Times are in s, amplitudes in m/s²,
velocities in m/s, displacements in m.  Inside the pulse the local time is
τ = t (all pulses start at 0); the support is the half-open ``[0, duration)``.
"""

from __future__ import annotations

import math
from abc import abstractmethod
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .base import GroundMotion

__all__ = ["PULSES", "HalfSine", "OneCosine", "OneSine", "Rectangular", "Ricker", "Sawtooth"]

Arr = NDArray[np.float64]


def _positive(name: str, value: float, unit: str) -> float:
    value = float(value)
    if not (math.isfinite(value) and value > 0):
        raise ValueError(f"{name} must be a positive finite number in {unit}, got {value!r}")
    return value


class _Pulse(GroundMotion):
    """Pulse supported on ``[0, T)``; subclasses give a, v, d for τ in [0, T]."""

    _T: float

    @abstractmethod
    def _a_in(self, tau: Arr) -> Arr: ...

    @abstractmethod
    def _v_in(self, tau: Arr) -> Arr: ...

    @abstractmethod
    def _d_in(self, tau: Arr) -> Arr: ...

    @property
    def duration(self) -> float:
        """float, s: end of the pulse; a = 0 afterwards."""
        return self._T

    @property
    def residual_velocity(self) -> float:
        """float, m/s: ground velocity left after the pulse."""
        return float(self._v_in(np.asarray(self._T)))

    def _acceleration(self, t: Arr) -> Arr:
        tau = np.clip(t, 0.0, self._T)
        return np.where((t >= 0) & (t < self._T), self._a_in(tau), 0.0)

    def _velocity(self, t: Arr) -> Arr:
        return np.where(t >= 0, self._v_in(np.clip(t, 0.0, self._T)), 0.0)

    def _displacement(self, t: Arr) -> Arr:
        tau = np.clip(t, 0.0, self._T)
        drift = self.residual_velocity * np.maximum(t - self._T, 0.0)
        return np.where(t >= 0, self._d_in(tau) + drift, 0.0)

    def _params(self) -> dict[str, Any]:
        return {}

    def describe(self) -> dict[str, Any]:
        return {"type": type(self).__name__, "name": self.name, **self._params(), "duration": self.duration}


class HalfSine(_Pulse):
    """Housner's half-sine pulse a(t) = A sin(ω t + φ), 0 ≤ t ≤ (π − φ)/ω, ω = 2π f.

    v(t) = A/ω (cos φ − cos(ωt + φ)),  d(t) = A/ω (t cos φ − (sin(ωt + φ) − sin φ)/ω).

    Parameters
    ----------
    amplitude : float, m/s²
        A > 0.
    frequency : float, Hz
        f > 0.
    phase : float, rad
        φ in [0, π); the pulse starts at a(0) = A sin φ and ends where ωt + φ = π.
    name : str, optional
    """

    def __init__(
        self, amplitude: float, frequency: float = 1.0, phase: float = 0.0, *, name: str = "half_sine"
    ) -> None:
        self.amplitude = _positive("amplitude", amplitude, "m/s²")
        self.frequency = _positive("frequency", frequency, "Hz")
        phase = float(phase)
        if not (0.0 <= phase < math.pi):
            raise ValueError(f"phase must be in [0, π) rad, got {phase!r}")
        self.phase = phase
        self.omega = 2.0 * math.pi * self.frequency
        self._T = (math.pi - phase) / self.omega
        self.name = name

    @classmethod
    def housner(
        cls, amplitude: float, uplift_accel: float, frequency: float = 1.0, *, name: str = "half_sine"
    ) -> HalfSine:
        """Pulse whose start a(0) = A sin φ equals the uplift acceleration g tan α.

        Parameters
        ----------
        amplitude : float, m/s²
            Pulse amplitude A.
        uplift_accel : float, m/s²
            Acceleration that initiates rocking (g tan α for a rectangular block).
        frequency : float, Hz

        Notes
        -----
        φ = asin(uplift_accel / A).  If A < uplift_accel no phase can reach the
        uplift value; φ = π/2 is used then, giving a quarter-sine that starts at
        its peak A (< uplift) and decays to zero — the block never uplifts.
        """
        amplitude = _positive("amplitude", amplitude, "m/s²")
        uplift = _positive("uplift_accel", uplift_accel, "m/s²")
        phase = math.asin(uplift / amplitude) if amplitude >= uplift else math.pi / 2
        return cls(amplitude, frequency, phase, name=name)

    def _a_in(self, tau: Arr) -> Arr:
        return self.amplitude * np.sin(self.omega * tau + self.phase)

    def _v_in(self, tau: Arr) -> Arr:
        return self.amplitude / self.omega * (math.cos(self.phase) - np.cos(self.omega * tau + self.phase))

    def _d_in(self, tau: Arr) -> Arr:
        w, p = self.omega, self.phase
        return self.amplitude / w * (tau * math.cos(p) - (np.sin(w * tau + p) - math.sin(p)) / w)

    @property
    def pga(self) -> float:
        """float, m/s²: A if the pulse passes its crest (φ ≤ π/2), else A sin φ."""
        return self.amplitude if self.phase <= math.pi / 2 else self.amplitude * math.sin(self.phase)

    @property
    def pgv(self) -> float:
        """float, m/s: A/ω (1 + cos φ), reached at the end of the pulse."""
        return self.amplitude / self.omega * (1.0 + math.cos(self.phase))

    def _params(self) -> dict[str, Any]:
        return {"amplitude": self.amplitude, "frequency": self.frequency, "phase": self.phase}


class Sawtooth(_Pulse):
    """Triangular ground-velocity pulse (pbr-xval definition, science notes §8).

    v rises linearly 0 → PGV over s·T, then falls linearly back to 0 at T, so
    a = PGV/(s T) for 0 ≤ t < s T and a = −PGV/((1 − s) T) for s T ≤ t < T.
    The residual velocity is 0 and the residual displacement PGV·T/2.

    Parameters
    ----------
    pgv : float, m/s
        Peak ground velocity, > 0.
    period : float, s
        Total pulse length T, > 0.
    skew : float
        s in (0, 1), dimensionless (0.5 = symmetric triangle).  s = 1 (a true
        sawtooth) is rejected: its instantaneous velocity drop is an
        acceleration impulse that no finite a(t) represents.
    name : str, optional
    """

    def __init__(self, pgv: float, period: float, skew: float = 0.5, *, name: str = "sawtooth") -> None:
        self.peak_velocity = _positive("pgv", pgv, "m/s")
        self.period = _positive("period", period, "s")
        skew = float(skew)
        if skew == 1.0:
            raise ValueError(
                "skew = 1 makes the velocity drop from PGV to 0 instantaneously, i.e. an acceleration "
                "impulse (Dirac delta) that a finite a(t) cannot represent; use 0 < skew < 1"
            )
        if not (0.0 < skew < 1.0):
            raise ValueError(f"skew must be in (0, 1), got {skew!r}")
        self.skew = skew
        self._T = self.period
        self._Tr = skew * self.period
        self.name = name

    @property
    def pgv(self) -> float:
        """float, m/s: peak ground velocity, reached at t = s T."""
        return self.peak_velocity

    @property
    def pga(self) -> float:
        """float, m/s²: max(PGV/(s T), PGV/((1 − s) T)); PGV/(s T) when s ≤ 0.5."""
        return self.peak_velocity / (min(self.skew, 1.0 - self.skew) * self.period)

    @property
    def breakpoints(self) -> tuple[float, ...]:
        """tuple of float, s: start, the velocity peak (end of the ramp) and the end."""
        return (0.0, self._Tr, self._T)

    def _a_in(self, tau: Arr) -> Arr:
        P, T, Tr = self.peak_velocity, self._T, self._Tr
        return np.where(tau < Tr, P / Tr, -P / (T - Tr))

    def _v_in(self, tau: Arr) -> Arr:
        P, T, Tr = self.peak_velocity, self._T, self._Tr
        return np.where(tau < Tr, P * tau / Tr, P * (T - tau) / (T - Tr))

    def _d_in(self, tau: Arr) -> Arr:
        P, T, Tr = self.peak_velocity, self._T, self._Tr
        fall = P * Tr / 2 + P * ((T - Tr) ** 2 - (T - tau) ** 2) / (2 * (T - Tr))
        return np.where(tau < Tr, P * tau**2 / (2 * Tr), fall)

    def _params(self) -> dict[str, Any]:
        return {"pgv": self.peak_velocity, "period": self.period, "skew": self.skew}


class _Cycloidal(_Pulse):
    def __init__(self, amplitude: float, frequency: float, *, name: str) -> None:
        self.amplitude = _positive("amplitude", amplitude, "m/s²")
        self.frequency = _positive("frequency", frequency, "Hz")
        self.omega = 2.0 * math.pi * self.frequency
        self._T = 1.0 / self.frequency
        self.name = name

    @property
    def pga(self) -> float:
        """float, m/s²: A."""
        return self.amplitude

    def _params(self) -> dict[str, Any]:
        return {"amplitude": self.amplitude, "frequency": self.frequency}


class OneSine(_Cycloidal):
    """Makris & Roussos type-A (one-sine) pulse, 0 ≤ τ < T = 1/f, ω = 2π f.

    a = A sin ωτ;  v = A/ω (1 − cos ωτ);  d = A/ω (τ − sin(ωτ)/ω).
    Residual velocity 0, residual displacement A T/ω.

    Parameters
    ----------
    amplitude : float, m/s²
    frequency : float, Hz
    name : str, optional
    """

    def __init__(self, amplitude: float, frequency: float, *, name: str = "one_sine") -> None:
        super().__init__(amplitude, frequency, name=name)

    @property
    def pgv(self) -> float:
        """float, m/s: 2A/ω at τ = T/2."""
        return 2.0 * self.amplitude / self.omega

    def _a_in(self, tau: Arr) -> Arr:
        return self.amplitude * np.sin(self.omega * tau)

    def _v_in(self, tau: Arr) -> Arr:
        return self.amplitude / self.omega * (1.0 - np.cos(self.omega * tau))

    def _d_in(self, tau: Arr) -> Arr:
        w = self.omega
        return self.amplitude / w * (tau - np.sin(w * tau) / w)


class OneCosine(_Cycloidal):
    """Makris & Roussos type-B (one-cosine) pulse, 0 ≤ τ < T = 1/f, ω = 2π f.

    a = A cos ωτ;  v = A/ω sin ωτ;  d = A/ω² (1 − cos ωτ).  a jumps at 0 and T;
    residual velocity and displacement are 0.

    Parameters
    ----------
    amplitude : float, m/s²
    frequency : float, Hz
    name : str, optional
    """

    def __init__(self, amplitude: float, frequency: float, *, name: str = "one_cosine") -> None:
        super().__init__(amplitude, frequency, name=name)

    @property
    def pgv(self) -> float:
        """float, m/s: A/ω."""
        return self.amplitude / self.omega

    def _a_in(self, tau: Arr) -> Arr:
        return self.amplitude * np.cos(self.omega * tau)

    def _v_in(self, tau: Arr) -> Arr:
        return self.amplitude / self.omega * np.sin(self.omega * tau)

    def _d_in(self, tau: Arr) -> Arr:
        return self.amplitude / self.omega**2 * (1.0 - np.cos(self.omega * tau))


class Rectangular(_Pulse):
    """Constant acceleration A for 0 ≤ t < duration (Housner 1963, science notes §1.6).

    v = A t, d = A t²/2; leaves a residual velocity A·duration.

    Parameters
    ----------
    amplitude : float, m/s²
    duration : float, s
    name : str, optional
    """

    def __init__(self, amplitude: float, duration: float, *, name: str = "rectangular") -> None:
        self.amplitude = _positive("amplitude", amplitude, "m/s²")
        self._T = _positive("duration", duration, "s")
        self.name = name

    @property
    def pga(self) -> float:
        """float, m/s²: A."""
        return self.amplitude

    @property
    def pgv(self) -> float:
        """float, m/s: A·duration."""
        return self.amplitude * self._T

    def _a_in(self, tau: Arr) -> Arr:
        return np.full_like(tau, self.amplitude, dtype=float)

    def _v_in(self, tau: Arr) -> Arr:
        return self.amplitude * tau

    def _d_in(self, tau: Arr) -> Arr:
        return 0.5 * self.amplitude * tau**2

    def _params(self) -> dict[str, Any]:
        return {"amplitude": self.amplitude}


class Ricker(GroundMotion):
    """Ricker wavelet a = A (1 − 2u²) exp(−u²), u = π f (t − t0).

    v = A/(π f) u e^{−u²},  d = −A e^{−u²} / (2 π² f²).

    The wavelet is not truncated: a, v, d are the closed forms above for all t,
    so v and d are integrals from t → −∞ (d is *not* shifted to d(0) = 0).
    With the default t0 = 1.5/f, |v(0)|/PGV ≈ 2.5e-9 and |d(0)|/PGD ≈ 2.3e-10,
    i.e. zero for practical purposes, and the same holds after ``duration = 2 t0``.

    Parameters
    ----------
    amplitude : float, m/s²
        Central peak A (also the PGA), > 0.
    frequency : float, Hz
        Peak frequency f, > 0.
    t0 : float, s, optional
        Centre time, > 0; default 1.5/f.
    name : str, optional
    """

    def __init__(
        self, amplitude: float, frequency: float, t0: float | None = None, *, name: str = "ricker"
    ) -> None:
        self.amplitude = _positive("amplitude", amplitude, "m/s²")
        self.frequency = _positive("frequency", frequency, "Hz")
        self.t0 = 1.5 / self.frequency if t0 is None else _positive("t0", t0, "s")
        self.name = name

    def _u(self, t: Arr) -> Arr:
        return math.pi * self.frequency * (t - self.t0)

    def _acceleration(self, t: Arr) -> Arr:
        u2 = self._u(t) ** 2
        return self.amplitude * (1.0 - 2.0 * u2) * np.exp(-u2)

    def _velocity(self, t: Arr) -> Arr:
        u = self._u(t)
        return self.amplitude / (math.pi * self.frequency) * u * np.exp(-(u**2))

    def _displacement(self, t: Arr) -> Arr:
        return -self.amplitude * np.exp(-(self._u(t) ** 2)) / (2.0 * (math.pi * self.frequency) ** 2)

    @property
    def duration(self) -> float:
        """float, s: 2 t0 (the wavelet is treated as negligible beyond)."""
        return 2.0 * self.t0

    @property
    def pga(self) -> float:
        """float, m/s²: A (at t = t0)."""
        return self.amplitude

    @property
    def pgv(self) -> float:
        """float, m/s: A e^{−1/2} / (√2 π f), at u = ±1/√2."""
        return self.amplitude * math.exp(-0.5) / (math.sqrt(2.0) * math.pi * self.frequency)

    @property
    def pgd(self) -> float:
        """float, m: A / (2 π² f²), at t = t0."""
        return self.amplitude / (2.0 * (math.pi * self.frequency) ** 2)

    def describe(self) -> dict[str, Any]:
        """Parameters as a JSON-serialisable dict (amplitude m/s², frequency Hz, times s)."""
        return {
            "type": "Ricker",
            "name": self.name,
            "amplitude": self.amplitude,
            "frequency": self.frequency,
            "t0": self.t0,
            "duration": self.duration,
        }


PULSES: dict[str, type[GroundMotion]] = {
    "half_sine": HalfSine,
    "sawtooth": Sawtooth,
    "one_sine": OneSine,
    "one_cosine": OneCosine,
    "rectangular": Rectangular,
    "ricker": Ricker,
}
