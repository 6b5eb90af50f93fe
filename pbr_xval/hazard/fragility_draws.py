"""The fragility's uncertainty carried into survival and into the reweighted hazard.

A rock's fragility is known only within its fit's uncertainty. pbr-xval represents it by **draws**
f_1 … f_J of the fragility, equally weighted:

* ``profile`` — from a lognormal fit's profile-likelihood intervals (``pbr-xval fragility``):
  ln θ and ln β drawn independently, each from a **split normal** whose median is the fit and whose
  2.5 % and 97.5 % points are the interval's ends (for a 95 % interval; the level is read from the
  file), i.e. a log-standard deviation ``(ln θ − ln θ_lo)/1.96`` below the fit and
  ``(ln θ_hi − ln θ)/1.96`` above. The correlation of θ̂ and β̂ is neglected (stated). Draws are
  scrambled-Sobol normal quantiles (seeded), so J = 256 draws give P_s to ~10⁻⁴.
* ``ensemble`` — the member fragilities of an ensemble (e.g. one per engine × parameter draw),
  each a draw.

With draws, for branch b, rock r and draw j: ν_brj and P_s,brj = E_T[exp(−ν_brj T)]. Then

* **P_s with the fragility's uncertainty** (prior hazard) = mean over j of Σ_b w_b P_s,brj, with the
  5–95 % band over j of Σ_b w_b P_s,brj (the band the fragility adds), and the draws' standard error;
* **the reweighted hazard**: the fragility is uncertain whatever the branch, so the likelihood of
  branch b is the marginal ``L_b = E_j[Π_r P_s,brj] = Π_r E_j[P_s,brj]`` (draws of different rocks
  are independent) and ``w'_b ∝ w_b L_b``; the band: the constrained mean curve's IM at the rate of
  interest (and its rate at the IM of interest) recomputed with each draw j alone, 5–95 % over j;
* **which part of the spread comes from where**: the conditional survival
  ``s(B, F, T) = exp(−ν(B, F)·T)`` of a rock, with B the hazard branch (prior weights), F the
  fragility draw and T the exposure age (64 equal-probability age quantiles), has first-order
  variance shares ``Var(E[s | X]) / Var(s)`` for X = B, F, T (Sobol first-order indices, exact on
  this grid); the rest (1 − their sum) is their interaction. P_s = E[s].

Only ``joint = "independent"`` (the default) carries the draws; with ``shared-events`` the
fragilities are taken at their fits (stated in the report).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy import stats

from pbr_xval.hazard.curves import HazardCurve
from pbr_xval.hazard.fragility_functions import Fragility, LognormalFragility
from pbr_xval.hazard.ims import HazardInputError
from pbr_xval.hazard.survival import (
    Age,
    Constraint,
    RockInput,
    toppling_rate,
    toppling_rate_lognormal_batch,
    weighted_quantile,
)

__all__ = ["FragilityDraws", "UncertaintyResult", "draws_from_profile", "propagate", "split_normal_sd"]


@dataclass
class FragilityDraws:
    """Equally weighted draws of one rock's fragility; ``method`` ``profile`` | ``ensemble``."""

    rock: str
    members: list[Fragility]
    method: str
    note: str = ""


def split_normal_sd(fit: LognormalFragility, level: float = 0.95) -> tuple[float, float, float, float]:
    """Log-standard deviations (θ below, θ above, β below, β above) matched to the fit's intervals."""
    z = float(stats.norm.ppf(0.5 + level / 2.0))
    (tl, th), (bl, bh) = fit.theta_ci, fit.beta_ci
    vals = (tl, th, bl, bh)
    if not all(math.isfinite(v) and v > 0 for v in vals):
        raise HazardInputError(
            f"fragility {fit.id!r}: intervals θ {list(fit.theta_ci)}, β {list(fit.beta_ci)}; expected finite "
            "positive ends to draw from (or fragility_uncertainty = 'none')"
        )
    lt, lb = math.log(fit.theta), math.log(fit.beta)
    out = ((lt - math.log(tl)) / z, (math.log(th) - lt) / z, (lb - math.log(bl)) / z, (math.log(bh) - lb) / z)
    if min(out) < 0:
        raise HazardInputError(
            f"fragility {fit.id!r}: the fit lies outside its own interval; expected θ, β inside"
        )
    return out


