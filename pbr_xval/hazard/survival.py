"""Survival of precarious rocks under a site's hazard, and the hazard it constrains.

Assumptions (stated in ``docs/hazard.md`` and in every report):

* **Poisson occurrence** — earthquakes whose IM at the site exceeds x arrive as a Poisson process of
  rate λ(x) (the hazard curve), stationary over the rock's exposure time T.
* **Fragility per event** — an event of intensity x topples the rock with probability P_f(x),
  independently of earlier events (no damage accumulation), with P_f measured for *this site's*
  rock on *its own pedestal* and the hazard computed for the same site condition.
* The rate of toppling events is then ``ν = ∫ P_f(x) |dλ(x)|`` (1/yr), the thinned Poisson
  process, and the rock survives T years with probability ``exp(−ν T)``. With an uncertain
  exposure age (e.g. a ¹⁰Be age ± σ) ``P_s = E_T[exp(−ν T)]``.
* **Several rocks** — ``joint="independent"`` (the default, as in the literature that reweights
  hazard models with several PBRs): rocks survive independently given the hazard,
  ``P = Π_r P_s,r``. ``joint="shared-events"``: the same earthquakes shake every rock of the site
  (one IM per event), toppling conditionally independent given that IM; a rock exposed over the
  most recent T_r years sees the events of that window. This gives a larger joint survival than
  the product (events that topple two rocks are counted once), i.e. a weaker constraint.

Integration: ``ν = P_f(x₁) λ(x₁) + ∫_{x₁}^{∞} λ(x) dP_f(x)`` (by parts from the lowest level x₁ of
the curve; the rate below x₁ is unknown and taken to topple nothing). For a lognormal fragility
the integral is taken over the fragility's density in z = ln(x/θ)/β (Simpson, 4001 points on
z ∈ [z₁, 9]); for a step at im*, ν = λ(im*); otherwise a Stieltjes sum on 4000 log-spaced points
refined at the fragility's breakpoints.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy import integrate, stats

from pbr_xval.hazard.curves import HazardCurve
from pbr_xval.hazard.fragility_functions import Fragility, LognormalFragility, StepFragility, UnionFragility
from pbr_xval.hazard.ims import HazardInputError

__all__ = [
    "Age",
    "Constraint",
    "RockInput",
    "TruncationCheck",
    "branches_from_quantiles",
    "constrain",
    "joint_survival",
    "survival_probability",
    "toppling_rate",
    "truncation_check",
    "weighted_quantile",
]

_Z_MAX = 9.0
_N = 4001


@dataclass(frozen=True)
class Age:
    """Exposure age of a rock, years: ``mean`` ± ``sd``; ``dist`` ``normal`` (truncated at 0),
    ``lognormal`` (mean and sd of T itself, not of ln T) or ``fixed``."""

    mean: float
    sd: float = 0.0
    dist: str = "normal"

    def __post_init__(self) -> None:
        if not (self.mean > 0 and math.isfinite(self.mean)):
            raise HazardInputError(f"age mean {self.mean!r} yr; expected > 0")
        if not (self.sd >= 0 and math.isfinite(self.sd)):
            raise HazardInputError(f"age sd {self.sd!r} yr; expected ≥ 0")
        if self.dist not in ("normal", "lognormal", "fixed"):
            raise HazardInputError(f"age dist {self.dist!r}; expected normal, lognormal or fixed")

    @property
    def _fixed(self) -> bool:
        return self.dist == "fixed" or self.sd == 0.0

    def expect_exp(self, nu: float) -> float:
        """E_T[exp(−ν T)] for ν ≥ 0 (1/yr): closed form for the truncated normal, Gauss–Hermite
        (96 nodes in ln T) for the lognormal."""
        if nu < 0:
            raise ValueError(f"rate ν = {nu!r}; expected ≥ 0")
        if self._fixed:
            return math.exp(-nu * self.mean)
        m, s = self.mean, self.sd
        if self.dist == "normal":
            lg = (
                -nu * m
                + 0.5 * (nu * s) ** 2
                + stats.norm.logcdf((m - nu * s * s) / s)
                - stats.norm.logcdf(m / s)
            )
            return float(math.exp(lg))
        s2 = math.log1p((s / m) ** 2)
        mu, sl = math.log(m) - s2 / 2.0, math.sqrt(s2)
        z, w = np.polynomial.hermite_e.hermegauss(96)
        return float(np.sum(w * np.exp(-nu * np.exp(mu + sl * z))) / math.sqrt(2.0 * math.pi))

    def expect_exp_array(self, nu: Any) -> np.ndarray:
        """:meth:`expect_exp` for an array of rates (same formulas, vectorised)."""
        v = np.asarray(nu, float)
        if np.any(v < 0):
            raise ValueError("rates ν must be ≥ 0")
        if self._fixed:
            return np.exp(-v * self.mean)
        m, s = self.mean, self.sd
        if self.dist == "normal":
            lg = (
                -v * m
                + 0.5 * (v * s) ** 2
                + stats.norm.logcdf((m - v * s * s) / s)
                - stats.norm.logcdf(m / s)
            )
            return np.exp(lg)
        s2 = math.log1p((s / m) ** 2)
        mu, sl = math.log(m) - s2 / 2.0, math.sqrt(s2)
        z, w = np.polynomial.hermite_e.hermegauss(96)
        t = np.exp(mu + sl * z)
        return (np.exp(-v[..., None] * t) @ w) / math.sqrt(2.0 * math.pi)

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """n ages (yr) drawn from the distribution (the normal truncated at 0 by rejection)."""
        if self._fixed:
            return np.full(n, self.mean)
        if self.dist == "lognormal":
            s2 = math.log1p((self.sd / self.mean) ** 2)
            return np.exp(rng.normal(math.log(self.mean) - s2 / 2, math.sqrt(s2), n))
        a = (0.0 - self.mean) / self.sd
        return stats.truncnorm.rvs(a, np.inf, loc=self.mean, scale=self.sd, size=n, random_state=rng)


def toppling_rate(fragility: Fragility, curve: HazardCurve) -> float:
    """Annual rate of toppling events ν = ∫ P_f(x) |dλ(x)| (1/yr).

    Parameters
    ----------
    fragility : Fragility
        On the same IM as ``curve`` (SI units).
    curve : HazardCurve

    Returns
    -------
    float, 1/yr
    """
    if fragility.im != curve.im:
        raise HazardInputError(
            f"fragility {fragility.id!r} is on {fragility.im}, hazard curve {curve.name!r} on {curve.im}; expected one IM"
        )
    x1 = float(curve.levels[0])
    xn = float(curve.levels[-1])
    cut = curve.tail == "cut" or curve._last_positive < curve.levels.size - 1
    base = float(fragility.probability(x1)) * float(curve.rates[0])
    if isinstance(fragility, StepFragility):
        s = fragility.im_star
        if s <= x1:
            return float(curve.rates[0])
        if cut and s > xn:
            return 0.0
        return float(curve.rate(s)[0])
    if isinstance(fragility, LognormalFragility):
        th, b = fragility.theta, fragility.beta
        z1 = math.log(x1 / th) / b
        z2 = min(_Z_MAX, math.log(xn / th) / b) if cut else _Z_MAX
        if z2 <= z1:
            return base
        z = np.linspace(z1, z2, _N)
        lam = curve.rate(th * np.exp(b * z))
        if cut:
            lam = np.where(z <= math.log(xn / th) / b, lam, 0.0)
        return base + float(integrate.simpson(lam * stats.norm.pdf(z), x=z))
    # generic: Stieltjes sum ∫ λ dP_f on a log grid refined at breakpoints
    _lo, hi = fragility.support()
    top = xn if cut else max(xn, hi if math.isfinite(hi) else xn) * math.e
    if top <= x1:
        return base
    bp = fragility.breakpoints()
    bp = bp[(bp > x1) & (bp < top)]
    grid = np.unique(np.r_[np.geomspace(x1, top, _N - 1), bp, bp * (1 - 1e-9)])
    p = fragility.probability(grid)
    lam = curve.rate(grid)
    if cut:
        lam = np.where(grid <= xn, lam, 0.0)
    return base + float(np.sum(0.5 * (lam[1:] + lam[:-1]) * np.diff(p)))


def toppling_rate_lognormal_batch(theta: Any, beta: Any, curve: HazardCurve, n: int = _N) -> np.ndarray:
    """:func:`toppling_rate` of many lognormal fragilities (θ_j, β_j, SI) on one curve at once —
    the same by-parts formula and Simpson rule (``n`` points per fragility; 4001 as the scalar
    function), vectorised."""
    th = np.atleast_1d(np.asarray(theta, float))
    b = np.atleast_1d(np.asarray(beta, float))
    x1, xn = float(curve.levels[0]), float(curve.levels[-1])
    cut = curve.tail == "cut" or curve._last_positive < curve.levels.size - 1
    base = stats.norm.cdf(np.log(x1 / th) / b) * float(curve.rates[0])
    z1 = np.log(x1 / th) / b
    zn = np.log(xn / th) / b
    z2 = np.minimum(_Z_MAX, zn) if cut else np.full_like(z1, _Z_MAX)
    out = base.copy()
    ok = z2 > z1
    if ok.any():
        z = np.linspace(z1[ok], z2[ok], n, axis=1)
        lam = curve.rate((th[ok, None] * np.exp(b[ok, None] * z)).ravel()).reshape(z.shape)
        if cut:
            lam = np.where(z <= zn[ok, None], lam, 0.0)
        out[ok] += integrate.simpson(lam * stats.norm.pdf(z), x=z, axis=1)
    return out


def survival_probability(fragility: Fragility, curve: HazardCurve, age: Age | float) -> float:
    """P_s = E_T[exp(−T ∫ P_f |dλ|)] — probability that the rock is still standing after its
    exposure age (``age`` in years, or an :class:`Age`)."""
    a = age if isinstance(age, Age) else Age(float(age), 0.0, "fixed")
    return a.expect_exp(toppling_rate(fragility, curve))


@dataclass
class TruncationCheck:
    """How much a hazard curve's ends can bias one rock's survival (see :func:`truncation_check`).

    IMs in SI, rates in 1/yr. ``pf_low`` = P_f at the curve's lowest level ``x_low``: events below it
    are unknown to the curve and counted as toppling nothing, so ``ps`` is an upper bound;
    ``nu_below`` estimates their toppling rate by continuing the lowest segment's power law
    downwards and ``ps_extended`` is P_s with it. ``top_bound`` = (1 − P_f(x_high))·λ(x_high) is the
    most any tail above the last level can change ν (for every non-increasing λ), ``top_share`` =
    ``top_bound``·T̄ the most it can change −ln P_s."""

    branch: str
    rock: str
    x_low: float
    pf_low: float
    x_high: float
    pf_high: float
    rate_high: float
    tail: str
    nu: float
    nu_below: float
    ps: float
    ps_extended: float
    top_bound: float
    top_share: float
    age_mean: float = math.nan
    low_flag: bool = False
    high_flag: bool = False

    def to_dict(self) -> dict[str, Any]:
        from dataclasses import asdict

        return asdict(self)


def _extended_below(curve: HazardCurve, x_to: float) -> HazardCurve | None:
    """The curve with its lowest segment's power law continued down to ``x_to`` (SI)."""
    x, r = curve.levels, curve.rates
    if not (x_to < x[0]) or r[1] <= 0:
        return None
    k = -math.log(r[1] / r[0]) / math.log(x[1] / x[0])
    if not (k > 0 and math.isfinite(k)):
        return None
    xs = np.geomspace(x_to, x[0], 60)[:-1]
    return HazardCurve(curve.im, np.r_[xs, x], np.r_[r[0] * (xs / x[0]) ** (-k), r], curve.name, curve.weight,
                       curve.tail, curve.source)  # fmt: skip


