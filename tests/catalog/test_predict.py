"""``pbr-xval predict``: P(topple) of an ensemble against the closed form on the Housner block."""

from __future__ import annotations

import json
import math
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from pbr_xval.catalog.predict import estimate, run_member, run_predict, stop_rule
from pbr_xval.cli import app
from pbr_xval.uncertainty import ensemble_spec

HOUSNER = Path(__file__).parents[2] / "examples" / "housner_halfsine.toml"
#: the exact toppling amplitude of this block under this pulse (examples/housner_halfsine.toml)
A_CRIT = 5.638
LO, HI = 5.0, 6.5


def housner_ensemble(tmp_path: Path, **unc: object) -> Path:
    d = tomllib.loads(HOUSNER.read_text())
    d["duration"] = 2.5  # the pulse lasts 0.5 s; the outcome is decided well before 2.5 s
    table = {
        "engines": ["housner"],
        "excitation": {"amplitude": {"dist": "uniform", "low": LO, "high": HI}},
        **unc,
    }
    import tomli_w

    p = tmp_path / "housner_ens.toml"
    text = tomli_w.dumps({k: v for k, v in d.items() if k != "uncertainty"})
    p.write_text(text + "\n" + tomli_w.dumps({"uncertainty": table}))
    return p


def load(p: Path):
    from pbr_xval.scenario import load_scenario

    return load_scenario(p)


def test_predict_matches_the_closed_form_share(tmp_path: Path) -> None:
    """P = share of the amplitude distribution above 5.638 m/s² (the independent reference)."""
    scn = load(housner_ensemble(tmp_path, members=32))
    spec = ensemble_spec(scn)
    assert spec is not None
    res = run_predict(scn, tmp_path / "out", spec=spec, executor="inline", progress=False)
    p_true = (HI - A_CRIT) / (HI - LO)
    o = res.overall
    assert o.n == 32 and res.failed == 0
    # a Sobol design puts one member in each 1/32 of the range: the share is within 1/32 of P;
    # the reported P, (k + ½) / (n + 1), is within |½ − share| / (n + 1) ≤ 1/66 of the share
    assert abs(o.share - p_true) <= 1 / 32 + 1e-9
    assert abs(o.p - o.share) <= 1 / 66 + 1e-12 and abs(o.p - p_true) <= 1 / 32 + 1 / 66 + 1e-9
    assert o.lo < p_true < o.hi
    # every member toppled exactly when its amplitude is above the closed-form level (±0.2 %)
    df = res.members
    a = df["value:excitation.amplitude"].to_numpy()
    far = np.abs(a - A_CRIT) > 0.002 * A_CRIT
    assert (df["toppled"].to_numpy()[far] == (a[far] > A_CRIT)).all()
    assert res.per_engine["housner"].n == 32
    # resumable: a rerun simulates nothing
    again = run_predict(scn, tmp_path / "out", spec=spec, executor="inline", progress=False)
    assert again.overall == o


def test_member_rerun_is_bit_identical(tmp_path: Path) -> None:
    scn = load(housner_ensemble(tmp_path, members=8, seed=5))
    spec = ensemble_spec(scn)
    assert spec is not None
    res = run_predict(scn, tmp_path / "out", spec=spec, executor="inline", progress=False)
    for i in (2, 5):
        m, traj = run_member(scn, spec, i)
        row = res.members.set_index("member").loc[i]
        assert traj.scene_info["ensemble_member"]["values"] == m.values
        assert m.values["excitation.amplitude"] == row["value:excitation.amplitude"]
        assert bool(traj.toppled) == bool(row["toppled"])
        assert float(np.max(traj.tilt())) == row["peak_tilt_rad"]  # bit for bit
        ta = traj.toppled_at
        assert (ta is None and np.isnan(row["toppled_at_s"])) or ta == row["toppled_at_s"]
        _, again = run_member(scn, spec, i)
        assert again.fingerprint() == traj.fingerprint()


def test_adaptive_stop_rules(tmp_path: Path) -> None:
    scn = load(housner_ensemble(tmp_path, members=64))
    spec = ensemble_spec(scn)
    assert spec is not None
    res = run_predict(
        scn, tmp_path / "out", spec=spec, executor="inline", progress=False, half_width=0.2, batch=4
    )
    assert res.stop.startswith("half-width") and res.overall.half_width <= 0.2
    assert len(res.members) % 4 == 0 and len(res.members) < 64
    assert [b["members"] for b in res.batches] == list(range(4, len(res.members) + 1, 4))
    assert all(b["half_width"] > 0.2 for b in res.batches[:-1])
    # decided: every member topples far above the threshold → the interval leaves 0.5 after one batch
    hi = load(
        housner_ensemble(
            tmp_path, members=64, excitation={"amplitude": {"dist": "uniform", "low": 7.0, "high": 8.0}}
        )
    )
    spec_hi = ensemble_spec(hi)
    assert spec_hi is not None
    r2 = run_predict(
        hi, tmp_path / "out2", spec=spec_hi, executor="inline", progress=False, half_width=0.05, batch=4
    )
    assert r2.stop.startswith("decided: the interval lies entirely above 0.5") and len(r2.members) == 4


