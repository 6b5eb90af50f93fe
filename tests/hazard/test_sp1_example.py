"""The SP1 end-to-end example (issue 25, item 6): the script on synthetic outcomes, and the committed
report reproduced from its committed inputs."""

from __future__ import annotations

import csv
import importlib.util
import json
import math
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

from pbr_xval.hazard.config import load_config
from pbr_xval.hazard.fragility_draws import propagate
from pbr_xval.hazard.ims import G
from pbr_xval.hazard.survival import constrain

ROOT = Path(__file__).resolve().parents[2]
REPORT = ROOT / "reports" / "hazard_sp1"


def _script():
    spec = importlib.util.spec_from_file_location(
        "run_sp1", ROOT / "examples" / "hazard" / "sp1" / "run_sp1.py"
    )
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_script_on_synthetic_outcomes(tmp_path):
    # a stand-in for `pbr-xval validate` output: 120 tests, outcomes ~ lognormal(0.4 g, 0.6) on PGA
    rng = np.random.default_rng(2)
    pga = 0.4 * G * np.exp(0.6 * rng.uniform(-2.5, 2.5, 120))
    ratio = np.exp(rng.normal(math.log(0.06), 0.4, 120))
    pred = rng.uniform(size=120) < stats.norm.cdf(np.log(pga / (0.4 * G)) / 0.6)
    rows = ["test,motion,observed,pga_m_s2,pgv_over_pga_s,pred_mujoco,status_mujoco"]
    rows += [
        f"{i},rec{i % 12},{int(p)},{float(a)!r},{float(r)!r},{int(p)},ok"
        for i, (a, r, p) in enumerate(zip(pga, ratio, pred, strict=True))
    ]
    v = tmp_path / "validate"
    v.mkdir()
    (v / "outcomes.csv").write_text("\n".join(rows) + "\n")
    out = tmp_path / "rep"
    assert _script().main([str(v), "--out", str(out), "--bootstrap"]) == 0
    s = json.loads((out / "summary.json").read_text())
    fit = json.loads((out / "inputs" / "sp1_fit.json").read_text())["fragility_pga"]
    assert (
        fit["theta_ci_g"][0] < fit["theta_g"] < fit["theta_ci_g"][1] and abs(fit["theta_g"] / 0.4 - 1) < 0.3
    )
    assert s["headline_field_units"]["field_unit"] == "g" and s["n_branches"] == 3
    # the band from `pbr-xval fragility --ensemble`'s record-clustered bootstrap, read back as draws
    assert s["fragility_uncertainty"]["rocks"]["SP1"]["method"] == "bootstrap"
    assert s["fragility_uncertainty"]["rocks"]["SP1"]["n_draws"] == 400
    assert "deterministic" in (out / "README.md").read_text()
    assert (out / "contribution.csv").is_file() and (out / "vector" / "index.html").is_file()
    page = (out / "index.html").read_text()
    assert "mean annual rate of exceeding PGA = 0.2 g" in page and "Contribution to each rock" in page


@pytest.mark.skipif(not (REPORT / "summary.json").is_file(), reason="committed report not present")
def test_committed_report_reproduces_from_its_inputs():
    s = json.loads((REPORT / "summary.json").read_text())
    cfg = load_config(REPORT / "inputs" / "constrain.toml")
    c = constrain(cfg.branches, cfg.rocks, cfg.joint, cfg.rate_of_interest, cfg.quantiles,
                  im_of_interest=cfg.im_of_interest)  # fmt: skip
    assert c.summary["rock_survival"]["SP1"] == pytest.approx(s["rock_survival"]["SP1"], rel=1e-9)
    assert c.summary["mean_im_after"] == pytest.approx(s["mean_im_after"], rel=1e-9)
    assert c.summary["mean_rate_after_at_im"] == pytest.approx(s["mean_rate_after_at_im"], rel=1e-9)
    u = propagate(c, cfg.branches, cfg.rocks, cfg.draws)
    su = s["fragility_uncertainty"]["rocks"]["SP1"]
    assert u.ps_mean[0] == pytest.approx(su["ps"], rel=1e-9) and u.ps_band[0, 0] == pytest.approx(
        su["ps_05"], rel=1e-9
    )
    # the figures quoted in docs/hazard.md
    assert round(s["rock_survival"]["SP1"], 3) == 0.302 and round(su["ps"], 3) == 0.332
    assert su["method"] == "bootstrap" and round(su["ps_05"], 3) == 0.118 and round(su["ps_95"], 3) == 0.567
    assert round(s["mean_im_before"] / G, 3) == 0.188 and round(s["mean_im_after"] / G, 3) == 0.145
    assert round(s["mean_rate_ratio_at_im"], 3) == 0.607
    branches = list(csv.DictReader((REPORT / "branches.csv").read_text().splitlines()))
    assert [b["branch"] for b in branches] == ["low", "central", "high"]