def truncation_check(
    fragility: Fragility, curve: HazardCurve, age: Age, p_low_max: float = 0.01, top_tol: float = 0.01
) -> TruncationCheck:
    """Check that ``curve`` spans ``fragility``: P_f at the lowest level ≤ ``p_low_max`` (else
    ``low_flag``) and, for a ``cut`` tail (not modelled), ``(1 − P_f(x_n))·λ(x_n)·T̄ ≤ top_tol``
    (else ``high_flag``). A ``powerlaw`` tail is a model and is not flagged; ``top_share`` says how
    much it carries. Returns the figures of :class:`TruncationCheck`."""
    x1, xn = float(curve.levels[0]), float(curve.levels[-1])
    pf1, pfn = float(fragility.probability(x1)), float(fragility.probability(xn))
    nu = toppling_rate(fragility, curve)
    lo = fragility.support()[0]
    x_to = lo if 0 < lo < x1 else x1 * 1e-3
    ext = _extended_below(curve, x_to) if pf1 > 0 else None
    nu_below = toppling_rate(fragility, ext) - nu if ext is not None else 0.0
    lam_n = float(curve.rates[-1])
    top = (1.0 - pfn) * lam_n
    share = top * age.mean
    cut = curve.tail == "cut" or curve._last_positive < curve.levels.size - 1
    return TruncationCheck(
        curve.name, fragility.id, x1, pf1, xn, pfn, lam_n, "cut" if cut else curve.tail, nu, max(nu_below, 0.0),
        age.expect_exp(nu), age.expect_exp(nu + max(nu_below, 0.0)), top, share, age.mean,
        low_flag=pf1 > p_low_max, high_flag=cut and share > top_tol,
    )  # fmt: skip