def test_stop_rule_units() -> None:
    assert stop_rule(estimate([True] * 4), None) is not None  # Beta(4.5, 0.5): lower end 0.555
    assert stop_rule(estimate([True] * 3), None) is None  # lower end 0.464
    assert stop_rule(estimate([False] * 4), None) is not None
    assert stop_rule(estimate([True, False] * 50), 0.1) is not None
    assert stop_rule(estimate([True, False] * 10), 0.1) is None


def test_predict_cli(tmp_path: Path) -> None:
    p = housner_ensemble(tmp_path, members=8)
    out = tmp_path / "cli"
    res = CliRunner().invoke(app, ["predict", str(p), "--out", str(out), "--workers", "1"])
    assert res.exit_code == 0, res.output
    assert "Jeffreys 95 % interval" in res.output and "P(topple) = " in res.output
    assert "housner: P = " in res.output and "(n = 8," in res.output
    df = pd.read_csv(out / "members.csv")
    assert list(df["member"]) == list(range(8)) and "value:excitation.amplitude" in df.columns
    doc = json.loads((out / "predict.json").read_text())
    assert doc["p_topple"]["n"] == 8 and doc["uncertainty"]["seed"] == 0
    # one member again, from the command line
    r1 = CliRunner().invoke(app, ["predict", str(p), "--out", str(out), "--member", "3"])
    assert r1.exit_code == 0, r1.output
    assert (out / "member_0003.housner.parquet").is_file()
    stood = not bool(df.loc[df["member"] == 3, "toppled"].iloc[0])
    assert ("stood" in r1.output) == stood


def test_predict_input_errors(tmp_path: Path) -> None:
    plain = CliRunner().invoke(app, ["predict", str(HOUSNER)])
    assert plain.exit_code == 2 and "no [uncertainty] table" in plain.output
    p = housner_ensemble(tmp_path)
    bad = CliRunner().invoke(app, ["predict", str(p), "--engine", "nosuch"])
    assert bad.exit_code == 2 and "--engine 'nosuch'" in bad.output
    hw = CliRunner().invoke(app, ["predict", str(p), "--half-width", "0.7"])
    assert hw.exit_code == 2 and "--half-width" in hw.output


@pytest.mark.parametrize("n", [4, 7])
def test_estimate_interval(n: int) -> None:
    e = estimate([True] * 2 + [False] * (n - 2))
    assert e.k == 2 and e.n == n and 0 < e.lo < e.p < e.hi < 1


@pytest.mark.parametrize(("k", "n"), [(0, 4), (4, 4), (2, 4), (0, 16), (11, 16), (1, 1)])
def test_p_is_the_jeffreys_posterior_mean(k: int, n: int) -> None:
    """P(topple) is the mean of the posterior Beta(k + ½, n − k + ½) the interval comes from
    (scipy's Beta as the independent reference), inside that interval and on the share's side of ½."""
    from scipy import stats

    e = estimate([True] * k + [False] * (n - k))
    assert e.p == pytest.approx(stats.beta(k + 0.5, n - k + 0.5).mean(), rel=1e-12)
    assert e.lo <= e.p <= e.hi and e.share == k / n
    assert (e.p >= 0.5) == (e.share >= 0.5)
    assert 0 < e.p < 1  # never a certainty from a finite ensemble
    assert math.isnan(estimate([]).p)


def test_run_member_matches_the_ensemble(tmp_path: Path) -> None:
    """`pbr-xval run SCEN --engine E --member I` is member I's run, bit for bit."""
    from pbr_xval.engine import Trajectory

    p = housner_ensemble(tmp_path, members=8, seed=5)
    scn = load(p)
    spec = ensemble_spec(scn)
    assert spec is not None
    res = run_predict(scn, tmp_path / "out", spec=spec, executor="inline", progress=False)
    out = tmp_path / "m4.parquet"
    r = CliRunner().invoke(app, ["run", str(p), "--engine", "housner", "--member", "4", "--out", str(out)])
    assert r.exit_code == 0, r.output
    traj = Trajectory.load_parquet(out)
    row = res.members.set_index("member").loc[4]
    assert traj.scene_info["ensemble_member"]["member"] == 4
    assert (
        traj.scene_info["ensemble_member"]["values"]["excitation.amplitude"]
        == row["value:excitation.amplitude"]
    )
    assert float(np.max(traj.tilt())) == row["peak_tilt_rad"] and bool(traj.toppled) == bool(row["toppled"])
    bad = CliRunner().invoke(
        app, ["run", str(p), "--engine", "housner", "--member", "8", "--out", str(tmp_path / "x.parquet")]
    )
    assert bad.exit_code == 2 and "--member 8" in bad.output
