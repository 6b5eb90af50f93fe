"""Traps refused (issue 25, item 1): a hazard curve that starts where the rock already topples, a cut
tail with significant rate, branch weights that do not sum to 1, fractiles from one branch."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy import optimize, stats

from pbr_xval.cli.hazard_impl import constrain_command
from pbr_xval.hazard import Age, HazardCurve, LognormalFragility, RockInput, constrain, survival_probability
from pbr_xval.hazard.config import load_config
from pbr_xval.hazard.ims import G, HazardInputError
from pbr_xval.hazard.survival import truncation_check


class _Quiet:
    def __init__(self):
        self.lines = []

    def print(self, *a, **k):
        self.lines.append(" ".join(str(x) for x in a))


# The measured case: a curve whose lowest level is 0.25 g, where P_f = 0.32, gave P_s = 0.370;
# the full curve 0.192. Rebuilt here in closed form: λ = λ₁·(x/x₁)^−k, lognormal θ = 0.30 g with β set so
# that P_f(0.25 g) = 0.32, k so that ν_trunc/ν_full = ln 0.370 / ln 0.192, the age so that P_s = 0.192.
Z1 = float(stats.norm.ppf(0.32))
THETA = 0.30 * G
BETA = math.log(0.25 / 0.30) / Z1
X1 = 0.25 * G


def _ratio(a: float) -> float:
    # ν_trunc/ν_full for a power law of exponent k = a/β (closed form, z = ln(x/θ)/β):
    # ν_full ∝ e^{a²/2}; ν_trunc ∝ P_f(x₁)e^{−a z₁} + e^{a²/2} Φ(−z₁ − a)
    return 0.32 * math.exp(-a * Z1 - a * a / 2) + stats.norm.cdf(-Z1 - a)


A = optimize.brentq(lambda a: _ratio(a) - math.log(0.370) / math.log(0.192), 0.1, 5.0)
K = A / BETA


def _curve(lo_g: float, tail: str = "powerlaw") -> HazardCurve:
    x = np.geomspace(lo_g * G, 3.0 * G, 40)
    return HazardCurve("PGA", x, 1e-3 * (x / X1) ** -K, name=f"from {lo_g:g} g", tail=tail)


FRAG = LognormalFragility("PGA", "rock", theta=THETA, beta=BETA)
NU_FULL = 1e-3 * (THETA / X1) ** -K * math.exp(A * A / 2)  # Cornell's closed form (λ(x₁) = 1e-3)
AGE = Age(-math.log(0.192) / NU_FULL, 0.0, "fixed")


def test_the_measured_case_is_reproduced_and_refused():
    full, trunc = _curve(0.005), _curve(0.25)
    assert float(FRAG.probability(trunc.levels[0])) == pytest.approx(0.32, abs=1e-12)
    assert round(survival_probability(FRAG, full, AGE), 3) == 0.192
    assert round(survival_probability(FRAG, trunc, AGE), 3) == 0.370  # what constrain used to report
    rock = RockInput("rock", FRAG, AGE)
    with pytest.raises(HazardInputError) as ei:
        constrain([trunc], [rock])
    msg = str(ei.value)
    assert "\n" not in msg
    assert "starts at 0.25 g where rock 'rock' already topples with P_f = 0.32 > 0.01" in msg
    # the bias figures: the reported value is an upper bound; the lowest segment continued below gives
    # the full curve's answer (the curve is a power law, so the continuation is exact here)
    assert "P_s = 0.370 is an upper bound" in msg and "gives 0.192" in msg
    assert "allow_truncated_curve = true" in msg
    ck = truncation_check(FRAG, trunc, AGE)
    assert ck.low_flag and not ck.high_flag
    assert ck.nu + ck.nu_below == pytest.approx(NU_FULL, rel=1e-4)
    # the full curve passes, and allowing the truncated one runs with a loud warning
    assert constrain([full], [rock]).warnings == []
    res = constrain([trunc], [rock], allow_truncated=True)
    assert res.warnings and res.warnings[0].startswith("TRUNCATED HAZARD CURVE (allowed)")
    assert round(res.summary["rock_survival"]["rock"], 3) == 0.370


def _write_oq_free(tmp_path, curves: dict[str, HazardCurve], toml: str):
    for name, c in curves.items():
        lines = ["pga_g,annual_rate"] + [
            f"{x / G:.10g},{r:.10g}" for x, r in zip(c.levels, c.rates, strict=True)
        ]
        (tmp_path / name).write_text("\n".join(lines) + "\n")
    (tmp_path / "f.csv").write_text(f"id,im,unit,theta,beta\nrock,PGA,g,{THETA / G!r},{BETA!r}\n")
    p = tmp_path / "c.toml"
    p.write_text(toml)
    return p


ROCK = f'[[rock]]\nid = "rock"\nfragility = "f.csv"\nage = {AGE.mean!r}\nage_dist = "fixed"\n'


def test_cli_refuses_then_warns_with_the_option(tmp_path):
    base = '[hazard]\n[[hazard.branch]]\nfile = "h.csv"\n'
    p = _write_oq_free(tmp_path, {"h.csv": _curve(0.25)}, base + ROCK)
    con = _Quiet()
    assert constrain_command(p, tmp_path / "out", console=con) == 2
    assert "P_f = 0.32" in con.lines[-1] and not (tmp_path / "out").exists()
    p.write_text("allow_truncated_curve = true\n" + base + ROCK)
    con = _Quiet()
    assert constrain_command(p, tmp_path / "out", console=con) == 0
    assert any(line.startswith("[bold yellow]WARNING") and "upper bound" in line for line in con.lines)
    page = (tmp_path / "out" / "index.html").read_text()
    assert 'class="warning"' in page and "upper bound" in page
    s = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert s["truncation"][0]["pf_low"] == pytest.approx(0.32) and s["warnings"]
    assert s["truncation"][0]["ps_extended"] == pytest.approx(0.192, abs=5e-4)


def test_cut_tail_with_significant_rate_is_refused():
    # the curve stops at θ (P_f = 0.5) with tail 'cut': half of every event above it is unaccounted for
    x = np.geomspace(0.01 * G, THETA, 30)
    c = HazardCurve("PGA", x, 1e-3 * (x / X1) ** -K, name="short", tail="cut")
    rock = RockInput("rock", FRAG, AGE)
    with pytest.raises(HazardInputError, match=r"stops at 0.3 g \(tail 'cut'\) where 1 − P_f = 0.50") as ei:
        constrain([c], [rock])
    assert "\n" not in str(ei.value)
    # the same curve with its power-law tail is a stated model: accepted, its share reported
    c2 = HazardCurve("PGA", x, c.rates, name="short", tail="powerlaw")
    ck = truncation_check(FRAG, c2, AGE)
    assert not ck.high_flag and ck.top_share == pytest.approx(0.5 * float(c.rates[-1]) * AGE.mean)
    constrain([c2], [rock])


def test_weights_must_sum_to_one(tmp_path):
    b = '[[hazard.branch]]\nfile = "h.csv"\nweight = 5.0\n[[hazard.branch]]\nfile = "h2.csv"\nweight = 0.5\n'
    h2 = HazardCurve("PGA", _curve(0.005).levels, 2 * _curve(0.005).rates)
    p = _write_oq_free(tmp_path, {"h.csv": _curve(0.005), "h2.csv": h2}, "[hazard]\n" + b + ROCK)
    with pytest.raises(
        HazardInputError, match=r"branch weights sum to 5.5; expected 1 .*normalize_weights"
    ) as ei:
        load_config(p)
    assert "\n" not in str(ei.value)
    p.write_text("normalize_weights = true\n[hazard]\n" + b + ROCK)
    cfg = load_config(p)
    assert any("rescaled" in n for n in cfg.notes)
    np.testing.assert_allclose(constrain(cfg.branches, cfg.rocks).prior, [5 / 5.5, 0.5 / 5.5])
    p.write_text(
        '[hazard]\n[[hazard.branch]]\nfile = "h.csv"\nweight = 0.5\n[[hazard.branch]]\nfile = "h2.csv"\n'
        + ROCK
    )
    with pytest.raises(HazardInputError, match="weights given for 1 of 2 branches"):
        load_config(p)
    p.write_text('normalize_weights = "yes"\n[hazard]\n' + b + ROCK)
    with pytest.raises(HazardInputError, match="key 'normalize_weights': 'yes'; expected true or false"):
        load_config(p)


def test_one_branch_has_no_fractiles(tmp_path):
    p = _write_oq_free(
        tmp_path,
        {"h.csv": _curve(0.005)},
        'quantiles = [0.05, 0.95]\n[hazard]\n[[hazard.branch]]\nfile = "h.csv"\n' + ROCK,
    )
    with pytest.raises(
        HazardInputError, match=r"with 1 hazard branch; fractiles need at least 2 branches"
    ) as ei:
        load_config(p)
    assert "\n" not in str(ei.value)
    p.write_text('[hazard]\n[[hazard.quantile]]\nfile = "h.csv"\nq = 0.5\n' + ROCK)
    with pytest.raises(HazardInputError, match=r"one fractile curve \(q = 0.5\) is not a distribution"):
        load_config(p)
    p.write_text('rate_of_interest = 1e-4\n[hazard]\n[[hazard.branch]]\nfile = "h.csv"\n' + ROCK)
    con = _Quiet()
    assert constrain_command(p, tmp_path / "out", console=con) == 0
    text = "\n".join(con.lines)
    assert "nan" not in text and "one branch: no fractile range" in text
    assert "one branch: no range" in (tmp_path / "out" / "index.html").read_text()
