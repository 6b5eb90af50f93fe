"""Histories study: self-comparison is exact, Housner's reference run matches the notes, engines agree."""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest

from pbr_xval.conformance import housner_scenario
from pbr_xval.study import histories


@pytest.fixture(scope="module")
def result() -> object:
    engines = ["housner"] + (["mujoco"] if importlib.util.find_spec("mujoco") else [])
    cfg = histories.HistoriesConfig(values={"excitation.amplitude": 5.0})
    return histories.run(cfg, housner_scenario(), engines)


def test_reference_run(result) -> None:
    m = result.tables["histories_metrics"].set_index("engine")
    h = m.loc["housner"]
    assert h["status"] == "ok"
    assert h["uplift_event_t_s"] == pytest.approx(0.0, abs=1e-6)
    assert h["uplift_t_s"] < 0.05
    assert h["impact1_t_s"] == pytest.approx(0.798, abs=1e-3)
    assert h["peak_theta_over_alpha"] == pytest.approx(0.3474, abs=5e-4)
    assert h["rebound1"] == pytest.approx(0.85, abs=2e-3)
    assert h["energy_drift_rel"] < 1e-3


def test_self_comparison_is_zero(result) -> None:
    h = result.tables["histories_metrics"].set_index("engine").loc["housner"]
    for col in (
        "peak_rel_error",
        "rms_theta_err_to_impact1_rad",
        "uplift_dt_s",
        "impact1_dt_s",
        "impact2_dt_s",
        "impact3_dt_s",
        "rebound1_diff",
    ):
        assert h[col] == 0.0, col


def test_tables_and_figures(result) -> None:
    th = result.tables["histories_theta"]
    assert set(th.columns) == {"t", "engine", "theta_over_alpha", "dtheta_over_alpha"}
    assert (th.groupby("engine").size() <= 2000).all()
    assert np.abs(th["theta_over_alpha"]).max() < 1.0
    assert {f.name for f in result.figures} == {"histories_theta", "toppling_theta", "histories_com"}
    assert result.provenance["reference_engine"] == "housner"


@pytest.mark.skipif(importlib.util.find_spec("mujoco") is None, reason="mujoco not installed")
def test_mujoco_close_to_housner(result) -> None:
    m = result.tables["histories_metrics"].set_index("engine").loc["mujoco"]
    assert m["status"] == "ok"
    assert abs(m["peak_rel_error"]) < 0.01
    assert abs(m["impact1_dt_s"]) < 0.01


def test_failure_is_recorded() -> None:
    cfg = histories.HistoriesConfig(values={"duration": 1.0})
    res = histories.run(cfg, housner_scenario(), ["housner", "curved_base", "no_such_engine"])
    m = res.tables["histories_metrics"].set_index("engine")
    assert m.loc["housner", "status"] == "ok"
    assert m.loc["curved_base", "status"] == "skipped"  # a box is not a curved-base rock
    assert m.loc["no_such_engine", "status"] == "skipped"
    assert any("no_such_engine" in n for n in res.notes)
