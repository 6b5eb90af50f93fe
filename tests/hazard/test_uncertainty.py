"""The fragility's uncertainty carried into P_s and the reweighted hazard (issue 25, item 2), checked
against a Monte Carlo written here: branch, fragility, age and the Poisson event sequence all drawn."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from pbr_xval.hazard import Age, HazardCurve, LognormalFragility, RockInput, constrain
from pbr_xval.hazard.fragility_draws import FragilityDraws, draws_from_profile, propagate, variance_shares

X1, K = 0.5, 2.8  # curves λ_b(x) = k0_b x^−K above x1 (m/s²)
K0 = (1.2e-4, 3.0e-4)
W = np.array([0.6, 0.4])
FIT = LognormalFragility("PGA", "r", theta=3.0, beta=0.4, theta_ci=(2.4, 4.2), beta_ci=(0.27, 0.65))
AGE = Age(3000.0, 600.0, "normal")


def _branches():
    x = np.geomspace(X1, 200.0, 60)
    return [
        HazardCurve("PGA", x, k0 * x**-K, name=f"b{i}", weight=float(w))
        for i, (k0, w) in enumerate(zip(K0, W, strict=True))
    ]


def _split(rng, med, lo, hi, n):
    """Split normal in ln: median ln med, 2.5 % / 97.5 % points ln lo / ln hi (written from the docs)."""
    z = rng.standard_normal(n)
    return np.exp(
        np.log(med)
        + np.where(
            z < 0, z * (np.log(med) - np.log(lo)) / 1.959964, z * (np.log(hi) - np.log(med)) / 1.959964
        )
    )


def _monte_carlo(n_hist: int, seed: int):
    rng = np.random.default_rng(seed)
    b = rng.choice(2, size=n_hist, p=W)
    th = _split(rng, FIT.theta, *FIT.theta_ci, n_hist)
    be = _split(rng, FIT.beta, *FIT.beta_ci, n_hist)
    t = rng.normal(AGE.mean, AGE.sd, 4 * n_hist)
    t = t[t > 0][:n_hist]  # truncated at 0 by rejection
    lam1 = np.array(K0)[b] * X1**-K
    n_ev = rng.poisson(lam1 * t)
    h = np.repeat(np.arange(n_hist), n_ev)
    x = X1 * rng.uniform(size=h.size) ** (-1.0 / K)  # Pareto above x1: P(X > x) = (x/x1)^−K
    top = rng.uniform(size=h.size) < stats.norm.cdf(np.log(x / th[h]) / be[h])
    surv = np.ones(n_hist, bool)
    surv[h[top]] = False
    return b, surv


def test_survival_with_fragility_uncertainty_matches_a_monte_carlo():
    br = _branches()
    rock = RockInput("r", FIT, AGE)
    c = constrain(br, [rock])
    d = draws_from_profile(FIT, 4096, seed=3)
    u = propagate(c, br, [rock], {"r": d})
    b, surv = _monte_carlo(200_000, 11)
    p_mc = surv.mean()
    se = math.sqrt(p_mc * (1 - p_mc) / surv.size)
    assert abs(u.ps_mean[0] - p_mc) < 4 * math.hypot(se, u.ps_se[0]), (u.ps_mean[0], p_mc, se, u.ps_se[0])
    # the uncertainty matters here: P_s with it differs from the fitted fragility's by many MC errors
    assert abs(u.ps_fit[0] - p_mc) > 6 * se
    # the marginal posterior weight of branch 0 = P(branch 0 | survived) in the simulation
    post_mc = (surv & (b == 0)).sum() / surv.sum()
    se_post = math.sqrt(post_mc * (1 - post_mc) / surv.sum())
    assert abs(u.posterior[0] - post_mc) < 4 * se_post, (u.posterior[0], post_mc, se_post)
    # the band is what the draws give: 5 % < mean < 95 %
    assert u.ps_band[0, 0] < u.ps_mean[0] < u.ps_band[0, 1]


def test_draws_match_the_intervals():
    d = draws_from_profile(FIT, 4096, seed=1)
    th = np.array([f.theta for f in d.members])
    be = np.array([f.beta for f in d.members])
    np.testing.assert_allclose(np.quantile(th, [0.025, 0.5, 0.975]), [2.4, 3.0, 4.2], rtol=5e-3)
    np.testing.assert_allclose(np.quantile(be, [0.025, 0.5, 0.975]), [0.27, 0.4, 0.65], rtol=5e-3)
    assert abs(stats.spearmanr(th, be)[0]) < 0.05  # drawn independently
    with pytest.raises(Exception, match="expected finite positive ends"):
        draws_from_profile(
            LognormalFragility("PGA", "x", theta=3.0, beta=0.4, theta_ci=(2.0, math.inf), beta_ci=(0.2, 0.6))
        )


def test_variance_shares_isolate_each_source():
    t = np.array([1000.0, 2000.0, 3000.0])
    only_age = variance_shares(np.array([[1e-4]]), np.array([1.0]), t)
    assert only_age["age"] == pytest.approx(1.0) and only_age["hazard"] == pytest.approx(0.0)
    only_frag = variance_shares(np.array([[1e-4, 3e-4, 5e-4]]), np.array([1.0]), np.array([2000.0]))
    assert only_frag["fragility"] == pytest.approx(1.0)
    only_haz = variance_shares(np.array([[1e-4], [5e-4]]), np.array([0.3, 0.7]), np.array([2000.0]))
    assert only_haz["hazard"] == pytest.approx(1.0)
    # additive in log space is not additive in exp(−νT): the shares and the interaction sum to 1
    mixed = variance_shares(np.array([[1e-4, 3e-4], [2e-4, 6e-4]]), np.array([0.5, 0.5]), t)
    assert sum(mixed[k] for k in ("hazard", "fragility", "age", "interaction")) == pytest.approx(1.0)
    assert all(mixed[k] > 0 for k in ("hazard", "fragility", "age"))


def test_ensemble_members_are_draws_and_a_known_fragility_has_no_band():
    br = _branches()
    rock = RockInput("r", FIT, AGE)
    c = constrain(br, [rock])
    mem = [LognormalFragility("PGA", f"m{i}", theta=t, beta=0.4) for i, t in enumerate((2.5, 3.0, 3.5))]
    u = propagate(c, br, [rock], {"r": FragilityDraws("r", mem, "ensemble")})
    ps_each = [sum(w * AGE.expect_exp(_nu(m, k0)) for w, k0 in zip(W, K0, strict=True)) for m in mem]
    assert u.ps_mean[0] == pytest.approx(np.mean(ps_each), rel=2e-5)
    u0 = propagate(c, br, [rock], {})
    assert u0.methods == ["none"] and u0.ps_band[0, 0] == pytest.approx(u0.ps_band[0, 1])
    assert u0.ps_mean[0] == pytest.approx(c.summary["rock_survival"]["r"], rel=2e-5)


def _nu(f, k0):
    # Cornell: power law from x1 far below θ (P_f(x1) < 1e-5 here)
    return k0 * f.theta**-K * math.exp(K * K * f.beta**2 / 2)


def test_bootstrap_draws_of_the_ensemble_fragility_command_are_read(tmp_path):
    # `pbr-xval fragility RESULTS --ensemble` writes ensemble_fragility_pga_draws.csv (draw, theta_m_s2, beta)
    from pbr_xval.hazard.config import load_config
    from pbr_xval.hazard.ims import HazardInputError

    x = np.geomspace(0.05, 100.0, 40)
    (tmp_path / "h.csv").write_text(
        "pga_m_s2,annual_rate\n" + "".join(f"{float(a)!r},{float(1e-4 * a**-2.5)!r}\n" for a in x)
    )
    (tmp_path / "f.csv").write_text("id,im,unit,theta,beta\nr,PGA,m/s²,3.0,0.4\n")
    (tmp_path / "d.csv").write_text("draw,theta_m_s2,beta\n0,2.5,0.35\n1,3.0,0.4\n2,3.6,0.5\n")
    rock = '[[rock]]\nid = "r"\nfragility = "f.csv"\nensemble = "d.csv"\nage = 3000.0\n'
    p = tmp_path / "c.toml"
    p.write_text('[hazard]\n[[hazard.branch]]\nfile = "h.csv"\n' + rock)
    cfg = load_config(p)
    d = cfg.draws["r"]
    assert d.method == "bootstrap" and [m.theta for m in d.members] == [2.5, 3.0, 3.6]
    assert [m.beta for m in d.members] == [0.35, 0.4, 0.5] and all(m.im == "PGA" for m in d.members)
    c = constrain(cfg.branches, cfg.rocks)
    u = propagate(c, cfg.branches, cfg.rocks, cfg.draws)
    assert u.ps_mean[0] == pytest.approx(
        np.mean([AGE_FIXED(3000.0).expect_exp(_nu1(m)) for m in d.members]), rel=1e-4
    )
    (tmp_path / "d.csv").write_text("draw,theta_m_s,beta\n0,0.3,0.4\n1,0.4,0.4\n")
    with pytest.raises(HazardInputError, match=r"d\.csv has theta_m_s; the rock.s fragility is on PGA"):
        load_config(p)


def AGE_FIXED(t):
    return Age(t, 0.0, "fixed")


def _nu1(f):
    # Cornell on λ = 1e-4 x^−2.5 from 0.05 m/s² (P_f there < 1e-9)
    return 1e-4 * f.theta**-2.5 * math.exp(2.5**2 * f.beta**2 / 2)
