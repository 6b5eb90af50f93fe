from __future__ import annotations

import math

import numpy as np
import pandas as pd
from scipy import stats

from pbr_xval.catalog.fragility import compare_medians, fit_catalog, fit_lognormal, fit_surface


def test_mle_recovers_known_lognormal():
    rng = np.random.default_rng(7)
    theta, beta = 3.0, 0.4
    levels = np.geomspace(1.0, 9.0, 12)
    x = np.repeat(levels, 40)
    p = stats.norm.cdf(np.log(x / theta) / beta)
    errs_t, errs_b = [], []
    for _ in range(20):
        t = rng.uniform(size=x.size) < p
        f = fit_lognormal(x, t, "pga")
        assert f.status == "ok" and f.converged
        errs_t.append(math.log(f.theta / theta))
        errs_b.append(f.beta / beta - 1)
    # sampling error of ln θ for 480 runs ≈ 0.02–0.03: mean over 20 fits is tight
    assert abs(np.mean(errs_t)) < 0.02 and np.std(errs_t) < 0.05
    assert abs(np.mean(errs_b)) < 0.08


def test_symmetric_data_closed_form():
    # counts symmetric about ln x = 0 in log space → θ = 1 exactly; two levels with fractions
    # p and 1-p at ln x = ±d → β = d / Φ⁻¹(1−p) (the MLE reproduces the observed fractions)
    d, n, z = 0.5, 100, 20
    x = np.r_[np.full(n, math.exp(-d)), np.full(n, math.exp(d))]
    t = np.r_[np.arange(n) < z, np.arange(n) < n - z]
    f = fit_lognormal(x, t)
    assert abs(f.theta - 1.0) < 1e-6
    assert abs(f.beta - d / stats.norm.ppf(1 - z / n)) < 1e-5
    assert f.n_per_level == [n, n] and f.z_per_level == [z, n - z]


def test_degenerate_cases():
    x = np.array([1.0, 2.0, 3.0, 4.0])
    assert fit_lognormal(x, [1, 1, 1, 1]).status == "all_toppled"
    f = fit_lognormal(x, [0, 0, 0, 0])
    assert f.status == "none_toppled" and math.isnan(f.theta) and not f.converged
    f = fit_lognormal(x, [0, 0, 1, 1])
    assert f.status == "separated" and f.beta == 0.0 and 2.0 < f.theta < 3.0 and not f.converged


def test_surface_recovers_coefficients():
    rng = np.random.default_rng(3)
    pga = rng.uniform(1, 10, 3000)
    r = rng.uniform(0.05, 0.5, 3000)
    b = np.array([-1.0, 2.0, 1.5])
    t = rng.uniform(size=pga.size) < stats.norm.cdf(b[0] + b[1] * np.log(pga) + b[2] * np.log(r))
    s = fit_surface(pga, r, t)
    assert s.converged
    assert np.allclose(s.coef, b, atol=0.25)
    assert abs(math.log(s.median_pga(0.2) / math.exp(-(b[0] + b[2] * math.log(0.2)) / b[1]))) < 0.1


def test_fit_catalog_and_compare():
    rng = np.random.default_rng(5)
    rows = []
    for eng, th in (("housner", 3.0), ("mujoco", 3.3)):
        for lv in np.geomspace(1, 9, 10):
            for _ in range(30):
                rows.append({"engine": eng, "profile": "", "settings": "{}", "rock_id": "r", "status": "ok",
                             "pga": lv, "pgv": lv * 0.2, "pgv_pga": 0.2,
                             "toppled": bool(rng.uniform() < stats.norm.cdf(np.log(lv / th) / 0.3))})  # fmt: skip
    fits = fit_catalog(pd.DataFrame(rows))
    assert set(fits["im"]) == {"pga", "pgv", "surface"}
    cmp = compare_medians(fits, "housner")
    assert len(cmp) == 1 and abs(cmp["rel_diff"].iloc[0] - 0.1) < 0.07