def _field(x: float, im: str) -> str:
    from pbr_xval.hazard.ims import oq_factor, oq_unit

    return f"{x / oq_factor(im):.3g} {oq_unit(im)}"


def _p3(p: float) -> str:
    """A probability to 3 decimals, or 2 significant digits below 0.001."""
    return f"{p:.3f}" if p >= 1e-3 or p == 0 else f"{p:.2g}"


def truncation_message(checks: list[TruncationCheck], p_low_max: float, top_tol: float, im: str) -> str:
    """One line on the worst flagged check (and how many there are)."""
    low = [c for c in checks if c.low_flag]
    high = [c for c in checks if c.high_flag]
    parts = []
    if low:
        c = max(low, key=lambda c: c.pf_low)
        parts.append(
            f"hazard branch {c.branch!r} starts at {_field(c.x_low, im)} where rock {c.rock!r} already topples with "
            f"P_f = {c.pf_low:.2f} > {p_low_max:g} ({len(low)} of {len(checks)} branch × rock pairs): events below "
            f"the curve are counted as toppling nothing, so P_s = {_p3(c.ps)} is an upper bound (the lowest segment's "
            f"power law continued below gives {_p3(c.ps_extended)}; missing toppling rate ≈ {c.nu_below:.3g}/yr, "
            f"× T̄ = {c.nu_below * c.age_mean:.3g} toppling events)"
        )
    if high:
        c = max(high, key=lambda c: c.top_share)
        parts.append(
            f"hazard branch {c.branch!r} stops at {_field(c.x_high, im)} (tail 'cut') where 1 − P_f = "
            f"{1 - c.pf_high:.2f} of rock {c.rock!r} and λ = {c.rate_high:.3g}/yr: the unmodelled tail can change "
            f"−ln P_s by up to {c.top_share:.3g} > {top_tol:g} ({len(high)} of {len(checks)} pairs)"
        )
    return "; ".join(parts)


