"""Fragility functions for hazard work: lognormal, step, discrete, and the union of several.

``P_f(x)`` is the probability that a rock topples in one earthquake whose intensity measure
(IM) at the site is ``x`` (SI: m/s² for PGA and SA, m/s for PGV). The lognormal form is
``Φ(ln(x/θ)/β)`` with median θ (IM units) and dispersion β (dimensionless).

OpenQuake's NRML ``logncdf`` fragility functions are written with the *linear* moments of the
lognormal capacity, not (θ, β):

    mean = θ·exp(β²/2),   stddev = mean·sqrt(exp(β²) − 1)

and back ``β = sqrt(ln(1 + (stddev/mean)²))``, ``θ = mean/sqrt(1 + (stddev/mean)²)``
(:func:`lognormal_to_moments`, :func:`moments_to_lognormal`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy import stats

from pbr_xval.hazard.ims import HazardInputError, canonical_im

__all__ = [
    "DiscreteFragility",
    "Fragility",
    "LognormalFragility",
    "StepFragility",
    "UnionFragility",
    "lognormal_to_moments",
    "moments_to_lognormal",
]


def lognormal_to_moments(theta: float, beta: float) -> tuple[float, float]:
    """(θ, β) → linear mean and standard deviation of the lognormal capacity (IM units).

    Examples
    --------
    >>> m, s = lognormal_to_moments(2.0, 0.5)
    >>> round(m, 6), round(s, 6)
    (2.266297, 1.2067)
    """
    if not (theta > 0 and beta >= 0 and math.isfinite(theta) and math.isfinite(beta)):
        raise ValueError(f"need θ > 0 and β ≥ 0, got θ = {theta!r}, β = {beta!r}")
    mean = theta * math.exp(beta * beta / 2.0)
    return mean, mean * math.sqrt(math.expm1(beta * beta))


def moments_to_lognormal(mean: float, stddev: float) -> tuple[float, float]:
    """Linear mean and standard deviation (IM units) → (θ, β) of the lognormal capacity."""
    if not (mean > 0 and stddev >= 0 and math.isfinite(mean) and math.isfinite(stddev)):
        raise ValueError(f"need mean > 0 and stddev ≥ 0, got mean = {mean!r}, stddev = {stddev!r}")
    c2 = (stddev / mean) ** 2
    return mean / math.sqrt(1.0 + c2), math.sqrt(math.log1p(c2))


@dataclass
class Fragility:
    """Base: an IM name and an id; subclasses give :meth:`probability`."""

    im: str
    id: str = "rock"

    def __post_init__(self) -> None:
        self.im = canonical_im(self.im)

    def probability(self, x: Any) -> np.ndarray:  # pragma: no cover - abstract
        """P(topple | IM = x); x : (n,) float, IM units (SI) → (n,) float in [0, 1]."""
        raise NotImplementedError

    def breakpoints(self) -> np.ndarray:
        """IM values (SI) where P_f changes shape (used to refine integration grids)."""
        return np.array([])

    def support(self) -> tuple[float, float]:
        """IM range (SI) outside which P_f is 0 (below) or constant (above), as far as known."""
        return (0.0, math.inf)


@dataclass
class LognormalFragility(Fragility):
    """``Φ(ln(x/θ)/β)``; θ : float, IM units (SI); β : float > 0. CIs are optional (from a fit)."""

    theta: float = math.nan
    beta: float = math.nan
    theta_ci: tuple[float, float] = (math.nan, math.nan)
    beta_ci: tuple[float, float] = (math.nan, math.nan)
    meta: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        super().__post_init__()
        if not (self.theta > 0 and math.isfinite(self.theta)):
            raise HazardInputError(f"fragility {self.id!r}: median θ = {self.theta!r}; expected > 0")
        if not (self.beta > 0 and math.isfinite(self.beta)):
            raise HazardInputError(f"fragility {self.id!r}: dispersion β = {self.beta!r}; expected > 0")

    def probability(self, x: Any) -> np.ndarray:
        x = np.asarray(x, float)
        with np.errstate(divide="ignore"):
            return stats.norm.cdf(np.log(np.maximum(x, 0.0) / self.theta) / self.beta)

    def breakpoints(self) -> np.ndarray:
        return np.array([self.theta])

    def support(self) -> tuple[float, float]:
        return (self.theta * math.exp(-8.5 * self.beta), self.theta * math.exp(8.5 * self.beta))

    @property
    def moments(self) -> tuple[float, float]:
        """(mean, stddev) of the capacity in IM units — NRML's ``mean``/``stddev``."""
        return lognormal_to_moments(self.theta, self.beta)


