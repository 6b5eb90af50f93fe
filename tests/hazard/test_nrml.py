"""NRML fragilityModel: (θ, β) ↔ moments both ways, round trip through an independent parser,
a hand-written snippet in the OpenQuake manual's format."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from pbr_xval.hazard import DiscreteFragility, LognormalFragility, lognormal_to_moments, moments_to_lognormal
from pbr_xval.hazard.ims import G, HazardInputError
from pbr_xval.hazard.nrml import (
    read_fragility_csv,
    read_fragility_model,
    write_fragility_csv,
    write_fragility_model,
)


def test_moments_match_scipy_lognormal_both_ways():
    from scipy import stats

    for theta, beta in [(0.3, 0.25), (2.5, 0.6), (10.0, 1.2)]:
        d = stats.lognorm(beta, scale=theta)  # independent: scipy's mean and std of the lognormal
        m, s = lognormal_to_moments(theta, beta)
        assert m == pytest.approx(d.mean(), rel=1e-12) and s == pytest.approx(d.std(), rel=1e-12)
        th2, b2 = moments_to_lognormal(d.mean(), d.std())
        assert th2 == pytest.approx(theta, rel=1e-12) and b2 == pytest.approx(beta, rel=1e-12)


def test_moments_from_hand_computation():
    # θ = 1, β = ln 2 ... use β² = ln 2: mean = exp(ln2/2) = √2, stddev = √2·√(2 − 1) = √2
    b = math.sqrt(math.log(2.0))
    m, s = lognormal_to_moments(1.0, b)
    assert m == pytest.approx(math.sqrt(2.0), rel=1e-14) and s == pytest.approx(math.sqrt(2.0), rel=1e-14)
    assert moments_to_lognormal(math.sqrt(2.0), math.sqrt(2.0)) == pytest.approx((1.0, b), rel=1e-14)


def _independent_parse(path):
    """A second reader, written here from the format description (not the package's reader)."""
    ns = {"n": "http://openquake.org/xmlns/nrml/0.5"}
    root = ET.parse(path).getroot()
    assert root.tag == "{http://openquake.org/xmlns/nrml/0.5}nrml"
    fm = root.find("n:fragilityModel", ns)
    assert fm.find("n:limitStates", ns).text.split() == ["topple"]
    out = {}
    for ff in fm.findall("n:fragilityFunction", ns):
        imls = ff.find("n:imls", ns)
        if ff.get("format") == "continuous":
            p = ff.find("n:params", ns)
            out[ff.get("id")] = ("continuous", imls.get("imt"), float(p.get("mean")), float(p.get("stddev")))
        else:
            x = [float(v) for v in imls.text.split()]
            y = [float(v) for v in ff.find("n:poes", ns).text.split()]
            out[ff.get("id")] = ("discrete", imls.get("imt"), x, y)
    return out


def test_round_trip_continuous_and_discrete(tmp_path):
    frs = [LognormalFragility("PGA", "rock A", theta=0.3 * G, beta=0.35),
           LognormalFragility("PGV", "rock_B", theta=0.42, beta=0.5),
           LognormalFragility("SA(1.0)", "rock_C", theta=0.6 * G, beta=0.4)]  # fmt: skip
    p = write_fragility_model(tmp_path / "c.xml", frs, "continuous")
    ind = _independent_parse(p)
    # ids sanitised; units: g for PGA/SA, cm/s for PGV; mean/stddev are linear moments
    assert ind["rock_A"][:2] == ("continuous", "PGA")
    m = 0.3 * math.exp(0.35**2 / 2)
    assert ind["rock_A"][2] == pytest.approx(m, rel=1e-9)
    assert ind["rock_A"][3] == pytest.approx(m * math.sqrt(math.expm1(0.35**2)), rel=1e-9)
    assert ind["rock_B"][1] == "PGV" and ind["rock_B"][2] == pytest.approx(42.0 * math.exp(0.125), rel=1e-9)
    back = read_fragility_model(p)
    for f in frs:
        g = back[f.id.replace(" ", "_")]
        assert (
            g.im == f.im
            and g.theta == pytest.approx(f.theta, rel=1e-9)
            and g.beta == pytest.approx(f.beta, rel=1e-9)
        )
    p2 = write_fragility_model(tmp_path / "d.xml", frs, "discrete")
    ind2 = _independent_parse(p2)
    kind, imt, x, y = ind2["rock_B"]
    assert kind == "discrete" and imt == "PGV" and len(x) == 25
    np.testing.assert_allclose(y, frs[1].probability(np.array(x) / 100.0), atol=1e-9)  # x in cm/s
    back2 = read_fragility_model(p2)
    xs = np.geomspace(0.2, 0.9, 7)
    np.testing.assert_allclose(back2["rock_B"].probability(xs), frs[1].probability(xs), atol=2e-3)


MANUAL_SNIPPET = """<?xml version="1.0" encoding="UTF-8"?>
<nrml xmlns="http://openquake.org/xmlns/nrml/0.5">
<fragilityModel id="fragility_example" assetCategory="buildings" lossCategory="structural">
  <description>Fragility Model Example</description>
  <limitStates>slight moderate extensive complete</limitStates>
  <fragilityFunction id="Woodframe_TwoStorey" format="discrete">
    <imls imt="PGA" noDamageLimit="0.05">0.005 0.2 0.4 0.6 0.8 1.0 1.2</imls>
    <poes ls="slight">0.00 0.01 0.15 0.84 0.99 1.00 1.00</poes>
    <poes ls="moderate">0.00 0.00 0.01 0.12 0.35 0.57 0.74</poes>
    <poes ls="extensive">0.00 0.00 0.00 0.08 0.19 0.32 0.45</poes>
    <poes ls="complete">0.00 0.00 0.00 0.06 0.17 0.26 0.35</poes>
  </fragilityFunction>
  <fragilityFunction id="RC_LowRise" format="continuous" shape="logncdf">
    <imls imt="SA(0.3)" noDamageLimit="0.05" minIML="0.0" maxIML="5.0"/>
    <params ls="slight" mean="0.50" stddev="0.10"/>
    <params ls="moderate" mean="1.00" stddev="0.40"/>
    <params ls="extensive" mean="1.50" stddev="0.90"/>
    <params ls="complete" mean="2.00" stddev="1.60"/>
  </fragilityFunction>
</fragilityModel>
</nrml>
"""


def test_reads_the_manuals_example(tmp_path):
    p = tmp_path / "manual.xml"
    p.write_text(MANUAL_SNIPPET)
    with pytest.raises(HazardInputError, match="limit states"):
        read_fragility_model(p)  # four limit states, none called topple: must choose
    fs = read_fragility_model(p, "moderate")
    rc = fs["RC_LowRise"]
    # by hand: mean 1.00 g, stddev 0.40 g → β = √ln(1.16) = 0.38525, θ = 1/√1.16 g
    assert rc.im == "SA(0.3)"
    assert rc.beta == pytest.approx(math.sqrt(math.log(1.16)), rel=1e-12)
    assert rc.theta == pytest.approx(G / math.sqrt(1.16), rel=1e-12)
    wf = fs["Woodframe_TwoStorey"]
    assert isinstance(wf, DiscreteFragility)
    # 0.5 g is halfway between 0.4 g (0.01) and 0.6 g (0.12); below noDamageLimit 0.05 g → 0
    assert float(wf.probability(0.5 * G)) == pytest.approx(0.065, abs=1e-12)
    assert float(wf.probability(0.04 * G)) == 0.0


def test_csv_round_trip(tmp_path):
    rows = [{"id": "a", "im": "pga", "theta": 2.9, "beta": 0.33, "status": "ok", "theta_lo": 2.5, "theta_hi": 3.4,
             "beta_lo": 0.25, "beta_hi": 0.45},
            {"id": "b", "im": "SA(1.0)", "theta": 4.0, "beta": 0.5, "status": "separated"}]  # fmt: skip
    p = write_fragility_csv(tmp_path / "f.csv", rows)
    text = p.read_text().splitlines()
    assert text[0].startswith("id,im,unit,theta,beta,mean,stddev")
    fs = read_fragility_csv(p)
    assert list(fs) == ["a"] and fs["a"].theta == pytest.approx(2.9) and fs["a"].beta == pytest.approx(0.33)
    assert fs["a"].theta_ci == pytest.approx((2.5, 3.4)) and fs["a"].beta_ci == pytest.approx((0.25, 0.45))
    bad = tmp_path / "bad.csv"
    bad.write_text("id,im,unit,theta,beta\nx,PGA,g,-1,0.3\n")
    with pytest.raises(HazardInputError, match=r"bad.csv line 2: fragility 'x': median θ = -9.80665"):
        read_fragility_csv(bad)


@pytest.mark.parametrize(
    "text,match",
    [
        ("", "empty file"),
        ("<nrml><foo/></nrml>", "no <fragilityModel>"),
        (
            '<nrml><fragilityModel><limitStates>topple</limitStates><fragilityFunction id="x" format="continuous">'
            '<imls imt="MMI"/><params ls="topple" mean="1" stddev="1"/></fragilityFunction></fragilityModel></nrml>',
            "fragilityFunction 'x': field 'imt'.*unknown intensity measure 'MMI'",
        ),
        (
            '<nrml><fragilityModel><limitStates>topple</limitStates><fragilityFunction id="x" format="continuous">'
            '<imls imt="PGA"/><params ls="topple" mean="-1" stddev="1"/></fragilityFunction></fragilityModel></nrml>',
            "mean = -1, stddev = 1; expected both > 0",
        ),
    ],
)
def test_bad_nrml_one_line_errors(tmp_path, text, match):
    p = tmp_path / "bad.xml"
    p.write_text(text)
    with pytest.raises(HazardInputError, match=match) as ei:
        read_fragility_model(p)
    msg = str(ei.value)
    assert "\n" not in msg and str(p) in msg


def test_continuous_span_and_discretisation_note_suit_a_pbr(tmp_path):
    # OpenQuake discretises [minIML, maxIML] into continuous_fragility_discretization (default 20) linear
    # levels; θ·e^∓5β with 20 levels stepped 0.09 g around a 0.3 g median (β 0.35). Now θ·e^∓3β, rounded
    # outwards, with the number of levels that keeps each step ≤ θβ/5 written in the description.
    from scipy import stats

    from pbr_xval.hazard.nrml import recommended_discretization

    frs = [
        LognormalFragility("PGA", "a", theta=0.3 * G, beta=0.35),
        LognormalFragility("PGV", "v", theta=0.42, beta=0.25),
    ]
    p = write_fragility_model(tmp_path / "c.xml", frs, "continuous")
    ns = {"n": "http://openquake.org/xmlns/nrml/0.5"}
    root = ET.parse(p).getroot()
    desc = root.find("n:fragilityModel/n:description", ns).text
    n = recommended_discretization(frs)
    assert f"continuous_fragility_discretization = {n}" in desc and n > 20
    for ff, f in zip(root.iter("{http://openquake.org/xmlns/nrml/0.5}fragilityFunction"), frs, strict=True):
        imls = ff.find("n:imls", ns)
        lo, hi = float(imls.get("minIML")), float(imls.get("maxIML"))
        unit = 100.0 if f.im == "PGV" else 1.0 / G  # cm/s per m/s, g per m/s²
        th, b = f.theta * unit, f.beta
        # outward rounding to 3 significant digits of θ·e^∓3β: P_f(min) ≤ 0.00135, P_f(max) ≥ 0.99865
        assert th * math.exp(-3 * b) * 0.99 <= lo <= th * math.exp(-3 * b)
        assert th * math.exp(3 * b) <= hi <= th * math.exp(3 * b) * 1.01
        assert stats.norm.cdf(math.log(lo / th) / b) <= 0.00135
        # OpenQuake's levels with the recommended discretisation: every step ≤ θβ/5
        assert np.diff(np.linspace(lo, hi, n)).max() <= th * b / 5 * (1 + 1e-9)
    # the 0.3 g rock: 20 levels over the old θ·e^∓5β stepped 0.088 g, the new span with n levels ≤ 0.021 g
    a = frs[0]
    assert (0.3 * math.exp(5 * 0.35) - 0.3 * math.exp(-5 * 0.35)) / 19 == pytest.approx(0.088, abs=5e-4)
    assert np.diff(np.linspace(0.104, 0.858, n)).max() <= 0.3 * a.beta / 5 + 1e-12
    # the file still reads back, and its moments are unchanged
    back = read_fragility_model(p)
    assert back["a"].theta == pytest.approx(a.theta, rel=1e-9) and back["a"].beta == pytest.approx(
        a.beta, rel=1e-9
    )