def joint_survival(
    fragilities: list[Fragility],
    curve: HazardCurve,
    ages: list[Age],
    joint: str = "independent",
    n_samples: int = 20000,
    seed: int = 0,
    _cache: dict[Any, float] | None = None,
) -> float:
    """Probability that every rock of a site survived (see the module docstring for ``joint``).

    ``shared-events`` averages over the ages by Monte Carlo (``n_samples``, common random numbers
    through ``seed``; exact when every age is fixed).
    """
    if len(fragilities) != len(ages):
        raise ValueError("one age per fragility")
    if joint == "independent":
        return float(
            np.prod([a.expect_exp(toppling_rate(f, curve)) for f, a in zip(fragilities, ages, strict=True)])
        )
    if joint != "shared-events":
        raise HazardInputError(f"joint {joint!r}; expected 'independent' or 'shared-events'")
    cache = {} if _cache is None else _cache

    def nu_of(members: tuple[int, ...]) -> float:
        if members not in cache:
            f = fragilities[members[0]] if len(members) == 1 else UnionFragility(
                fragilities[0].im, "union", [fragilities[i] for i in members])  # fmt: skip
            cache[members] = toppling_rate(f, curve)
        return cache[members]

    n = len(fragilities)
    fixed = all(a._fixed for a in ages)
    rng = np.random.default_rng(seed)
    T = np.column_stack([a.sample(rng, 1 if fixed else n_samples) for a in ages])  # (s, n)
    order = np.argsort(T, axis=1)
    total = np.zeros(T.shape[0])
    prev = np.zeros(T.shape[0])
    # on (t_(k-1), t_(k)] the exposed rocks are those with age ≥ t_(k): order[:, k:]
    for k in range(n):
        tk = np.take_along_axis(T, order[:, k : k + 1], axis=1)[:, 0]
        exposed = np.sort(order[:, k:], axis=1)
        keys, inv = np.unique(exposed, axis=0, return_inverse=True)
        nus = np.array([nu_of(tuple(int(i) for i in row)) for row in keys])
        total += (tk - prev) * nus[inv.ravel()]
        prev = tk
    return float(np.mean(np.exp(-total)))


