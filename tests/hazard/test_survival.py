"""Survival probability against closed forms and independent numerical methods."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate, stats

from pbr_xval.hazard import (
    Age,
    DiscreteFragility,
    HazardCurve,
    LognormalFragility,
    StepFragility,
    joint_survival,
    survival_probability,
    toppling_rate,
)

K0, K = 2e-4, 2.8  # λ(x) = K0 x^-K, x in m/s²


def power_curve(lo: float = 1e-3, hi: float = 100.0, n: int = 40, tail: str = "powerlaw") -> HazardCurve:
    x = np.geomspace(lo, hi, n)
    return HazardCurve("PGA", x, K0 * x**-K, tail=tail)


@pytest.mark.parametrize("im_star", [0.5, 2.0, 7.3, 150.0])
def test_step_fragility_is_exp_minus_T_lambda(im_star):
    # closed form: a step at im* topples in every event above im*, rate λ(im*) = K0 im*^-K
    c = power_curve()
    T = 12000.0
    ps = survival_probability(StepFragility("PGA", "s", im_star=im_star), c, T)
    assert ps == pytest.approx(math.exp(-T * K0 * im_star**-K), rel=1e-12)


@pytest.mark.parametrize("theta,beta", [(2.0, 0.3), (4.0, 0.5), (1.5, 0.8)])
def test_lognormal_matches_cornell_closed_form(theta, beta):
    # power-law hazard ⊗ lognormal fragility: ν = K0 θ^-K exp(K²β²/2) (Cornell 1968 / SAC-FEMA);
    # the curve starts at 1e-3 m/s², far below θ, so the missing low-IM part is < 1e-20
    c = power_curve()
    nu = toppling_rate(LognormalFragility("PGA", "r", theta=theta, beta=beta), c)
    exact = K0 * theta**-K * math.exp(K * K * beta * beta / 2)
    assert nu == pytest.approx(exact, rel=1e-9)  # measured ≤ 6e-13


def _curved(x):  # a non-power-law hazard (quadratic in log-log), 1/yr, x in m/s²
    u = np.log(np.asarray(x, float) / 1.0)
    return 1e-3 * np.exp(-1.8 * u - 0.25 * u * u)


def test_lognormal_matches_direct_quadrature_on_curved_hazard():
    # independent: scipy.integrate.quad of P_f(x)·(−dλ/dx) in x with the analytic derivative,
    # vs the implementation's by-parts integral over the fragility density on a tabulated curve
    x = np.geomspace(0.05, 200.0, 400)
    c = HazardCurve("PGA", x, _curved(x))
    f = LognormalFragility("PGA", "r", theta=3.0, beta=0.45)

    def dens(xx):
        u = math.log(xx)
        return float(_curved(xx)) * (1.8 + 0.5 * u) / xx * float(f.probability(xx))

    # events above 200 m/s² (P_f = 1 there to 1e-13) add λ(200); the curve's tail carries the same
    ref = integrate.quad(dens, 0.05, 200.0, limit=400, points=[3.0])[0] + float(_curved(200.0))
    nu = toppling_rate(f, c)
    # tabulated (400 log-spaced points) vs analytic curve: log-log interpolation, measured −1.8e-5
    assert nu == pytest.approx(ref, rel=2e-4)


def test_lognormal_survival_matches_monte_carlo_over_events():
    # independent: simulate the Poisson process of events above x1 and a coin per event
    rng = np.random.default_rng(42)
    c = power_curve(lo=0.5, hi=100.0)
    f = LognormalFragility("PGA", "r", theta=3.0, beta=0.4)
    T = 3000.0
    lam1 = K0 * 0.5**-K
    n_hist = 40000
    n_events = rng.poisson(lam1 * T, n_hist)
    tot = n_events.sum()
    # IM of an event above x1: Pareto, P(X > x | X > x1) = (x/x1)^-K
    xs = 0.5 * rng.uniform(size=tot) ** (-1.0 / K)
    topple = rng.uniform(size=tot) < f.probability(xs)
    hist = np.repeat(np.arange(n_hist), n_events)
    survived = np.ones(n_hist, bool)
    survived[hist[topple]] = False
    p_mc = survived.mean()
    se = math.sqrt(p_mc * (1 - p_mc) / n_hist)
    ps = survival_probability(f, c, T)
    assert abs(ps - p_mc) < 4 * se, (ps, p_mc, se)


def test_discrete_fragility_agrees_with_its_lognormal():
    c = power_curve()
    f = LognormalFragility("PGA", "r", theta=3.0, beta=0.4)
    xs = np.geomspace(3.0 * math.exp(-3.2), 3.0 * math.exp(3.2), 600)
    d = DiscreteFragility("PGA", "d", imls=xs, poes=f.probability(xs))
    exact = K0 * 3.0**-K * math.exp(K * K * 0.16 / 2)
    # 600 levels over θe^±3.2 (±8β), linear between levels: measured 5.5e-5 relative
    assert toppling_rate(d, c) == pytest.approx(exact, rel=3e-4)


def test_cut_tail_is_a_lower_bound_and_step_above_curve_survives():
    c_pl = power_curve(hi=5.0)
    c_cut = power_curve(hi=5.0, tail="cut")
    f = LognormalFragility("PGA", "r", theta=4.0, beta=0.5)
    assert toppling_rate(f, c_cut) < toppling_rate(f, c_pl)
    # with a cut tail the rate above 5 m/s² is put at 5: ν = P_f(5)·λ(5) + ∫_{x1}^{5} λ dP_f
    s = StepFragility("PGA", "s", im_star=6.0)
    assert toppling_rate(s, c_cut) == 0.0
    assert toppling_rate(s, c_pl) == pytest.approx(K0 * 6.0**-K, rel=1e-12)


@pytest.mark.parametrize("dist", ["normal", "lognormal"])
def test_age_expectation_matches_quadrature(dist):
    # independent: quad over the age density (truncnorm / lognorm from scipy.stats)
    nu = 1.3e-4
    a = Age(10000.0, 2500.0, dist)
    if dist == "normal":
        pdf = stats.truncnorm(-4.0, np.inf, loc=10000.0, scale=2500.0).pdf
    else:
        s2 = math.log1p(0.25**2)
        pdf = stats.lognorm(math.sqrt(s2), scale=10000.0 * math.exp(-s2 / 2)).pdf
    ref = integrate.quad(lambda t: math.exp(-nu * t) * pdf(t), 0, 1e5, limit=200, points=[10000.0])[0]
    assert a.expect_exp(nu) == pytest.approx(ref, rel=1e-8)
    assert Age(10000.0, 0.0).expect_exp(nu) == pytest.approx(math.exp(-1.3))


def test_joint_survival_modes():
    c = power_curve()
    f1 = LognormalFragility("PGA", "a", theta=2.0, beta=0.3)
    f2 = LognormalFragility("PGA", "b", theta=3.0, beta=0.4)
    ages = [Age(8000.0, 0.0, "fixed"), Age(12000.0, 0.0, "fixed")]
    ind = joint_survival([f1, f2], c, ages)
    assert ind == pytest.approx(survival_probability(f1, c, 8000.0) * survival_probability(f2, c, 12000.0))
    sh = joint_survival([f1, f2], c, ages, joint="shared-events")
    # closed form with fixed ages: both exposed 8000 yr to ν(1 ∪ 2) = ν1 + ν2 − ν12, rock 2 alone 4000 yr
    n1, n2 = toppling_rate(f1, c), toppling_rate(f2, c)
    x = np.geomspace(1e-3, 1e4, 200001)
    p12 = f1.probability(x) * f2.probability(x)
    n12 = float(np.sum(0.5 * (p12[1:] + p12[:-1]) * -np.diff(K0 * x**-K)))
    assert sh == pytest.approx(math.exp(-8000 * (n1 + n2 - n12) - 4000 * n2), rel=1e-4)
    assert sh > ind  # shared events are counted once: weaker joint constraint
    # two identical rocks of one age, shared events: P = exp(−T ∫ (1 − (1 − p)²) |dλ|)
    sh_same = joint_survival([f1, f1], c, [ages[0], ages[0]], joint="shared-events")
    n11 = float(
        np.sum(
            0.5
            * (1 - (1 - f1.probability(x[1:])) ** 2 + 1 - (1 - f1.probability(x[:-1])) ** 2)
            * -np.diff(K0 * x**-K)
        )
    )
    assert sh_same == pytest.approx(math.exp(-8000 * n11), rel=1e-4)
