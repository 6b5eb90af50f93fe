"""Hazard-curve readers: plain CSV, OpenQuake CSV and NRML; poe → rate; bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pbr_xval.hazard import HazardCurve, poe_to_rate, read_hazard_curve, read_hazard_curves
from pbr_xval.hazard.curves import write_curve_csv, write_oq_csv
from pbr_xval.hazard.ims import G, HazardInputError

# The OpenQuake manual's classical-PSHA CSV output (one line of header comment, then lon,lat,depth,poe-…)
OQ_CSV = """#,,,,,"generated_by='OpenQuake engine 3.18.0', start_date='2023-10-03T06:09:08', checksum=2107362341, kind='mean', investigation_time=1.0, imt='PGA'"
lon,lat,depth,poe-0.1000000,poe-0.4000000,poe-0.6000000
0.00000,0.00000,-0.10000,4.553860E-01,5.754042E-02,6.354511E-03
0.10000,0.00000,-0.10000,1.522632E-01,0.000000E+00,0.000000E+00
"""

# NRML 0.4 hazardCurves as in OpenQuake's QA tests (SA with saPeriod, 50-year investigation time)
OQ_XML = """<?xml version="1.0" encoding="utf-8"?>
<nrml xmlns:gml="http://www.opengis.net/gml" xmlns="http://openquake.org/xmlns/nrml/0.4">
    <hazardCurves sourceModelTreePath="b1_b2_b4" gsimTreePath="b1_b2" investigationTime="50.0" IMT="SA" saPeriod="0.025" saDamping="5.0">
        <IMLs>5.0000e-03 7.0000e-03 1.3700e-02</IMLs>
        <hazardCurve>
            <gml:Point><gml:pos>-122.5000 37.5000</gml:pos></gml:Point>
            <poEs>9.8728e-01 9.8266e-01 9.4957e-01</poEs>
        </hazardCurve>
        <hazardCurve>
            <gml:Point><gml:pos>-123.5000 37.5000</gml:pos></gml:Point>
            <poEs>9.8728e-02 9.8266e-02 9.4957e-02</poEs>
        </hazardCurve>
    </hazardCurves>
</nrml>
"""


def test_poisson_conversion_by_hand():
    # poe 0.1 in 50 yr ↔ λ = −ln 0.9 / 50 = 2.1072e-3 /yr (the "475-year" level: 1/474.56)
    assert float(poe_to_rate(0.1, 50.0)) == pytest.approx(1 / 474.5607, rel=1e-6)


def test_openquake_csv(tmp_path):
    p = tmp_path / "hazard_curve-mean-PGA_22.csv"
    p.write_text(OQ_CSV)
    c = read_hazard_curve(p, site=(0.0, 0.0))
    assert c.im == "PGA" and c.name == "mean"
    np.testing.assert_allclose(c.levels, [0.1 * G, 0.4 * G, 0.6 * G])
    np.testing.assert_allclose(
        c.rates, -np.log1p(-np.array([0.455386, 0.05754042, 0.006354511])) / 1.0, rtol=1e-6
    )
    with pytest.raises(HazardInputError, match="2 sites"):
        read_hazard_curve(p)
    # the second site's curve reaches 0: segment to 0 is linear in λ, nothing above
    c2 = read_hazard_curve(p, site=(0.1, 0.0))
    assert c2.rate(0.4 * G)[0] == 0.0 and c2.im_at_rate(1e-9) == pytest.approx(0.4 * G, rel=1e-6)


def test_openquake_nrml(tmp_path):
    p = tmp_path / "hc.xml"
    p.write_text(OQ_XML)
    c = read_hazard_curve(p, site=(-123.4, 37.5))
    assert c.im == "SA(0.025)" and c.name == "b1_b2_b4|b1_b2"
    np.testing.assert_allclose(c.levels, np.array([5e-3, 7e-3, 1.37e-2]) * G)
    np.testing.assert_allclose(c.rates, -np.log1p(-np.array([9.8728e-02, 9.8266e-02, 9.4957e-02])) / 50.0)


def test_plain_csv_and_round_trips(tmp_path):
    x = np.geomspace(0.5, 20.0, 12)
    c = HazardCurve("PGV", x / 10, 1e-3 * x**-2.0, name="b")
    back = read_hazard_curve(write_curve_csv(c, tmp_path / "b.csv"))
    np.testing.assert_allclose(back.levels, c.levels, rtol=1e-9)
    np.testing.assert_allclose(back.rates, c.rates, rtol=1e-9)
    back2 = read_hazard_curve(write_oq_csv(c, tmp_path / "hazard_curve-rlz-001-PGV_0.csv", 50.0))
    assert back2.im == "PGV"
    np.testing.assert_allclose(back2.levels, c.levels, rtol=1e-7)
    np.testing.assert_allclose(back2.rates, c.rates, rtol=1e-5)  # poe written with 7 digits
    p = tmp_path / "g.csv"
    p.write_text("# PGA in g\npga_g,annual_rate\n0.1,1e-2\n0.2,3e-3\n0.4,5e-4\n")
    g = read_hazard_curve(p)
    np.testing.assert_allclose(g.levels, [0.1 * G, 0.2 * G, 0.4 * G])
    # log-log interpolation between nodes is a power law: λ(√(0.1·0.2) g) = √(1e-2·3e-3)
    assert g.rate(math.sqrt(0.02) * G)[0] == pytest.approx(math.sqrt(3e-5), rel=1e-12)
    assert g.im_at_rate(math.sqrt(3e-5)) == pytest.approx(math.sqrt(0.02) * G, rel=1e-12)


@pytest.mark.parametrize(
    "name,text,match",
    [
        ("empty.csv", "", "empty.csv: empty file"),
        ("hdr.csv", "pga_g,annual_rate\n", "no data rows"),
        (
            "nonmono.csv",
            "pga_g,annual_rate\n0.1,1e-2\n0.2,3e-2\n",
            "field 'rates': rate rises from 0.01 at IM",
        ),
        ("neg.csv", "pga_g,annual_rate\n0.1,1e-2\n0.2,-3e-3\n", "field 'rates': negative rate -0.003"),
        ("im.csv", "mmi_g,annual_rate\n6,1e-2\n7,1e-3\n", "IM column 'mmi_g': unknown IM or unit"),
        ("unit.csv", "pgv_g,annual_rate\n6,1e-2\n7,1e-3\n", "unit 'g' does not fit PGV"),
        (
            "lv.csv",
            "pga_g,annual_rate\n0.2,1e-2\n0.1,1e-3\n",
            "field 'levels': 1.96.*then 0.98.*expected strictly increasing",
        ),
        (
            "num.csv",
            "pga_g,annual_rate\n0.1,abc\n0.2,1e-3\n",
            "line 2: field 'annual_rate': 'abc' is not a number",
        ),
        ("oq.csv", OQ_CSV.replace("imt='PGA'", "imt='MMI'"), "unknown intensity measure 'MMI'"),
        ("t.csv", OQ_CSV.replace("investigation_time=1.0, ", ""), "no investigation_time"),
        ("x.xml", OQ_XML.replace('IMT="SA" ', 'IMT="XYZ" '), "unknown intensity measure 'XYZ'"),
        ("e.xml", "", "not well-formed XML"),
    ],
)
def test_bad_input_one_line_naming_file_and_field(tmp_path, name, text, match):
    p = tmp_path / name
    p.write_text(text)
    with pytest.raises(HazardInputError, match=match) as ei:
        read_hazard_curves(p, site=(0.0, 0.0))
    msg = str(ei.value)
    assert "\n" not in msg and name in msg