def weighted_quantile(values: Any, weights: Any, q: float) -> np.ndarray:
    """Weighted quantile across branches, OpenQuake's convention: sort the values at each level,
    accumulate the (normalised) weights, interpolate ``q`` linearly in the cumulative weights.

    values : (b, m) float; weights : (b,) float ≥ 0 → (m,) float
    """
    v = np.asarray(values, float)
    w = np.asarray(weights, float)
    w = w / w.sum()
    idx = np.argsort(v, axis=0)
    sv = np.take_along_axis(v, idx, axis=0)
    cw = np.cumsum(w[idx], axis=0)
    return np.array([np.interp(q, cw[:, j], sv[:, j]) for j in range(v.shape[1])])


def branches_from_quantiles(curves: list[HazardCurve], quantiles: list[float]) -> list[HazardCurve]:
    """Fractile curves as discrete branches: weight of fractile q_i = the interval between the
    midpoints to its neighbours (0 and 1 at the ends). An approximation of the distribution that
    the fractiles describe; state it when you use it."""
    q = np.asarray(quantiles, float)
    if q.size == 1:
        raise HazardInputError(
            f"one fractile curve (q = {q[0]:g}) is not a distribution; expected at least 2 fractiles, "
            "or give the curve as a [[hazard.branch]]"
        )
    if q.size != len(curves) or q.size == 0 or np.any(np.diff(q) <= 0) or q[0] <= 0 or q[-1] >= 1:
        raise HazardInputError(f"quantiles {q.tolist()}; expected increasing values in (0, 1), one per curve")
    b = np.r_[0.0, 0.5 * (q[1:] + q[:-1]), 1.0]
    out = []
    for c, qi, wi in zip(curves, q, np.diff(b), strict=True):
        out.append(
            HazardCurve(
                c.im, c.levels, c.rates, f"quantile-{qi:g}", float(wi), c.tail, c.source, list(c.notes)
            )
        )
    return out


@dataclass
class RockInput:
    """A rock of the site: its fragility (on the hazard's IM) and exposure age."""

    id: str
    fragility: Fragility
    age: Age