def draws_from_profile(
    fit: LognormalFragility, n: int = 256, seed: int = 0, level: float | None = None
) -> FragilityDraws:
    """``n`` draws of (θ, β) from split normals in ln θ, ln β matched to the fit's intervals."""
    lev = float(level if level is not None else fit.meta.get("ci_level", 0.95))
    if not 0 < lev < 1:
        lev = 0.95
    st_lo, st_hi, sb_lo, sb_hi = split_normal_sd(fit, lev)
    from scipy.stats import qmc

    m = max(math.ceil(math.log2(max(n, 2))), 1)
    u = qmc.Sobol(2, scramble=True, seed=seed).random_base2(m)[:n]
    zz = stats.norm.ppf(np.clip(u, 1e-12, 1 - 1e-12))
    lt = math.log(fit.theta) + zz[:, 0] * np.where(zz[:, 0] < 0, st_lo, st_hi)
    lb = math.log(fit.beta) + zz[:, 1] * np.where(zz[:, 1] < 0, sb_lo, sb_hi)
    members: list[Fragility] = [
        LognormalFragility(fit.im, f"{fit.id}#{j}", theta=float(math.exp(a)), beta=float(math.exp(b)))
        for j, (a, b) in enumerate(zip(lt, lb, strict=True))
    ]
    note = (f"{n} draws: ln θ, ln β independent split normals matched to the {lev:.0%} profile intervals "
            f"θ ∈ [{fit.theta_ci[0]:.4g}, {fit.theta_ci[1]:.4g}], β ∈ [{fit.beta_ci[0]:.3g}, {fit.beta_ci[1]:.3g}]")  # fmt: skip
    return FragilityDraws(fit.id, members, "profile", note)


@dataclass
class UncertaintyResult:
    """Shapes: b branches, r rocks, j draws. P_s figures under the prior hazard."""

    rock_ids: list[str]
    methods: list[str]
    notes: list[str]
    n_draws: list[int]
    ps_fit: np.ndarray  # (r,) at the fitted fragilities
    ps_mean: np.ndarray  # (r,) mean over draws
    ps_se: np.ndarray  # (r,) standard error of ps_mean from the finite draws
    ps_band: np.ndarray  # (r, 2) 5 % and 95 % over draws
    joint_mean: float
    joint_band: tuple[float, float]
    posterior: np.ndarray  # (b,) marginal over the draws
    mean_im_after: float  # SI, marginal posterior mean curve at the rate of interest
    mean_im_after_band: tuple[float, float]
    rate_after_at_im: float
    rate_after_at_im_band: tuple[float, float]
    shares: dict[str, dict[str, float]] = field(
        default_factory=dict
    )  # rock → hazard/fragility/age/interaction
    ps_by_branch: np.ndarray | None = None  # (b, r, j)
    #: rock → 95th percentile over draws of P_f at the highest of the branches' lowest levels (the
    #: truncation check of the fitted fragility, repeated over the draws)
    pf_low_95: dict[str, float] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return {
            "rocks": {
                rid: {"method": self.methods[i], "n_draws": self.n_draws[i], "ps_fit": float(self.ps_fit[i]),
                      "ps": float(self.ps_mean[i]), "ps_se": float(self.ps_se[i]),
                      "ps_05": float(self.ps_band[i, 0]), "ps_95": float(self.ps_band[i, 1]),
                      "variance_shares": self.shares.get(rid, {}), "note": self.notes[i],
                      "pf_lowest_level_95_over_draws": self.pf_low_95.get(rid, math.nan)}
                for i, rid in enumerate(self.rock_ids)
            },
            "joint_survival": self.joint_mean, "joint_survival_05_95": list(self.joint_band),
            "posterior_weights_marginal": [float(v) for v in self.posterior],
            "mean_im_after_marginal": self.mean_im_after, "mean_im_after_05_95": list(self.mean_im_after_band),
            "mean_rate_after_at_im_marginal": self.rate_after_at_im,
            "mean_rate_after_at_im_05_95": list(self.rate_after_at_im_band),
        }  # fmt: skip


def _age_nodes(age: Age, k: int = 64) -> np.ndarray:
    """k equal-probability quantiles of the age distribution (yr)."""
    p = (np.arange(k) + 0.5) / k
    if age._fixed:
        return np.full(k, age.mean)
    if age.dist == "lognormal":
        s2 = math.log1p((age.sd / age.mean) ** 2)
        return np.exp(math.log(age.mean) - s2 / 2 + math.sqrt(s2) * stats.norm.ppf(p))
    a = -age.mean / age.sd
    return np.asarray(stats.truncnorm.ppf(p, a, np.inf, loc=age.mean, scale=age.sd), float)


def variance_shares(nu: np.ndarray, w: np.ndarray, t: np.ndarray) -> dict[str, float]:
    """First-order variance shares of s = exp(−ν_bj·t_k): branch b (weights w), draw j (equal),
    age node k (equal). nu : (b, j) 1/yr; w : (b,); t : (k,) yr."""
    s = np.exp(-nu[:, :, None] * t[None, None, :])
    wb = (w / w.sum())[:, None, None]
    e = float((wb * s).sum() / (s.shape[1] * s.shape[2]))
    var = float((wb * s * s).sum() / (s.shape[1] * s.shape[2])) - e * e
    if not var > 1e-300:
        return {
            "hazard": math.nan,
            "fragility": math.nan,
            "age": math.nan,
            "interaction": math.nan,
            "variance": 0.0,
        }
    eb = s.mean(axis=(1, 2))
    ej = (wb * s).sum(axis=0).mean(axis=1)
    ek = (wb * s).sum(axis=0).mean(axis=0)
    vb = float(((w / w.sum()) * (eb - e) ** 2).sum())
    vj = float(((ej - e) ** 2).mean())
    vk = float(((ek - e) ** 2).mean())
    return {"hazard": vb / var, "fragility": vj / var, "age": vk / var, "interaction": 1.0 - (vb + vj + vk) / var,
            "variance": var}  # fmt: skip


