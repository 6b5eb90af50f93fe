"""Lognormal fragility fits by maximum likelihood (Baker 2015) and a 2-D PGA × PGV/PGA surface.

``P(topple | IM = x) = Φ(ln(x/θ)/β)``. With ``n_j`` runs and ``z_j`` topples at IM level
``x_j`` the binomial log-likelihood is ``Σ z_j ln Φ_j + (n_j − z_j) ln(1 − Φ_j)`` (Baker 2015,
Earthquake Spectra 31(1), eq. 11); θ and β maximise it (optimised in ln θ, ln β). Degenerate
data get no fake fit: all toppled, none toppled, or complete separation (every non-toppled
level below every toppled level: the MLE has β → 0) are reported as such.

The surface is a probit GLM ``P = Φ(b0 + b1 ln PGA + b2 ln(PGV/PGA))`` by maximum likelihood
(scipy.optimize); its median-PGA line is ``ln PGA50 = −(b0 + b2 ln(PGV/PGA))/b1``.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
from scipy import optimize, stats

__all__ = [
    "EnsembleFragility",
    "FragilityFit",
    "SurfaceFit",
    "compare_medians",
    "fit_catalog",
    "fit_ensemble_fragility",
    "fit_lognormal",
    "fit_surface",
    "profile_intervals",
]

_EPS = 1e-12


@dataclass
class FragilityFit:
    """θ: median (IM units), β: lognormal dispersion; status ``ok`` | ``all_toppled`` |
    ``none_toppled`` | ``separated`` | ``too_few`` | ``failed``."""

    im: str
    theta: float
    beta: float
    n_runs: int
    n_toppled: int
    levels: list[float] = field(default_factory=list)
    n_per_level: list[int] = field(default_factory=list)
    z_per_level: list[int] = field(default_factory=list)
    converged: bool = False
    status: str = "ok"
    message: str = ""
    loglik: float = math.nan
    #: profile-likelihood confidence intervals (see :func:`profile_intervals`); nan when not computed
    theta_ci: tuple[float, float] = (math.nan, math.nan)
    beta_ci: tuple[float, float] = (math.nan, math.nan)
    ci_level: float = math.nan

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    def probability(self, x: Any) -> Any:
        return stats.norm.cdf(np.log(np.asarray(x, float) / self.theta) / self.beta)


def _group(
    im: np.ndarray, toppled: np.ndarray, rel: float = 1e-9
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    order = np.argsort(im)
    im, toppled = im[order], toppled[order]
    levels: list[float] = []
    n: list[int] = []
    z: list[int] = []
    for x, t in zip(im, toppled, strict=True):
        if levels and abs(x - levels[-1]) <= rel * max(abs(x), 1.0):
            n[-1] += 1
            z[-1] += int(t)
        else:
            levels.append(float(x))
            n.append(1)
            z.append(int(t))
    return np.array(levels), np.array(n), np.array(z)


def _nll(params: np.ndarray, lx: np.ndarray, n: np.ndarray, z: np.ndarray) -> float:
    mu, lb = params
    s = (lx - mu) / math.exp(lb)
    lp = stats.norm.logcdf(s)
    lq = stats.norm.logcdf(-s)
    return float(-(z * lp + (n - z) * lq).sum())


def fit_lognormal(
    im: Any, toppled: Any, im_name: str = "IM", min_runs: int = 2, ci_level: float | None = None
) -> FragilityFit:
    """Maximum-likelihood lognormal fragility from (IM value, toppled) pairs; IM > 0.

    ``ci_level`` (e.g. 0.95) adds profile-likelihood intervals for θ and β
    (:func:`profile_intervals`) to a converged fit.
    """
    x = np.asarray(im, float)
    t = np.asarray(toppled, bool)
    keep = np.isfinite(x) & (x > 0)
    x, t = x[keep], t[keep]
    levels, n, z = _group(x, t)
    fit = FragilityFit(
        im_name, math.nan, math.nan, int(n.sum()), int(z.sum()), levels.tolist(), n.tolist(), z.tolist()
    )
    if fit.n_runs < min_runs:
        fit.status, fit.message = "too_few", f"{fit.n_runs} runs; need at least {min_runs}"
        return fit
    if fit.n_toppled == fit.n_runs:
        fit.status, fit.message = "all_toppled", f"all {fit.n_runs} runs toppled (θ < {levels.min():.4g})"
        return fit
    if fit.n_toppled == 0:
        fit.status, fit.message = "none_toppled", f"no run toppled (θ > {levels.max():.4g})"
        return fit
    top_lo = x[t].min()
    stay_hi = x[~t].max()
    if stay_hi < top_lo:
        fit.status = "separated"
        fit.theta = float(math.sqrt(stay_hi * top_lo))
        fit.beta = 0.0
        fit.message = f"complete separation between {stay_hi:.4g} and {top_lo:.4g}: β → 0, θ bracketed"
        return fit
    lx = np.log(levels)
    # start: moment estimate
    p = (z + 0.5) / (n + 1.0)
    q = stats.norm.ppf(p)
    try:
        slope, icpt = np.polyfit(lx, q, 1, w=np.sqrt(n))
        b0 = 1.0 / slope if slope > 0 else 0.5
        m0 = -icpt * b0
    except Exception:  # pragma: no cover
        b0, m0 = 0.5, float(np.average(lx, weights=n))
    if not (np.isfinite(b0) and b0 > 0):
        b0 = 0.5
    start = np.array([m0 if np.isfinite(m0) else lx.mean(), math.log(min(max(b0, 0.02), 5.0))])
    res = optimize.minimize(
        _nll,
        start,
        args=(lx, n, z),
        method="Nelder-Mead",
        options={"xatol": 1e-10, "fatol": 1e-12, "maxiter": 4000},
    )
    res2 = optimize.minimize(_nll, res.x, args=(lx, n, z), method="BFGS")
    best = res2 if res2.success and res2.fun <= res.fun + 1e-12 else res
    fit.theta = float(math.exp(best.x[0]))
    fit.beta = float(math.exp(best.x[1]))
    fit.loglik = -float(best.fun)
    fit.converged = bool(res.success or res2.success) and 1e-4 < fit.beta < 50
    if not fit.converged:
        fit.status, fit.message = "failed", f"optimiser did not converge ({best.message})"
    elif ci_level is not None:
        fit.theta_ci, fit.beta_ci = profile_intervals(fit, ci_level)
        fit.ci_level = float(ci_level)
    return fit


def _profile(lx: np.ndarray, n: np.ndarray, z: np.ndarray, which: int, value: float, start: float) -> float:
    """Maximum log-likelihood with parameter ``which`` (0: ln θ, 1: ln β) held at ``value``."""

    def f(other: float) -> float:
        p = np.array([value, other]) if which == 0 else np.array([other, value])
        return _nll(p, lx, n, z)

    lo, hi = (start - 4.0, start + 4.0) if which == 0 else (math.log(1e-3), math.log(50.0))
    r = optimize.minimize_scalar(f, bounds=(lo, hi), method="bounded", options={"xatol": 1e-7})
    return -float(r.fun)


def profile_intervals(
    fit: FragilityFit, level: float = 0.95
) -> tuple[tuple[float, float], tuple[float, float]]:
    """Profile-likelihood confidence intervals of θ and β of a converged fit.

    The interval of a parameter is where ``2 (ℓ_max − ℓ_profile) ≤ χ²₁(level)`` (3.84 at 95 %),
    ℓ_profile maximising the binomial log-likelihood over the other parameter. An end that is not
    reached within θ·e^±8 (β within [1e-3, 50]) is ±inf / the bound.

    Returns
    -------
    ((θ_lo, θ_hi), (β_lo, β_hi)), θ in IM units.
    """
    if not (fit.converged and fit.status == "ok"):
        return (math.nan, math.nan), (math.nan, math.nan)
    lx = np.log(np.asarray(fit.levels, float))
    n = np.asarray(fit.n_per_level, float)
    z = np.asarray(fit.z_per_level, float)
    crit = float(stats.chi2.ppf(level, 1)) / 2.0
    mu0, lb0 = math.log(fit.theta), math.log(fit.beta)
    lmax = -_nll(np.array([mu0, lb0]), lx, n, z)
    out = []
    for which, p0, span in ((0, mu0, 8.0), (1, lb0, 0.0)):
        other0 = lb0 if which == 0 else mu0

        def g(v: float, which: int = which, other0: float = other0) -> float:
            return lmax - _profile(lx, n, z, which, v, other0) - crit

        ends = []
        for sign in (-1.0, 1.0):
            if which == 0:
                far = p0 + sign * span
            else:
                far = math.log(1e-3) if sign < 0 else math.log(50.0)
            if g(far) < 0:
                ends.append(far if which == 1 else sign * math.inf)
                continue
            ends.append(optimize.brentq(g, p0, far, xtol=1e-8) if far != p0 else p0)
        out.append(
            tuple(float(math.exp(e)) if math.isfinite(e) else (0.0 if e < 0 else math.inf) for e in ends)
        )
    return out[0], out[1]  # type: ignore[return-value]


@dataclass
class SurfaceFit:
    """Probit GLM P = Φ(b0 + b1 ln PGA + b2 ln(PGV/PGA)); status as :class:`FragilityFit`."""

    coef: list[float]
    n_runs: int
    n_toppled: int
    converged: bool
    status: str = "ok"
    message: str = ""
    loglik: float = math.nan

    def probability(self, pga: Any, pgv_pga: Any) -> Any:
        b0, b1, b2 = self.coef
        return stats.norm.cdf(b0 + b1 * np.log(pga) + b2 * np.log(pgv_pga))

    def median_pga(self, pgv_pga: Any) -> Any:
        b0, b1, b2 = self.coef
        return np.exp(-(b0 + b2 * np.log(np.asarray(pgv_pga, float))) / b1)

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def fit_surface(pga: Any, pgv_pga: Any, toppled: Any) -> SurfaceFit:
    a, r = np.asarray(pga, float), np.asarray(pgv_pga, float)
    t = np.asarray(toppled, bool)
    keep = np.isfinite(a) & np.isfinite(r) & (a > 0) & (r > 0)
    a, r, t = a[keep], r[keep], t[keep]
    X = np.column_stack([np.ones_like(a), np.log(a), np.log(r)])
    out = SurfaceFit([math.nan] * 3, int(t.size), int(t.sum()), False)
    if t.size < 3 or t.all() or not t.any():
        out.status = "all_toppled" if t.size and t.all() else ("none_toppled" if t.size >= 3 else "too_few")
        out.message = "no fit: the outcomes do not vary"
        return out

    def nll(b: np.ndarray) -> float:
        s = X @ b
        return float(-(np.where(t, stats.norm.logcdf(s), stats.norm.logcdf(-s))).sum()) + 1e-8 * float(b @ b)

    def grad(b: np.ndarray) -> np.ndarray:
        s = X @ b
        lp = stats.norm.logpdf(s)
        g1 = np.exp(lp - stats.norm.logcdf(s))
        g0 = np.exp(lp - stats.norm.logcdf(-s))
        w = np.where(t, -g1, g0)
        return X.T @ w + 2e-8 * b

    res = optimize.minimize(
        nll, np.zeros(3), jac=grad, method="BFGS", options={"gtol": 1e-8, "maxiter": 2000}
    )
    out.coef = [float(v) for v in res.x]
    out.loglik = -float(res.fun)
    big = np.abs(res.x).max() > 1e3
    gnorm = float(np.linalg.norm(grad(res.x)))
    out.converged = bool(res.success or gnorm < 1e-5 * max(t.size, 1)) and not big and res.x[1] > 0
    if big:
        out.status, out.message = "separated", "coefficients diverge: the data are (quasi-)separated"
    elif not out.converged:
        out.status, out.message = "failed", str(res.message)
    return out


def fit_catalog(df: Any, ims: tuple[str, ...] = ("pga", "pgv"), min_runs: int = 2) -> Any:
    """One row per (engine, rock, IM): θ, β, counts, status; plus a ``surface`` row set.

    ``df`` is :func:`pbr_xval.catalog.store.load_results` output; only ``status == 'ok'`` runs count.
    """
    import json

    import pandas as pd

    rows = []
    ok = df[df["status"] == "ok"]
    keys = ["engine", "profile", "settings", "rock_id"]
    for key, g in ok.groupby(keys, sort=True):
        for im in ims:
            f = fit_lognormal(g[im].to_numpy(), g["toppled"].to_numpy(), im, min_runs=min_runs)
            rows.append({**dict(zip(keys, key, strict=True)), "im": im, "theta": f.theta, "beta": f.beta,
                         "n_runs": f.n_runs, "n_toppled": f.n_toppled, "converged": f.converged,
                         "status": f.status, "message": f.message,
                         "levels": json.dumps(f.levels), "n_per_level": json.dumps(f.n_per_level),
                         "z_per_level": json.dumps(f.z_per_level)})  # fmt: skip
        s = fit_surface(g["pga"].to_numpy(), g["pgv_pga"].to_numpy(), g["toppled"].to_numpy())
        rows.append({**dict(zip(keys, key, strict=True)), "im": "surface", "theta": math.nan, "beta": math.nan,
                     "n_runs": s.n_runs, "n_toppled": s.n_toppled, "converged": s.converged, "status": s.status,
                     "message": s.message or f"b = {s.coef}", "levels": json.dumps(s.coef), "n_per_level": "", "z_per_level": ""})  # fmt: skip
    return pd.DataFrame(rows)


def compare_medians(fits: Any, reference: str, im: str = "pga") -> Any:
    """Per rock and engine: θ, the reference engine's θ and the relative difference θ/θ_ref − 1."""
    import pandas as pd

    f = fits[(fits["im"] == im) & (fits["status"] == "ok")]
    ref = f[f["engine"] == reference].groupby("rock_id")["theta"].first()
    rows = []
    for _, r in f.iterrows():
        if r["engine"] == reference:
            continue
        th_ref = ref.get(r["rock_id"], math.nan)
        rows.append({"rock_id": r["rock_id"], "engine": r["engine"], "profile": r["profile"], "settings": r["settings"],
                     "im": im, "theta": r["theta"], "theta_ref": th_ref, "reference": reference,
                     "rel_diff": r["theta"] / th_ref - 1.0 if th_ref == th_ref else math.nan})  # fmt: skip
    return pd.DataFrame(rows)