@dataclass
class Constraint:
    """Result of :func:`constrain`. Shapes: b branches, r rocks, m grid levels."""

    im: str
    grid: np.ndarray  # (m,) SI
    branch_names: list[str]
    prior: np.ndarray  # (b,)
    posterior: np.ndarray  # (b,)
    rates: np.ndarray  # (b, m) 1/yr
    nu: np.ndarray  # (b, r) 1/yr
    survival: np.ndarray  # (b, r)
    joint: np.ndarray  # (b,)
    rock_ids: list[str]
    joint_mode: str
    quantiles: tuple[float, ...]
    rate_of_interest: float
    summary: dict[str, Any] = field(default_factory=dict)
    #: the curves' ends against each rock's fragility (:func:`truncation_check`), one per branch × rock
    checks: list[TruncationCheck] = field(default_factory=list)
    #: loud warnings (truncated curves allowed by the user, …), also in the report
    warnings: list[str] = field(default_factory=list)
    im_of_interest: float | None = None

    def mean(self, after: bool = False) -> np.ndarray:
        """Weighted mean hazard curve on :attr:`grid` (1/yr)."""
        w = self.posterior if after else self.prior
        return (w[:, None] * self.rates).sum(axis=0) / w.sum()

    def quantile(self, q: float, after: bool = False) -> np.ndarray:
        """Weighted fractile hazard curve on :attr:`grid` (1/yr)."""
        return weighted_quantile(self.rates, self.posterior if after else self.prior, q)

    def im_at_rate(self, rates_on_grid: np.ndarray, rate: float) -> float:
        """IM (SI) where a curve on :attr:`grid` crosses ``rate`` (log-log interpolation); nan if not."""
        r = np.asarray(rates_on_grid, float)
        ok = r > 0
        if not ok.any() or rate > r[ok].max() or rate < r[ok].min():
            return math.nan
        return float(np.exp(np.interp(math.log(rate), np.log(r[ok])[::-1], np.log(self.grid[ok])[::-1])))

    def rate_at_im(self, rates_on_grid: np.ndarray, x: float) -> float:
        """Annual rate (1/yr) of a curve on :attr:`grid` at IM ``x`` (SI; log-log); nan outside the grid."""
        if x is None or not (math.isfinite(x) and self.grid[0] <= x <= self.grid[-1]):
            return math.nan
        r = np.maximum(np.asarray(rates_on_grid, float), 1e-300)
        return float(np.exp(np.interp(math.log(x), np.log(self.grid), np.log(r))))

    def contribution(self, fragility: Fragility, after: bool = False) -> np.ndarray:
        """Where the toppling rate comes from: P_f(x)·|dλ/d ln x| of the mean curve on :attr:`grid`
        (1/yr per unit ln x; its integral over ln x is the toppling rate above the grid's start)."""
        lam = np.maximum(self.mean(after), 1e-300)
        lx = np.log(self.grid)
        d = -np.gradient(lam, lx)
        return np.asarray(fragility.probability(self.grid), float) * np.maximum(d, 0.0)


def _grid(branches: list[HazardCurve], n: int = 200) -> np.ndarray:
    lo = max(float(c.levels[0]) for c in branches)
    hi = min(float(c.levels[-1]) for c in branches)
    if not hi > lo:
        raise HazardInputError("hazard branches share no IM range; expected overlapping levels")
    nodes = np.concatenate([c.levels for c in branches])
    return np.unique(np.r_[np.geomspace(lo, hi, n), nodes[(nodes >= lo) & (nodes <= hi)]])