def _rates(members: list[Fragility], branches: list[HazardCurve]) -> np.ndarray:
    """ν (1/yr) of every member on every branch, (b, j); lognormal members in one batch."""
    if all(isinstance(f, LognormalFragility) for f in members):
        th = np.array([f.theta for f in members])  # type: ignore[attr-defined]
        be = np.array([f.beta for f in members])  # type: ignore[attr-defined]
        return np.array([toppling_rate_lognormal_batch(th, be, br, n=401) for br in branches])
    return np.array([[toppling_rate(f, br) for f in members] for br in branches])


def propagate(
    c: Constraint, branches: list[HazardCurve], rocks: list[RockInput], draws: dict[str, FragilityDraws]
) -> UncertaintyResult:
    """Carry each rock's fragility draws (rocks without draws keep their fit) into P_s and the
    reweighted hazard of :func:`~pbr_xval.hazard.survival.constrain`'s result ``c``."""
    w = c.prior
    nb = len(branches)
    ps_all, nus, methods, notes, nd = [], [], [], [], []
    for r in rocks:
        d = draws.get(r.id)
        mem = d.members if d is not None else [r.fragility]
        methods.append(d.method if d is not None else "none")
        notes.append(d.note if d is not None else "fragility taken as known (no intervals or draws)")
        nd.append(len(mem))
        nu = _rates(mem, branches)  # (b, j)
        nus.append(nu)
        ps_all.append(r.age.expect_exp_array(nu))
    jmax = max(nd)
    ps_prior = [(w[:, None] * p).sum(axis=0) for p in ps_all]  # (j,) per rock
    ps_mean = np.array([float(p.mean()) for p in ps_prior])
    ps_se = np.array([float(p.std(ddof=1) / math.sqrt(p.size)) if p.size > 1 else 0.0 for p in ps_prior])
    ps_band = np.array([np.quantile(p, [0.05, 0.95]) for p in ps_prior])
    # marginal likelihood per branch; per-draw posteriors (draw j of every rock, cycling shorter sets)
    lik = np.prod([p.mean(axis=1) for p in ps_all], axis=0)
    post = w * lik / (w * lik).sum()
    per = np.ones((nb, jmax))
    for p in ps_all:
        per *= p[:, np.arange(jmax) % p.shape[1]]
    im_draws, rate_draws = [], []
    x0 = c.summary.get("im_of_interest", math.nan)
    for j in range(jmax):
        pj = w * per[:, j]
        if not pj.sum() > 0:
            continue
        pj = pj / pj.sum()
        m = (pj[:, None] * c.rates).sum(axis=0)
        im_draws.append(c.im_at_rate(m, c.rate_of_interest))
        rate_draws.append(c.rate_at_im(m, x0))
    mean_after = (post[:, None] * c.rates).sum(axis=0)
    joint_d = (w[:, None] * per).sum(axis=0)

    def band(v: list[float]) -> tuple[float, float]:
        a = np.asarray([x for x in v if math.isfinite(x)], float)
        return (float(np.quantile(a, 0.05)), float(np.quantile(a, 0.95))) if a.size else (math.nan, math.nan)

    shares = {r.id: variance_shares(nus[i], w, _age_nodes(r.age)) for i, r in enumerate(rocks)}
    x_low = max(float(br.levels[0]) for br in branches)
    pf_low = {}
    for r in rocks:
        d = draws.get(r.id)
        mem = d.members if d is not None else [r.fragility]
        pf_low[r.id] = float(np.quantile([float(f.probability(x_low)) for f in mem], 0.95))
    return UncertaintyResult(
        [r.id for r in rocks], methods, notes, nd,
        np.array([float(c.summary["rock_survival"][r.id]) for r in rocks]), ps_mean, ps_se, ps_band,
        float((w * lik).sum()), band(list(joint_d)), post, c.im_at_rate(mean_after, c.rate_of_interest),
        band(im_draws), c.rate_at_im(mean_after, x0), band(rate_draws), shares,
        np.stack([p[:, np.arange(jmax) % p.shape[1]] for p in ps_all], axis=1), pf_low,
    )  # fmt: skip


def weighted_im_range(c: Constraint, weights: np.ndarray) -> tuple[float, float]:
    """5–95 % of the branches' IMs at the rate of interest under ``weights`` (as the summary's range)."""
    ims = np.array([c.im_at_rate(c.rates[i], c.rate_of_interest) for i in range(c.rates.shape[0])])
    ok = np.isfinite(ims)
    if ok.sum() < 2:
        return (math.nan, math.nan)
    return (float(weighted_quantile(ims[ok][:, None], weights[ok], 0.05)[0]),
            float(weighted_quantile(ims[ok][:, None], weights[ok], 0.95)[0]))  # fmt: skip
