"""Fragility of ensemble members with its band (issue 22 item 6): a synthetic rock of known θ, β."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy import stats
from typer.testing import CliRunner

from pbr_xval.catalog.fragility import fit_ensemble_fragility
from pbr_xval.cli import app

THETA, BETA = 3.0, 0.4  # m/s², –


def synthetic_members(seed: int, n_tests: int = 30, members: int = 16) -> pd.DataFrame:
    """Tests at log-uniform PGA (3 tests per record); each member topples with P = Φ(ln(x/θ)/β)."""
    rng = np.random.default_rng(seed)
    x = np.exp(rng.uniform(np.log(1.0), np.log(9.0), n_tests))
    p = stats.norm.cdf(np.log(x / THETA) / BETA)
    rows = []
    for j in range(n_tests):
        for m in range(members):
            rows.append(
                {"test": f"t{j}", "record": f"r{j // 3}", "member": m, "engine": "housner",
                 "pga_m_s2": x[j], "pgv_m_s": 0.1 * x[j], "toppled": bool(rng.random() < p[j]), "status": "ok"}
            )  # fmt: skip
    return pd.DataFrame(rows)


def test_band_covers_the_true_fragility() -> None:
    df = synthetic_members(seed=3)
    f = fit_ensemble_fragility(
        df["pga_m_s2"], df["toppled"], df["test"], df["record"], im_name="PGA", n_boot=150, seed=1
    )
    assert f.status == "ok" and f.n_tests == 30 and f.n_groups == 10 and f.members_per_test == 16
    assert f.theta_ci[0] < THETA < f.theta_ci[1]
    assert f.beta_ci[0] < BETA < f.beta_ci[1]
    assert f.theta_profile_ci[0] < f.theta < f.theta_profile_ci[1]
    assert len(f.draws) + f.boot_failed == 150 and len(f.draws) >= 140
    grid = np.array([2.5, 3.0, 4.0])  # around the median (a pointwise 95 % band may miss a far tail)
    p, lo, hi = f.band(grid)
    truth = stats.norm.cdf(np.log(grid / THETA) / BETA)
    assert np.all(lo <= truth) and np.all(truth <= hi) and np.all(lo <= p) and np.all(p <= hi)


def test_fewer_members_widen_the_band() -> None:
    full = synthetic_members(seed=4, members=16)
    few = full[full["member"] < 2]
    kw = {"im_name": "PGA", "n_boot": 100, "seed": 2}
    a = fit_ensemble_fragility(full["pga_m_s2"], full["toppled"], full["test"], full["record"], **kw)
    b = fit_ensemble_fragility(few["pga_m_s2"], few["toppled"], few["test"], few["record"], **kw)
    width = lambda f: np.log(f.theta_ci[1] / f.theta_ci[0])  # noqa: E731
    assert width(b) > width(a)


def test_degenerate_members_get_no_fit() -> None:
    f = fit_ensemble_fragility([1.0, 2.0, 3.0], [True, True, True], ["a", "b", "c"], n_boot=10)
    assert f.status == "all_toppled" and not f.draws


def test_fragility_cli_ensemble(tmp_path: Path) -> None:
    folder = tmp_path / "validate_report"
    folder.mkdir()
    synthetic_members(seed=5).to_csv(folder / "ensemble_members.csv", index=False)
    out = tmp_path / "frag"
    res = CliRunner().invoke(
        app, ["fragility", str(folder), "--ensemble", "--bootstrap", "60", "--out", str(out)]
    )
    assert res.exit_code == 0, res.output
    assert "PGA: θ = " in res.output and "two-stage bootstrap" in res.output
    s = pd.read_csv(out / "ensemble_fragility_pga.csv")
    assert {"theta_m_s2", "theta_lo_m_s2", "theta_hi_m_s2", "beta", "beta_lo", "beta_hi"} <= set(s.columns)
    assert s["theta_m_s2"].iloc[0] == pytest.approx(THETA, rel=0.15)
    d = pd.read_csv(out / "ensemble_fragility_pgv_draws.csv")
    assert list(d.columns) == ["draw", "theta_m_s", "beta"] and len(d) >= 50
    b = pd.read_csv(out / "ensemble_fragility_pga_band.csv")
    assert list(b.columns) == ["pga_m_s2", "p_fit", "p_lo", "p_hi"] and (b["p_lo"] <= b["p_hi"]).all()
    bad = CliRunner().invoke(app, ["fragility", str(tmp_path / "nothing"), "--ensemble", "--out", str(out)])
    assert bad.exit_code == 2 and "no ensemble_members.csv" in bad.output