def constrain(
    branches: list[HazardCurve],
    rocks: list[RockInput],
    joint: str = "independent",
    rate_of_interest: float = 1e-4,
    quantiles: tuple[float, ...] = (0.05, 0.5, 0.95),
    n_samples: int = 20000,
    seed: int = 0,
    allow_truncated: bool = False,
    p_low_max: float = 0.01,
    top_tol: float = 0.01,
    im_of_interest: float | None = None,
) -> Constraint:
    """Reweight hazard branches by the likelihood that every rock survived.

    ``w'_b ∝ w_b · P(all rocks survived | branch b)``; the constrained mean and fractile curves are
    the weighted mean and fractiles of the branches with w'. ``summary`` gives, at
    ``rate_of_interest`` (1/yr), the IM of the mean curve and the 5–95 % range of the branches'
    IMs (weighted fractiles), before and after; and at ``im_of_interest`` (SI; default the prior
    mean curve's IM at the rate of interest) the mean curve's rate before and after.

    Every branch × rock is checked with :func:`truncation_check`: a curve whose lowest level leaves
    P_f > ``p_low_max``, or whose unmodelled (``cut``) tail could change −ln P_s by more than
    ``top_tol``, raises :class:`HazardInputError` (one line with the bias figures) unless
    ``allow_truncated``, which records the same line in :attr:`Constraint.warnings`. With one
    branch there are no fractiles (``quantiles`` is emptied and the summary's ranges are nan).
    """
    if not branches:
        raise HazardInputError("no hazard branches; expected at least one curve")
    if not rocks:
        raise HazardInputError("no rocks; expected at least one rock with a fragility and an age")
    im = branches[0].im
    for c in branches:
        if c.im != im:
            raise HazardInputError(f"hazard branch {c.name!r} is on {c.im}, others on {im}; expected one IM")
    for r in rocks:
        if r.fragility.im != im:
            raise HazardInputError(
                f"rock {r.id!r}: fragility on {r.fragility.im}, hazard on {im}; expected the same IM"
            )
    w = np.array([c.weight for c in branches], float)
    if not w.sum() > 0:
        raise HazardInputError("hazard branch weights sum to 0; expected positive weights")
    w = w / w.sum()
    checks = [truncation_check(r.fragility, c, r.age, p_low_max, top_tol) for c in branches for r in rocks]
    warnings: list[str] = []
    if any(k.low_flag or k.high_flag for k in checks):
        msg = truncation_message(checks, p_low_max, top_tol, im)
        if not allow_truncated:
            raise HazardInputError(msg + "; extend the hazard curve, or set allow_truncated_curve = true")
        warnings.append("TRUNCATED HAZARD CURVE (allowed): " + msg)
    if len(branches) == 1:
        quantiles = ()
    nu = np.array([[toppling_rate(r.fragility, c) for r in rocks] for c in branches])
    surv = np.array([[r.age.expect_exp(v) for r, v in zip(rocks, row, strict=True)] for row in nu])
    if joint == "independent":
        jnt = surv.prod(axis=1)
    else:
        jnt = np.array([
            joint_survival([r.fragility for r in rocks], c, [r.age for r in rocks], joint, n_samples, seed)
            for c in branches
        ])  # fmt: skip
    if not (w * jnt).sum() > 0:
        raise HazardInputError(
            "every branch gives the rocks a survival probability of 0; the data contradict the hazard model"
        )
    post = w * jnt / (w * jnt).sum()
    grid = _grid(branches)
    rates = np.array([c.rate(grid) for c in branches])
    out = Constraint(im, grid, [c.name for c in branches], w, post, rates, nu, surv, jnt, [r.id for r in rocks],
                     joint, tuple(quantiles), float(rate_of_interest))  # fmt: skip
    out.checks, out.warnings, out.im_of_interest = checks, warnings, im_of_interest
    out.summary = _summary(out, branches)
    return out


def _summary(c: Constraint, branches: list[HazardCurve]) -> dict[str, Any]:
    r = c.rate_of_interest
    # on the common grid (no extrapolation): a branch that does not reach r there is left out
    ims = np.array([c.im_at_rate(c.rates[i], r) for i in range(len(branches))])
    ok = np.isfinite(ims)
    s: dict[str, Any] = {
        "rate_of_interest": r,
        "branches_reaching_rate": int(ok.sum()),
        "n_branches": len(branches),
    }
    for tag, after in (("before", False), ("after", True)):
        w = c.posterior if after else c.prior
        s[f"mean_im_{tag}"] = c.im_at_rate(c.mean(after), r)
        if ok.sum() > 1:
            q05 = float(weighted_quantile(ims[ok][:, None], w[ok], 0.05)[0])
            q95 = float(weighted_quantile(ims[ok][:, None], w[ok], 0.95)[0])
        else:
            q05 = q95 = math.nan
        s[f"im05_{tag}"], s[f"im95_{tag}"] = q05, q95
        s[f"range_{tag}"] = q95 - q05
    s["mean_im_change"] = s["mean_im_after"] / s["mean_im_before"] - 1.0
    s["range_ratio"] = s["range_after"] / s["range_before"] if s["range_before"] > 0 else math.nan
    # second headline: the mean curve's annual rate at a fixed IM, before and after (default: the
    # prior mean curve's IM at the rate of interest, where the "before" rate is the rate of interest)
    x0 = c.im_of_interest if c.im_of_interest is not None else s["mean_im_before"]
    s["im_of_interest"] = x0
    s["im_of_interest_given"] = c.im_of_interest is not None
    for tag, after in (("before", False), ("after", True)):
        s[f"mean_rate_{tag}_at_im"] = c.rate_at_im(c.mean(after), x0)
    s["mean_rate_ratio_at_im"] = s["mean_rate_after_at_im"] / s["mean_rate_before_at_im"]
    s["mean_rate_after_at_that_im"] = s["mean_rate_after_at_im"]  # old key, kept
    s["prior_joint_survival"] = float((c.prior * c.joint).sum())
    s["rock_survival"] = {rid: float((c.prior * c.survival[:, i]).sum()) for i, rid in enumerate(c.rock_ids)}
    return s