@dataclass
class StepFragility(Fragility):
    """Deterministic threshold: P_f = 1 for x ≥ im_star, else 0 (im_star in IM units, SI)."""

    im_star: float = math.nan

    def __post_init__(self) -> None:
        super().__post_init__()
        if not (self.im_star > 0 and math.isfinite(self.im_star)):
            raise HazardInputError(f"fragility {self.id!r}: threshold {self.im_star!r}; expected > 0")

    def probability(self, x: Any) -> np.ndarray:
        return (np.asarray(x, float) >= self.im_star).astype(float)

    def breakpoints(self) -> np.ndarray:
        return np.array([self.im_star])

    def support(self) -> tuple[float, float]:
        return (self.im_star, self.im_star)


@dataclass
class DiscreteFragility(Fragility):
    """P_f at IM levels, linear between them, 0 below the first level (or ``no_damage_limit``)
    and held at the last value above the last level (OpenQuake's ``format="discrete"``)."""

    imls: Any = None
    poes: Any = None
    no_damage_limit: float | None = None

    def __post_init__(self) -> None:
        super().__post_init__()
        x = np.asarray(self.imls, float)
        p = np.asarray(self.poes, float)
        where = f"fragility {self.id!r}"
        if x.ndim != 1 or x.size < 2 or x.shape != p.shape:
            raise HazardInputError(
                f"{where}: imls/poes of shapes {x.shape}/{p.shape}; expected two equal 1-D lists ≥ 2"
            )
        if not (np.all(np.isfinite(x)) and np.all(x >= 0) and np.all(np.diff(x) > 0)):
            raise HazardInputError(f"{where}: imls {x.tolist()}; expected strictly increasing values ≥ 0")
        if not (np.all(p >= 0) and np.all(p <= 1) and np.all(np.diff(p) >= -1e-12)):
            raise HazardInputError(
                f"{where}: poes {p.tolist()}; expected non-decreasing probabilities in [0, 1]"
            )
        self.imls, self.poes = x, p

    def probability(self, x: Any) -> np.ndarray:
        x = np.asarray(x, float)
        lo = self.imls[0] if self.no_damage_limit is None else max(self.no_damage_limit, 0.0)
        p = np.interp(x, self.imls, self.poes, left=self.poes[0], right=self.poes[-1])
        return np.where(x < lo, 0.0, p)

    def breakpoints(self) -> np.ndarray:
        extra = [] if self.no_damage_limit is None else [self.no_damage_limit]
        return np.unique(np.r_[self.imls, extra])

    def support(self) -> tuple[float, float]:
        return (float(self.imls[0]), float(self.imls[-1]))


@dataclass
class UnionFragility(Fragility):
    """P(at least one of several rocks topples | x) = 1 − Π(1 − P_r(x)), toppling conditionally
    independent given the event's IM (several rocks of one site shaken by the same events)."""

    members: list[Fragility] = field(default_factory=list)

    def __post_init__(self) -> None:
        super().__post_init__()
        for m in self.members:
            if m.im != self.im:
                raise HazardInputError(f"union of fragilities on {self.im} and {m.im}: expected one IM")

    def probability(self, x: Any) -> np.ndarray:
        q = np.ones_like(np.asarray(x, float))
        for m in self.members:
            q = q * (1.0 - m.probability(x))
        return 1.0 - q

    def breakpoints(self) -> np.ndarray:
        return np.unique(np.concatenate([m.breakpoints() for m in self.members] or [np.array([])]))

    def support(self) -> tuple[float, float]:
        s = [m.support() for m in self.members]
        return (min(a for a, _ in s), max(b for _, b in s))
