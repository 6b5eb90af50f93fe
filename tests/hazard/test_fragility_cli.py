"""`pbr-xval fragility` on a real (tiny) Housner sweep, and SA(T) recomputed from the catalog."""

from __future__ import annotations

import csv
import math

import numpy as np
import pytest

from pbr_xval.cli.hazard_impl import fragility_command
from pbr_xval.hazard.nrml import read_fragility_model

CAT = """name = "tiny_msa"
seed = 11
duration = 2.5
engines = ["housner"]
chunk_size = 8

[settings.housner]
rtol = 1e-7
atol = 1e-9

[[rock]]
id = "blk"
shape = "box"
half_extents = [0.15, 0.15, 0.6]
density = 2400.0
friction = 2.0

[motions]
[[motions.pulse]]
type = "half_sine"
amplitude = [3.0, 5.0, 8.0]
frequency = [1.0, 2.0]
"""


class _Quiet:
    def __init__(self):
        self.lines = []

    def print(self, *a, **k):
        self.lines.append(" ".join(str(x) for x in a))


@pytest.fixture(scope="module")
def sweep(tmp_path_factory):
    from pbr_xval.catalog import load_catalog, run_sweep

    d = tmp_path_factory.mktemp("msa")
    (d / "cat.toml").write_text(CAT)
    s = run_sweep(load_catalog(d / "cat.toml"), d / "out", executor="inline")
    assert not s.failed
    return d


def test_sa_from_catalog_physics(sweep):
    from pbr_xval.catalog import load_catalog
    from pbr_xval.hazard.fit import sweep_intensity_measures

    im = sweep_intensity_measures(load_catalog(sweep / "cat.toml"), [0.01, 1.0]).set_index("motion_id")
    # a stiff oscillator (T = 0.01 s ≪ the 0.5–1 s pulse) follows the ground: SA → PGA (measured 0.05 %)
    np.testing.assert_allclose(im["SA(0.01)"], im["PGA"], rtol=2e-3)
    # linear oscillator: SA scales with the amplitude; PGV of a half-sine = A/(π f)
    r = im.loc["half_sine_a8_f1", "SA(1.0)"] / im.loc["half_sine_a3_f1", "SA(1.0)"]
    assert r == pytest.approx(8.0 / 3.0, rel=1e-9)
    assert im.loc["half_sine_a5_f2", "PGV"] == pytest.approx(5.0 / (math.pi * 2.0), rel=1e-9)


def test_fragility_command_writes_fits_and_nrml(sweep, tmp_path):
    con = _Quiet()
    code = fragility_command(sweep / "out", sweep / "cat.toml", [0.5, 1.0], out=tmp_path, console=con)
    rows = list(csv.DictReader((tmp_path / "fits.csv").read_text().splitlines()))
    ims = {r["im"] for r in rows}
    assert ims == {"PGA", "PGV", "SA(0.5)", "SA(1.0)", "PGA|PGV/PGA"}
    assert (tmp_path / "im_comparison.csv").exists()
    assert any("IMs by dispersion" in line for line in con.lines)
    ok = [r for r in rows if r["status"] == "ok" and r["im"] != "PGA|PGV/PGA"]
    # PGA stripes 3, 5, 8 m/s² topple 0/2, 1/2, 2/2: at least PGA has a converged fit
    assert code == 0 and any(r["im"] == "PGA" for r in ok)
    # the console in the field's units: PGA θ in g (SI in brackets), PGV in cm/s
    pga = next(r for r in ok if r["im"] == "PGA")
    line = next(ln for ln in con.lines if " PGA: θ = " in ln)
    assert f"θ = {float(pga['theta']) / 9.80665:.4g} g ({float(pga['theta']):.4g} m/s²)" in line
    fr = read_fragility_model(tmp_path / "fragility.xml")  # the NRML carries exactly the converged fits

    def fid(im):
        return f"blk__{im}".replace("(", "_").replace(")", "_").replace(".", "_")

    assert {fid(r["im"]) for r in ok} == set(fr)
    for r in ok:
        assert fr[fid(r["im"])].theta == pytest.approx(float(r["theta"]), rel=1e-8)


def test_fragility_command_bad_input(tmp_path):
    con = _Quiet()
    assert fragility_command(tmp_path / "nope", None, [], console=con) == 2
    assert "results folder not found" in con.lines[-1]
    assert fragility_command(tmp_path, None, [1.0], console=con) == 2
    assert "--period needs --catalog" in con.lines[-1]
    assert fragility_command(tmp_path, None, [-1.0], console=con) == 2