# ------------------------------------------------------------------ ensembles (issue 22 item 6)
@dataclass
class EnsembleFragility:
    """A lognormal fragility fitted to ensemble members' outcomes, with its uncertainty band.

    ``theta`` (IM units) and ``beta`` are the binomial MLE over every member run (each test's
    members are its binomial trials at that test's IM). The band is a two-stage bootstrap:
    the groups (records, else tests) are resampled with replacement, then each drawn test's
    members, and the fragility is refitted; ``theta_ci`` / ``beta_ci`` are percentile intervals
    of the refits and ``draws`` the refitted (θ, β) pairs — the band reflects both the finite
    set of tests and the finite ensemble. ``theta_profile_ci`` / ``beta_profile_ci`` are the
    profile-likelihood intervals of the pooled member data (they treat member runs as
    independent trials, so they are narrower than the bootstrap when members of a test agree).
    """

    im: str
    theta: float
    beta: float
    status: str
    message: str
    n_tests: int
    n_groups: int
    n_runs: int
    n_toppled: int
    members_per_test: float
    level: float
    theta_ci: tuple[float, float] = (math.nan, math.nan)
    beta_ci: tuple[float, float] = (math.nan, math.nan)
    theta_profile_ci: tuple[float, float] = (math.nan, math.nan)
    beta_profile_ci: tuple[float, float] = (math.nan, math.nan)
    n_boot: int = 0
    boot_failed: int = 0
    draws: list[tuple[float, float]] = field(default_factory=list)

    def probability(self, x: Any) -> Any:
        return stats.norm.cdf(np.log(np.asarray(x, float) / self.theta) / self.beta)

    def band(self, grid: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(P of the fit, lower, upper) on ``grid``: percentile band of the bootstrap refits' curves."""
        g = np.asarray(grid, float)
        p = self.probability(g) if self.status == "ok" else np.full(g.shape, np.nan)
        if not self.draws:
            return p, np.full(g.shape, np.nan), np.full(g.shape, np.nan)
        th = np.array([d[0] for d in self.draws])[:, None]
        be = np.array([d[1] for d in self.draws])[:, None]
        curves = stats.norm.cdf(np.log(g[None, :] / th) / be)
        a = (1 - self.level) / 2
        return p, np.quantile(curves, a, axis=0), np.quantile(curves, 1 - a, axis=0)


def _quiet_fit(x: np.ndarray, z: np.ndarray, im: str, ci_level: float | None = None) -> FragilityFit:
    import warnings

    with warnings.catch_warnings():  # resamples with few levels: the fit's status says what happened
        warnings.simplefilter("ignore", RuntimeWarning)
        warnings.simplefilter("ignore", np.exceptions.RankWarning)
        return fit_lognormal(x, z, im_name=im, ci_level=ci_level)


def _refit(x: np.ndarray, t: np.ndarray, mu0: float, lb0: float) -> tuple[float, float] | None:
    """(θ, β) of a bootstrap resample by BFGS from the full data's MLE; None when degenerate
    (all or none toppled, complete separation, no convergence, β outside (1e-4, 50))."""
    if t.all() or not t.any() or x[~t].max() < x[t].min():
        return None
    levels, n, z = _group(x, t)
    lx = np.log(levels)
    r = optimize.minimize(_nll, np.array([mu0, lb0]), args=(lx, n, z), method="BFGS")
    theta, beta = math.exp(r.x[0]), math.exp(r.x[1])
    if not (np.isfinite(r.fun) and 1e-4 < beta < 50 and np.isfinite(theta)):
        return None
    return float(theta), float(beta)


def fit_ensemble_fragility(
    im: Any,
    toppled: Any,
    test: Any,
    group: Any = None,
    *,
    im_name: str = "IM",
    n_boot: int = 200,
    level: float = 0.95,
    seed: int = 0,
) -> EnsembleFragility:
    """Fit θ, β to member runs ``(im, toppled)`` of tests ``test`` (clustered by ``group``) with a band.

    Parameters
    ----------
    im : (n,) IM of each member run (IM units; the same for every member of a test).
    toppled : (n,) bool outcome of each member run.
    test : (n,) test identifier of each run (its members are resampled together).
    group : (n,) cluster of each run (e.g. the earthquake record; default: the test).
    n_boot : bootstrap refits (0: none).
    """
    x = np.asarray(im, float)
    t = np.asarray(toppled, bool)
    tests = np.asarray([str(v) for v in test])
    groups = tests if group is None else np.asarray([str(v) for v in group])
    keep = np.isfinite(x) & (x > 0)
    x, t, tests, groups = x[keep], t[keep], tests[keep], groups[keep]
    fit = _quiet_fit(x, t, im_name, ci_level=level)
    uniq_tests = list(dict.fromkeys(tests.tolist()))
    out = EnsembleFragility(
        im=im_name, theta=fit.theta, beta=fit.beta, status=fit.status, message=fit.message,
        n_tests=len(uniq_tests), n_groups=len(set(groups.tolist())), n_runs=int(t.size),
        n_toppled=int(t.sum()), members_per_test=(t.size / len(uniq_tests) if uniq_tests else 0.0),
        level=float(level), theta_profile_ci=fit.theta_ci, beta_profile_ci=fit.beta_ci,
    )  # fmt: skip
    if fit.status != "ok" or n_boot <= 0:
        return out
    # index: group -> its tests -> the rows of each test
    by_test: dict[str, np.ndarray] = {k: np.flatnonzero(tests == k) for k in uniq_tests}
    group_tests: dict[str, list[str]] = {}
    for k in uniq_tests:
        group_tests.setdefault(str(groups[by_test[k][0]]), []).append(k)
    glist = list(group_tests)
    rng = np.random.default_rng(seed)
    draws: list[tuple[float, float]] = []
    failed = 0
    for _ in range(int(n_boot)):
        idx: list[np.ndarray] = []
        for gi in rng.integers(0, len(glist), len(glist)):
            for k in group_tests[glist[gi]]:
                rows = by_test[k]
                idx.append(rows[rng.integers(0, rows.size, rows.size)])
        sel = np.concatenate(idx)
        d = _refit(x[sel], t[sel], math.log(fit.theta), math.log(fit.beta))
        if d is None:
            failed += 1
        else:
            draws.append(d)
    out.n_boot, out.boot_failed, out.draws = int(n_boot), failed, draws
    if len(draws) >= 10:
        a = (1 - level) / 2
        th = np.array([d[0] for d in draws])
        be = np.array([d[1] for d in draws])
        out.theta_ci = (float(np.quantile(th, a)), float(np.quantile(th, 1 - a)))
        out.beta_ci = (float(np.quantile(be, a)), float(np.quantile(be, 1 - a)))
    return out
