"""The vector fragility (PGA × PGV/PGA) under a PGA hazard with a stated PGV/PGA model (issue 25, item 5)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate, stats

from pbr_xval.hazard import Age, survival_probability
from pbr_xval.hazard.config import load_config
from pbr_xval.hazard.ims import G, HazardInputError
from pbr_xval.hazard.vector import PgvPgaModel, VectorFragility

COEF = (-2.0, 3.2, 1.4)  # Φ(b0 + b1 ln PGA[m/s²] + b2 ln(PGV/PGA)[s])


@pytest.mark.parametrize("slope", [0.0, -0.2])
def test_pga_fragility_is_the_expectation_over_the_ratio(slope):
    m = PgvPgaModel(0.09, 0.4, slope)
    v = VectorFragility("r", COEF)
    f = v.on_pga(m)
    for a in (0.5, 1.5, 3.0, 6.0):
        mu = math.log(0.09) + slope * math.log(a / G)

        def integrand(z, a=a, mu=mu):
            return v.probability(a, math.exp(mu + 0.4 * z)) * stats.norm.pdf(z)

        ref = integrate.quad(integrand, -12, 12, limit=200)[0]
        assert float(f.probability(a)) == pytest.approx(ref, abs=1e-9)
    # Monte Carlo, independent of quad
    rng = np.random.default_rng(5)
    a = 2.0
    r = np.exp(math.log(0.09) + slope * math.log(a / G) + 0.4 * rng.standard_normal(400_000))
    mc = stats.norm.cdf(COEF[0] + COEF[1] * math.log(a) + COEF[2] * np.log(r)).mean()
    assert float(f.probability(a)) == pytest.approx(mc, abs=3e-3)


def test_a_ratio_without_scatter_is_the_vector_median_line():
    v = VectorFragility("r", COEF)
    f = v.on_pga(PgvPgaModel(0.12, 0.0))
    # σ = 0: θ is the vector fit's median PGA at PGV/PGA = 0.12 s, β = 1/b1
    assert f.theta == pytest.approx(math.exp(-(COEF[0] + COEF[2] * math.log(0.12)) / COEF[1]))
    assert f.beta == pytest.approx(1 / COEF[1])
    with pytest.raises(HazardInputError, match="expected > 0"):
        v.on_pga(PgvPgaModel(0.1, 0.3, slope=-3.0))  # b1 + b2·slope < 0


def test_constrain_file_with_a_vector_fragility(tmp_path):
    x = np.geomspace(0.01, 3.0, 30)
    (tmp_path / "h.csv").write_text(
        "pga_g,annual_rate\n" + "".join(f"{a:.8g},{2e-4 * a**-2.0:.8g}\n" for a in x)
    )
    rock = f'[[rock]]\nid = "V"\nvector_coef = {list(COEF)}\nage = 10000.0\nage_sd = 1000.0\n'
    p = tmp_path / "c.toml"
    p.write_text('[hazard]\n[[hazard.branch]]\nfile = "h.csv"\n' + rock)
    with pytest.raises(HazardInputError, match=r"needs a PGV/PGA model; expected \[hazard.pgv_pga\]"):
        load_config(p)
    p.write_text(
        '[hazard]\npgv_pga = { median_s = 0.09, sigma_ln = 0.4, source = "GMM medians, M6.5 at 10 km" }\n'
        '[[hazard.branch]]\nfile = "h.csv"\n' + rock
    )
    cfg = load_config(p)
    f = cfg.rocks[0].fragility
    assert f.im == "PGA" and any("PGV/PGA given PGA" in n and "GMM medians" in n for n in cfg.notes)
    ref = VectorFragility("V", COEF).on_pga(PgvPgaModel(0.09, 0.4))
    assert f.theta == pytest.approx(ref.theta) and f.beta == pytest.approx(ref.beta)
    ps = survival_probability(f, cfg.branches[0], Age(10000.0, 1000.0))
    assert 0 < ps < 1
