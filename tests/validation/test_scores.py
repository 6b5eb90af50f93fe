"""Probabilistic scores, reliability bins and the logistic baselines (pbr_xval.validation.scores).

Reference values are computed by hand from the definitions (not with scikit-learn, which the
module uses), and the logistic fits are checked on data drawn from a known logistic law.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from pbr_xval.validation.metrics import group_folds
from pbr_xval.validation.scores import (
    LOG_LOSS_EPS,
    RockGeometry,
    fit_logistic,
    logistic_baselines,
    logistic_out_of_fold,
    normalised_ims,
    probabilistic_scores,
    reliability,
    transferred_baseline,
)

from .conftest import BOX_SCENARIO, SCANS, SHAKE_TABLE, SP1_SCENARIO, box_validate_args


# ------------------------------------------------------------------ scores against hand values
def test_scores_match_hand_computed_values() -> None:
    o = [1, 0, 1, 0, 1]
    p = [0.9, 0.2, 0.3, 0.4, 0.4]
    s = probabilistic_scores(o, p)
    # Brier: (0.1² + 0.2² + 0.7² + 0.4² + 0.6²)/5 = (0.01 + 0.04 + 0.49 + 0.16 + 0.36)/5
    assert s["brier"] == pytest.approx(1.06 / 5, abs=1e-12)
    # log loss: −mean(ln 0.9, ln 0.8, ln 0.3, ln 0.6, ln 0.4)
    ll = -(math.log(0.9) + math.log(0.8) + math.log(0.3) + math.log(0.6) + math.log(0.4)) / 5
    assert s["log_loss"] == pytest.approx(ll, abs=1e-12)
    # AUC over the 3 × 2 (toppled, stood) pairs: 0.9 > 0.2, 0.9 > 0.4, 0.3 > 0.2, 0.3 < 0.4,
    # 0.4 > 0.2, 0.4 = 0.4 (½) → 4.5 / 6
    assert s["auc"] == pytest.approx(0.75, abs=1e-12)
    # at P ≥ 0.5 only the first test is predicted toppled: TP 1, FN 2, FP 0, TN 2, F1 = 2/(2+2)
    assert (s["tp"], s["fp"], s["fn"], s["tn"], s["n"]) == (1, 0, 2, 2, 5)
    assert s["f1"] == pytest.approx(0.5, abs=1e-12)


def test_deterministic_predictions_are_scored_with_the_clip() -> None:
    o = [1, 0, 1, 0]
    p = [1.0, 0.0, 0.0, 0.0]  # one missed topple
    s = probabilistic_scores(o, p)
    assert s["brier"] == pytest.approx(0.25, abs=1e-12)  # the error rate
    eps = LOG_LOSS_EPS
    assert s["log_loss"] == pytest.approx((-3 * math.log(1 - eps) - math.log(eps)) / 4, abs=1e-12)
    assert s["log_loss_eps"] == eps
    # pairs: 1 > 0, 1 > 0, 0 = 0 (½), 0 = 0 (½) → 3 / 4
    assert s["auc"] == pytest.approx(0.75, abs=1e-12)
    assert s["f1"] == pytest.approx(2 / 3, abs=1e-12)


def test_one_class_gives_nan_auc_and_bad_input_is_refused() -> None:
    s = probabilistic_scores([0, 0, 0], [0.1, 0.2, 0.0])
    assert math.isnan(s["auc"])
    assert s["brier"] == pytest.approx((0.01 + 0.04) / 3, abs=1e-12)
    assert math.isnan(s["f1"])  # no topple observed nor predicted: 0/0
    with pytest.raises(ValueError, match="probabilities"):
        probabilistic_scores([0, 1], [0.5, math.nan])
    with pytest.raises(ValueError, match="0/1"):
        probabilistic_scores([0, 2], [0.5, 0.5])


def test_reliability_bins_and_counts() -> None:
    o = [0, 0, 1, 1, 1, 0]
    p = [0.05, 0.15, 0.12, 0.95, 1.0, 0.55]
    r = reliability(o, p, n_bins=10)
    assert r["n"].sum() == len(p)
    assert r["n"].tolist() == [1, 2, 1, 2]
    assert r["bin_lo"].tolist() == pytest.approx([0.0, 0.1, 0.5, 0.9])
    assert r["bin_hi"].tolist() == pytest.approx([0.1, 0.2, 0.6, 1.0])
    assert r["mean_predicted"].tolist() == pytest.approx([0.05, 0.135, 0.55, 0.975])
    assert r["observed_frequency"].tolist() == pytest.approx([0.0, 0.5, 0.0, 1.0])
    rng = np.random.default_rng(3)
    q = rng.uniform(size=137)
    for strategy in ("uniform", "quantile"):
        rq = reliability(rng.uniform(size=137) < q, q, n_bins=7, strategy=strategy)
        assert rq["n"].sum() == 137


# ------------------------------------------------------------------ logistic baselines
def _logistic_sample(n: int, b0: float, b1: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    x = rng.normal(0.5, 0.8, n)
    o = (rng.uniform(size=n) < 1 / (1 + np.exp(-(b0 + b1 * x)))).astype(int)
    return x, o


def test_logistic_fit_recovers_a_known_law_within_sampling_error() -> None:
    b0, b1 = -1.0, 2.5
    x, o = _logistic_sample(3000, b0, b1, seed=11)
    fit = fit_logistic(x, o, features=["ln_pga"])
    # standard errors from the Fisher information at the fit (independent of scikit-learn)
    X = np.column_stack([np.ones_like(x), x])
    q = fit.predict(x)
    cov = np.linalg.inv(X.T @ (X * (q * (1 - q))[:, None]))
    se = np.sqrt(np.diag(cov))
    assert abs(fit.intercept - b0) < 4 * se[0]
    assert abs(fit.coef[0] - b1) < 4 * se[1]
    assert fit.features == ("ln_pga",)


def test_out_of_fold_probability_ignores_the_tests_own_label() -> None:
    x, o = _logistic_sample(120, -0.5, 2.0, seed=5)
    records = [f"rec{i // 5}" for i in range(x.size)]  # 24 records of 5 tests
    folds = group_folds(records, 4)
    p, fits = logistic_out_of_fold(x, o, folds)
    assert len(fits) == 4 and np.all((p > 0) & (p < 1))
    for i in (0, 37, 119):
        flipped = o.copy()
        flipped[i] = 1 - flipped[i]
        q, _ = logistic_out_of_fold(x, flipped, folds)
        same = folds == folds[i]
        np.testing.assert_array_equal(q[same], p[same])  # its whole fold is untouched
        assert not np.allclose(q[~same], p[~same])  # the other folds did see the flip


def test_a_fold_without_contrast_gets_the_base_rate() -> None:
    x = np.arange(8.0)
    o = np.array([0, 0, 0, 1, 1, 1, 0, 0])
    folds = np.array([0, 0, 0, 0, 0, 0, 1, 1])  # fold 0 is predicted from standing tests only
    p, fits = logistic_out_of_fold(x, o, folds)
    assert fits[0] is None and np.all(p[folds == 0] == 0.0)
    # fold 1's training tests are separable: the weak penalty keeps the fit finite
    assert fits[1] is not None and np.all((p[folds == 1] > 0.5) & (p[folds == 1] < 1))


def test_logistic_baselines_names_and_features() -> None:
    rng = np.random.default_rng(2)
    n = 200
    pga = np.exp(rng.normal(0.5, 0.6, n))  # m/s²
    pgv = pga * np.exp(rng.normal(-2.5, 0.4, n))  # m/s
    o = (rng.uniform(size=n) < 1 / (1 + np.exp(-(3.0 * np.log(pgv) + 6.0)))).astype(int)
    folds = group_folds([f"r{i // 8}" for i in range(n)], 4)
    res = logistic_baselines(pga, pgv, o, folds)
    assert list(res) == ["logistic(lnPGA)", "logistic(lnPGV)", "logistic(lnPGA,lnPGV)"]
    briers = {k: probabilistic_scores(o, v)["brier"] for k, v in res.items()}
    # the outcome depends on PGV only: the PGV models beat the PGA one
    assert briers["logistic(lnPGV)"] < briers["logistic(lnPGA)"]
    assert briers["logistic(lnPGA,lnPGV)"] < briers["logistic(lnPGA)"]
    single, _ = logistic_out_of_fold(np.log(pgv), o, folds)
    np.testing.assert_allclose(res["logistic(lnPGV)"], single)


# ------------------------------------------------------------------ transferred baseline
def test_block_geometry_and_from_scene(tmp_path) -> None:
    from pbr_xval.scenario import load_scenario
    from pbr_xval.scene import compile_scene

    g = RockGeometry.block(0.1, 0.4)
    assert g.alpha == pytest.approx(math.atan(0.25))
    assert g.R == pytest.approx(math.sqrt(0.17))
    assert g.p == pytest.approx(math.sqrt(3 * 9.81 / (4 * math.sqrt(0.17))))
    path = tmp_path / "box.toml"
    path.write_text(BOX_SCENARIO)  # 0.2 × 0.2 × 0.8 m block
    scene = compile_scene(load_scenario(path))
    gs = RockGeometry.from_scene(scene)
    assert gs.alpha == pytest.approx(math.atan(0.25), abs=1e-6)  # toward a face, not a diagonal
    assert gs.R == pytest.approx(math.sqrt(0.17), rel=1e-6)
    # general form √(m g R / I_O) equals the block's √(3g/4R)
    assert gs.p == pytest.approx(math.sqrt(3 * scene.gravity / (4 * gs.R)), rel=1e-6)
    assert round(math.degrees(gs.azimuth)) % 90 == 0


def test_transferred_baseline_recovers_a_normalised_law() -> None:
    rng = np.random.default_rng(7)
    source_geom = RockGeometry.block(0.10, 0.40)  # slender, small
    target_geom = RockGeometry.block(0.25, 0.60)  # stockier, larger
    b = (1.0, 0.8, 3.0)  # logit P = b0 + b1 x1 + b2 x2 in the normalised measures

    def draw(n: int, geom: RockGeometry) -> pd.DataFrame:
        pga = geom.uplift * np.exp(rng.normal(0.3, 0.7, n))
        pgv = pga * np.exp(rng.normal(-2.3, 0.5, n))
        x = normalised_ims(pga, pgv, geom)
        p = 1 / (1 + np.exp(-(b[0] + x @ np.array(b[1:]))))
        return pd.DataFrame(
            {"pga": pga, "pgv": pgv, "p_true": p, "observed": (rng.uniform(size=n) < p).astype(int)}
        )

    src = draw(4000, source_geom)
    tgt = draw(300, target_geom)
    res = transferred_baseline(tgt[["pga", "pgv"]], src, target_geom, source_geom)
    assert res.p.shape == (300,)
    assert np.max(np.abs(res.p - tgt["p_true"])) < 0.06
    assert res.fit.coef[1] == pytest.approx(b[2], rel=0.15)
    # without the geometry (the source's law applied to raw ln PGA, ln PGV) the target is far off
    raw = fit_logistic(np.log(src[["pga", "pgv"]].to_numpy()), src["observed"])
    naive = raw.predict(np.log(tgt[["pga", "pgv"]].to_numpy()))
    assert np.mean(np.abs(naive - tgt["p_true"])) > 3 * np.mean(np.abs(res.p - tgt["p_true"]))


# ------------------------------------------------------------------ the shared shake-table data
#: out-of-fold Brier of the logistic baselines on the calibration half (sheet PGA and PGV,
#: 4 folds by record), as quoted in docs/validation.md ("Probabilistic baselines")
DOCUMENTED_BRIER = {
    1: {"logistic(lnPGA)": 0.2017, "logistic(lnPGV)": 0.1025, "logistic(lnPGA,lnPGV)": 0.0974},
    2: {"logistic(lnPGA)": 0.1750, "logistic(lnPGV)": 0.0993, "logistic(lnPGA,lnPGV)": 0.0993},
}


@pytest.mark.skipif(not (SHAKE_TABLE / "experiments.csv").is_file(), reason="shared shake-table data absent")
@pytest.mark.parametrize("specimen", [1, 2])
def test_documented_logistic_baselines_on_the_shared_campaign(specimen: int) -> None:
    from pbr_xval.validation.campaign import G_STANDARD, load_campaign

    camp = load_campaign(SHAKE_TABLE, specimen)
    pga = np.array([t.sheet["pga_g"] * G_STANDARD for t in camp.tests])
    pgv = pga * np.array([t.sheet["pgv_over_pga_s"] for t in camp.tests])
    o = np.array([int(t.toppled) for t in camp.tests])
    folds = group_folds([t.motion for t in camp.tests], 4)
    res = logistic_baselines(pga, pgv, o, folds)
    got = {k: probabilistic_scores(o, v)["brier"] for k, v in res.items()}
    # Tolerance 1e-3: the numbers are deterministic (fixed folds, data and C). Measured: the
    # solver's stopping rule (lbfgs tol 1e-4 vs 1e-10) moves them by < 1e-5 and the weak penalty
    # (C = 100 vs 1e6, i.e. none) by < 5e-5; 1e-3 leaves room for other library versions and is
    # a fifteenth of the 15 % margin on these Briers (≈ 0.015).
    for k, v in DOCUMENTED_BRIER[specimen].items():
        assert got[k] == pytest.approx(v, abs=1e-3), k


# ------------------------------------------------------------------ report pieces
def _result_with_probabilities():
    from pbr_xval.validation.campaign_report import ValidationResult, add_model

    oc = pd.DataFrame(
        {
            "test": ["1", "2", "3", "4"],
            "pga_m_s2": [1.0, 3.0, 6.0, 8.0],
            "pgv_m_s": [0.1, 0.3, 0.9, 1.2],
            "pgv_over_pga_s": [0.1, 0.1, 0.15, 0.15],
            "observed": [0, 0, 1, 1],
            "pred_e": [0, 1, 1, None],  # the last run failed
        }
    )
    row = {"model": "e", "kind": "physics", "evaluated_on": "all tests", "n": 3, "tp": 1, "fp": 1, "fn": 0,
           "tn": 1, "accuracy": 2 / 3, "precision": 0.5, "recall": 1.0, "f1": 2 / 3,
           "brier": 1 / 3, "log_loss": math.nan, "auc": 0.75}  # fmt: skip
    res = ValidationResult(oc, pd.DataFrame([row]), ["e"], "record", 2)
    add_model(res, "ensemble", [0.1, 0.6, 0.8, math.nan], kind="ensemble", evaluated_on="all tests")
    return res


def test_add_model_and_brier_lines() -> None:
    from pbr_xval.validation.campaign_report import brier_lines, f1_lines

    res = _result_with_probabilities()
    ens = res.scores.set_index("model").loc["ensemble"]
    # the NaN test is left out: (0.1² + 0.6² + 0.2²)/3; at P ≥ 0.5: TP 1, FP 1, TN 1
    assert ens["brier"] == pytest.approx((0.01 + 0.36 + 0.04) / 3)
    assert (ens["n"], ens["tp"], ens["fp"], ens["fn"], ens["tn"]) == (3, 1, 1, 0, 1)
    assert brier_lines(res) == ["Brier e 0.3333", "Brier ensemble 0.1367"]
    assert f1_lines(res) == ["F1 e 0.6667"]  # unchanged: engines only


def test_probabilistic_figures_carry_units() -> None:
    import matplotlib.pyplot as plt

    from pbr_xval.validation.campaign_report import probability_plane_figure, reliability_figure

    res = _result_with_probabilities()
    fig = reliability_figure(res)
    ax = fig.axes[0]
    assert ax.get_xlabel() == "predicted P(topple) [–]" and ax.get_ylabel() == "observed frequency [–]"
    # the diagonal and the count of each bin
    assert any(list(line.get_xdata()) == [0, 1] for line in ax.get_lines())
    assert sorted(t.get_text() for t in ax.texts) == ["1", "1", "1"]
    plt.close(fig)
    fig = probability_plane_figure(res)
    ax = fig.axes[0]
    assert ax.get_xlabel() == "PGA [m/s²]" and ax.get_ylabel() == "PGV/PGA [s]"
    assert any(a.get_ylabel() == "P(topple) [–]" for a in fig.axes)  # the colour bar
    plt.close(fig)


def test_evaluate_scores_every_model_probabilistically(box_campaign_files, tmp_path) -> None:
    from pbr_xval.validation.campaign import Baseline, load_campaign
    from pbr_xval.validation.campaign_report import PROB_COLUMNS, evaluate, write_report
    from pbr_xval.validation.execution import prepare_motions

    csv, _, observed = box_campaign_files
    camp = load_campaign(csv, 1)
    motions = prepare_motions(
        camp, Baseline(detrend="none", highpass_hz=None, lowpass_hz=None), tmp_path / "m"
    )
    wrong_first = [1 - observed[0], *observed[1:]]
    tests = [t.test for t in camp.tests]
    rows = pd.DataFrame(
        {"test": tests, "engine": "fake", "toppled": wrong_first, "status": "ok", "wall_s": 0.1}
    )
    res = evaluate(camp, rows, motions, ["fake"], folds=3)
    sc = res.scores.set_index("model")
    assert set(PROB_COLUMNS) <= set(sc.columns)
    assert sc.loc["fake", "brier"] == pytest.approx(1 / 6)  # one wrong 0/1 prediction of six
    assert {"logistic(lnPGA)", "logistic(lnPGV)", "logistic(lnPGA,lnPGV)"} <= set(sc.index)
    assert sc[list(PROB_COLUMNS[:2])].notna().all().all()
    for name in ("PGA rule", "logistic(lnPGV)"):
        assert 0 <= sc.loc[name, "brier"] <= 1
    paths = write_report(res, tmp_path / "report", {"scenario": "box"})
    written = pd.read_csv(paths["scores"])
    assert {"brier", "log_loss", "auc", "f1", "tp"} <= set(written.columns)
    page = paths["html"].read_text()
    assert "Probabilistic scores" in page and "reliability diagram" in page
    assert (tmp_path / "report" / "reliability.csv").is_file()
    bands = pd.read_csv(paths["bands"])  # errors by band of PGV/PGA: every test in one band, every model
    assert bands.tests.sum() == len(tests) and bands.observed.sum() == sum(observed)
    assert bands.fake.sum() == sum(wrong_first) and "logistic(lnPGV)" in bands.columns
    assert "Errors by band of PGV/PGA" in page


#: transferred baseline (fitted on the other specimen, geometry-normalised sheet PGA and PGV,
#: α_min of each committed scenario's rock), as quoted in docs/validation.md
DOCUMENTED_TRANSFERRED_BRIER = {1: 0.1461, 2: 0.1316}


@pytest.mark.slow
@pytest.mark.skipif(
    not (SHAKE_TABLE / "experiments.csv").is_file() or not (SCANS / "SP1_mesh.obj").is_file(),
    reason="shared shake-table data or scans absent",
)
def test_documented_transferred_baseline_on_the_shared_campaign() -> None:
    from pbr_xval.validation.campaign import G_STANDARD, load_campaign

    sp2_mesh = SP1_SCENARIO.parent / "sp2.rock.obj"
    if not sp2_mesh.is_file():
        pytest.skip("SP2's mesh not reconstructed (python examples/validation/make_sp2_mesh.py)")
    frames, geoms = {}, {}
    for spec in (1, 2):
        camp = load_campaign(SHAKE_TABLE, spec)
        pga = np.array([t.sheet["pga_g"] * G_STANDARD for t in camp.tests])
        pgv = pga * np.array([t.sheet["pgv_over_pga_s"] for t in camp.tests])
        frames[spec] = pd.DataFrame(
            {"pga": pga, "pgv": pgv, "observed": [int(t.toppled) for t in camp.tests]}
        )
        geoms[spec] = RockGeometry.from_scenario(SP1_SCENARIO.parent / f"sp{spec}.toml")
    # α_min over all directions: SP1 4.59° (a narrow dip at 336–339° that the 5° table misses),
    # SP2 7.45° near 27°
    assert math.degrees(geoms[1].alpha) == pytest.approx(4.59, abs=0.05)
    assert math.degrees(geoms[2].alpha) == pytest.approx(7.45, abs=0.05)
    for target, source in ((1, 2), (2, 1)):
        tr = transferred_baseline(frames[target], frames[source], geoms[target], geoms[source])
        brier = probabilistic_scores(frames[target]["observed"], tr.p)["brier"]
        # same tolerance and reason as the logistic baselines above
        assert brier == pytest.approx(DOCUMENTED_TRANSFERRED_BRIER[target], abs=1e-3), target


def test_validate_transfer_option(box_campaign_files, tmp_path) -> None:
    import json

    from typer.testing import CliRunner

    from pbr_xval.cli import app

    csv, scn, _ = box_campaign_files
    out = tmp_path / "report"
    base = box_validate_args(csv, scn, out)
    runner = CliRunner()
    bad = runner.invoke(app, [*base, "--transfer", f"{csv}:one:{scn}"])
    assert bad.exit_code == 2 and "CAMPAIGN:SPECIMEN:SCENARIO" in bad.output
    assert not (out / "store").exists()  # refused before running
    # the campaign as its own source: a block transferred to itself (the plumbing, not a claim)
    res = runner.invoke(app, [*base, "--transfer", f"{csv}:1:{scn}"])
    assert res.exit_code == 0, res.output
    lines = [ln for ln in res.output.splitlines() if ln.startswith("Brier transferred ")]
    assert len(lines) == 1 and 0 <= float(lines[0].split()[2]) <= 1
    sc = pd.read_csv(out / "scores.csv").set_index("model")
    assert sc.loc["transferred", "kind"] == "transferred"
    doc = json.loads((out / "validation.json").read_text())
    assert doc["transferred"]["target_geometry"]["alpha_deg"] == pytest.approx(
        math.degrees(math.atan(0.25)), abs=1e-4
    )


def test_min_tilt_search_matches_a_brute_force_grid() -> None:
    """α_min of the transferred baseline's geometry (StabilityTable.minimum: branch and bound)
    equals the minimum of an exhaustive grid of critical tilts."""
    import trimesh

    from pbr_xval.geometry.stability import StabilityTable, critical_tilt, hull_vertices, support_lever

    rng = np.random.default_rng(4)
    pts = rng.normal(size=(60, 3)) * [0.3, 0.2, 0.5]
    pts[:, 2] = np.maximum(pts[:, 2], -0.1)  # an irregular rock on a flat base
    hull = trimesh.convex.convex_hull(pts)
    hv, com = hull_vertices(hull.vertices), hull.center_mass

    def tilt(phi: float) -> float:
        a = critical_tilt(hv, com, np.array([math.cos(phi), math.sin(phi), 0.0]))
        return a if np.isfinite(a) else math.inf

    grid = np.radians(np.arange(0.0, 360.0, 1.0))
    alpha = np.array([tilt(p) for p in grid])
    bound = np.array(
        [math.atan2(*support_lever(hv, com, np.array([math.cos(p), math.sin(p), 0.0]))) for p in grid]
    )
    assert np.all(alpha >= bound - 1e-12)  # α ≥ atan(b_s/h): a cheap bound holds on this rock
    table = StabilityTable(hv, com)
    for step in (5.0, 0.25):
        best, phi = table.minimum(step_deg=step)
        assert best == pytest.approx(tilt(phi), abs=1e-12)
        on_grid = alpha[:: int(step)] if step >= 1 else alpha  # the search's own grid, or a coarser one
        assert best <= on_grid.min() + 1e-12 and best > on_grid.min() - math.radians(1.0)


def test_band_table_counts_topples_per_band_of_pgv_over_pga() -> None:
    """Errors by band (issue 22): eight tests in two PGV/PGA bands, counted by hand."""
    from pbr_xval.validation.campaign_report import ValidationResult, band_table

    ratio = [0.02, 0.03, 0.04, 0.05, 0.08, 0.09, 0.10, 0.12]  # s; quantile edges 0.02 / 0.065 / 0.12
    oc = pd.DataFrame(
        {
            "test": [str(i) for i in range(8)],
            "observed": [0, 0, 1, 1, 1, 1, 1, 0],
            "sheet_pga_m_s2": 2.0,
            "sheet_pgv_over_pga_s": ratio,
            "pred_fake": [1, 1, 1, 0, 0, 0, 1, np.nan],  # too fragile at short periods, too stable at long
            "p_ensemble": [0.5, 0.5, 0.5, 0.5, 0.25, 0.25, 0.25, 0.25],
        }
    )
    res = ValidationResult(
        outcomes=oc, scores=pd.DataFrame(), engines=["fake"], baseline_source="sheet", folds=2
    )
    b = band_table(res, n_bands=2)
    assert b.pgv_over_pga_lo_s.tolist() == pytest.approx([0.02, 0.065])
    assert b.pgv_over_pga_hi_s.tolist() == pytest.approx([0.065, 0.12])
    assert b.tests.tolist() == [4, 4] and b.observed.tolist() == [2, 3]
    assert b.fake.tolist() == [3.0, 1.0]  # the failed run (NaN) counts as no prediction
    assert b.ensemble.tolist() == pytest.approx([2.0, 1.0])
    # a test exactly on an inner edge belongs to the lower band; the first band includes its lower edge
    oc2 = oc.assign(sheet_pgv_over_pga_s=[0.02, 0.02, 0.02, 0.05, 0.05, 0.09, 0.10, 0.12])
    b2 = band_table(ValidationResult(oc2, pd.DataFrame(), ["fake"], "sheet", 2), n_bands=2)
    assert b2.tests.tolist() == [5, 3]
