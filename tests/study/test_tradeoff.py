from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from pbr_xval.conformance import housner_scenario
from pbr_xval.study.tradeoff import TradeoffConfig, pareto_front, recommend, run

CRASHY = str(Path(__file__).with_name("_crashy_engine.py"))


def test_pareto_front_synthetic():
    cost = [1.0, 2.0, 3.0, 0.5, 2.5, math.nan, 4.0]
    err = [0.10, 0.01, 0.001, 0.2, 0.02, 0.0, 0.001]
    mask = pareto_front(cost, err)
    # (2.5, 0.02) is dominated by (2.0, 0.01); (4.0, 0.001) by (3.0, 0.001); NaN never on the front
    assert mask.tolist() == [True, True, True, True, False, False, False]
    assert pareto_front([], []).size == 0


def test_recommend_picks_cheapest_within_budget():
    pts = pd.DataFrame(
        {
            "engine": ["a", "a", "a", "b", "b"],
            "setting": ["dt=1e-2", "dt=1e-3", "dt=1e-4", "x", "y"],
            "wall_s_per_sim": [0.01, 0.1, 1.0, 0.5, 0.2],
            "rel_error": [-0.03, 0.008, 0.0001, 0.001, -0.015],
        }
    )
    pts["abs_rel_error"] = pts["rel_error"].abs()
    rec = recommend(pts, [0.005, 0.01, 0.02, 0.05])
    a = rec[rec.engine == "a"].set_index("budget")["setting"].to_dict()
    assert a == {0.005: "dt=1e-4", 0.01: "dt=1e-3", 0.02: "dt=1e-3", 0.05: "dt=1e-2"}
    b = rec[rec.engine == "b"].set_index("budget")["setting"].to_dict()
    assert b[0.005] == "x" and b[0.02] == "y"
    rec2 = recommend(pts[pts.engine == "b"], [1e-4])
    assert rec2.iloc[0]["setting"] is None


def test_study_records_failures_and_out_of_range():
    # a rock that never topples (out of range) and an engine that segfaults: both recorded
    cfg = TradeoffConfig(
        reference=5.638,
        timesteps=[1e-3],
        iterations={},
        profiles=["faithful"],
        n_grid=2,
        timeout_per_point=60,
    )
    res = run(
        cfg, housner_scenario(duration=0.2), [f"{CRASHY}:StillEngine", f"{CRASHY}:SegfaultEngine", "nope"]
    )
    pts = res.tables["tradeoff_points"].set_index("engine")
    assert pts.loc["still", "status"] == "out_of_range"
    assert pts.loc["segfault", "status"] == "crash"
    assert any("nope" in n for n in res.notes)
    assert (
        res.tables["tradeoff_recommendations"].empty
        or res.tables["tradeoff_recommendations"]["setting"].isna().all()
    )
    assert res.figures and res.figures[0].table == "tradeoff_points"


@pytest.mark.slow
def test_real_sweep_mujoco():
    cfg = TradeoffConfig(reference=5.638, timesteps=[2e-3, 1e-3], iterations={}, lo=5.4, hi=6.0, n_grid=3)
    res = run(cfg, housner_scenario(), ["mujoco"])
    pts = res.tables["tradeoff_points"]
    assert (pts["status"] == "ok").all(), pts
    faithful = pts[(pts.profile == "faithful") & np.isclose(pts.timestep_s, 1e-3)].iloc[0]
    assert abs(faithful["rel_error"]) <= 5e-3
    default = pts[(pts.profile == "engine-default") & np.isclose(pts.timestep_s, 1e-3)].iloc[0]
    assert abs(default["threshold"] - faithful["threshold"]) > 2 * faithful["tolerance"]
    rec = res.tables["tradeoff_recommendations"]
    assert set(rec.budget) == {0.005, 0.01, 0.02} and rec.setting.notna().all()
    assert any(line.startswith("mujoco: ≤ 0.5%") for line in res.summary)


def test_cost_prediction_separates_fixed_and_per_step_cost():
    from pbr_xval.study.tradeoff import _predict_cost

    assert _predict_cost([(1e-2, 1.0), (1e-3, 2.0)], 1e-4) == pytest.approx(12.0)
    assert _predict_cost([(1e-2, 1.0)], 1e-3) == pytest.approx(5.5)
