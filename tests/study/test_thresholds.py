"""Threshold study: Housner's 5.638 m/s² and a non-monotonic (two-band) case."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pbr_xval.conformance import HOUSNER_THRESHOLD, housner_scenario
from pbr_xval.runner import run_scenario
from pbr_xval.study import thresholds
from pbr_xval.study.base import StudyResult


def test_housner_minimum_and_tables() -> None:
    cfg = thresholds.ThresholdsConfig(lo=5.5, hi=5.8, n_grid=3, rel_tol=1e-4, reference=HOUSNER_THRESHOLD)
    res = thresholds.run(cfg, housner_scenario(), ["housner", "no_such_engine"])
    assert isinstance(res, StudyResult)
    tab = res.tables["thresholds"].set_index("engine")
    a = tab.loc["housner", "minimum_m_s2"]
    assert abs(a / HOUSNER_THRESHOLD - 1) <= 5e-4, a
    assert tab.loc["housner", "tolerance_m_s2"] <= 1e-3
    assert tab.loc["housner", "n_bands"] == 1
    assert tab.loc["housner", "rel_error_vs_reference_engine"] == 0.0
    assert tab.loc["no_such_engine", "status"] == "skipped"
    assert any("no_such_engine" in n for n in res.notes)
    assert res.headline["housner"] == pytest.approx(a)
    bands = res.tables["bands"]
    assert len(bands) == 1 and math.isnan(bands["band_end_m_s2"].iloc[0])
    assert res.provenance["scenario_hash"] == housner_scenario().content_hash()
    assert "housner" in res.provenance["versions"]
    assert res.figures and res.figures[0].table == "thresholds"
    assert any("housner" in line for line in res.summary)


def test_non_monotonic_two_bands() -> None:
    """Makris & Roussos type-B (one-cosine) pulse, f = 2 Hz, on Housner's block: the block topples
    (after an impact) at ~11–16 m/s², survives above — passing its critical tilt and being pulled
    back by the reversing pulse from ~28 m/s² on — and topples again (no impact) from ~52 m/s²."""
    scn = housner_scenario(
        duration=3.0, excitation={"type": "one_cosine", "amplitude": 12.0, "frequency": 2.0}
    )
    fast = {"omega_rest": 1e-3}
    cfg = thresholds.ThresholdsConfig(
        lo=8.0, hi=70.0, n_grid=12, rel_tol=1e-3, reference_engine="housner", settings={"housner": fast}
    )
    res = thresholds.run(cfg, scn, ["housner"])
    bands = res.tables["bands"]
    assert len(bands) == 2, bands
    assert res.tables["thresholds"]["n_bands"].iloc[0] == len(bands)
    b0, b1 = bands.iloc[0], bands.iloc[1]
    assert 10.0 < b0["band_start_m_s2"] < 12.0 and 15.0 < b0["band_end_m_s2"] < 17.0
    assert 45.0 < b1["band_start_m_s2"] < 60.0 and math.isnan(b1["band_end_m_s2"])

    def run(a: float, **kw: object) -> object:  # default settings: the fast rest detection changes nothing
        return run_scenario(scn.with_value("excitation.amplitude", a), "housner", **kw)

    def topples(a: float) -> bool:
        return run(a).toppled

    s0, e0, s1 = b0["band_start_m_s2"], b0["band_end_m_s2"], b1["band_start_m_s2"]
    assert not topples(s0 * 0.995) and topples(s0 * 1.005)
    assert topples(0.5 * (s0 + e0)) and topples(e0 * 0.995) and not topples(e0 * 1.005)
    assert not topples(20.0)
    # inside the safe band the block passes its critical tilt and is pulled back: not toppled
    traj = run(35.0)
    alpha = math.atan(0.2 / 0.6)
    assert not traj.toppled and np.max(np.abs(traj.rocking_angle())) > 1.2 * alpha
    assert topples(s1 * 1.01) and topples(65.0)
    assert res.headline["housner"] == pytest.approx(s0)
    fig = res.figures[0].figure
    assert len(fig.axes) == 2  # band panel drawn when there is more than one band
    assert np.isfinite(res.tables["thresholds"]["minimum_m_s2"].iloc[0])
