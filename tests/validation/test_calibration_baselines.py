"""``validate --calibration CAMPAIGN[:SPECIMEN]``: the empirical baselines fitted on another campaign (the
calibration half) and applied unchanged to this one (the held-out half) — the comparison issue 22's goals
name ("the best logistic baseline fitted on the calibration half").

The shared campaign is split by record into two halves written to ``tmp_path`` (its lab sheet rows; the
records' archive linked, not copied). References: scikit-learn's own pipeline (standardise, L2 logistic
regression at C = 100) fitted on the first half, a brute-force F1-optimal PGV threshold on the first
half, and leakage checks (the second half's outcomes flipped: nothing fitted on the first half moves)."""

from __future__ import annotations

import json
import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from .conftest import SHAKE_TABLE, box_validate_args

G0 = 9.80665


def _halves(tmp: Path, flip_second: bool = False) -> tuple[Path, Path]:
    from pbr_xval.validation.metrics import group_folds

    ex = pd.read_csv(SHAKE_TABLE / "experiments.csv")
    fold = group_folds(ex.motion.tolist(), 2)
    paths = []
    for k in (0, 1):
        d = tmp / f"half{k}"
        d.mkdir(parents=True, exist_ok=True)
        sub = ex[fold == k].copy()
        if k == 1 and flip_second:
            for c in ("toppled_specimen1", "toppled_specimen2"):
                sub[c] = 1 - sub[c]
        sub.to_csv(d / "experiments.csv", index=False)
        if not (d / "table_motions.npz").exists():
            (d / "table_motions.npz").symlink_to((SHAKE_TABLE / "table_motions.npz").resolve())
        paths.append(d)
    return paths[0], paths[1]


def _result(held: Path, specimen: int):  # type: ignore[no-untyped-def]
    """evaluate() on the held-out half with no engine (the baselines need no simulation)."""
    from pbr_xval.validation.campaign import load_campaign
    from pbr_xval.validation.campaign_report import evaluate

    camp = load_campaign(held, specimen)
    motions = {t.test: SimpleNamespace(pga=1.0, pgv=0.1, duration=10.0) for t in camp.tests}
    rows = pd.DataFrame(columns=["test", "engine", "toppled", "status", "wall_s"])
    return evaluate(camp, rows, motions, [], folds=4, baseline_source="sheet")


pytestmark = pytest.mark.skipif(
    not (SHAKE_TABLE / "experiments.csv").is_file(), reason="shared shake-table data not present"
)


@pytest.mark.parametrize("specimen", [1, 2])
def test_baselines_fitted_on_the_other_half(tmp_path: Path, specimen: int) -> None:
    from sklearn.linear_model import LogisticRegression
    from sklearn.pipeline import make_pipeline
    from sklearn.preprocessing import StandardScaler

    from pbr_xval.validation.campaign_report import add_calibration_baselines

    cal, held = _halves(tmp_path)
    res = _result(held, specimen)
    info = add_calibration_baselines(res, str(cal), specimen)
    a = pd.read_csv(cal / "experiments.csv")
    b = pd.read_csv(held / "experiments.csv").set_index("test").loc[res.outcomes["test"].astype(int)]
    assert info["tests"] == len(a) and info["shared_tests"] == []
    obs_a = a[f"toppled_specimen{specimen}"].to_numpy(int)

    def ims(df: pd.DataFrame) -> tuple[np.ndarray, np.ndarray]:
        pga = df.pga_g.to_numpy(float) * G0
        return pga, pga * df.pgv_over_pga_s.to_numpy(float)

    (pga_a, pgv_a), (pga_b, pgv_b) = ims(a), ims(b)
    # the logistic laws: scikit-learn's pipeline fitted on the calibration half only
    for name, cols in {
        "logistic(lnPGA)": [pga_a],
        "logistic(lnPGV)": [pgv_a],
        "logistic(lnPGA,lnPGV)": [pga_a, pgv_a],
    }.items():
        xa = np.log(np.column_stack(cols))
        xb = np.log(
            np.column_stack(
                {"logistic(lnPGA)": [pga_b], "logistic(lnPGV)": [pgv_b]}.get(name, [pga_b, pgv_b])
            )
        )
        ref = (
            make_pipeline(StandardScaler(), LogisticRegression(C=100.0))
            .fit(xa, obs_a)
            .predict_proba(xb)[:, 1]
        )
        got = res.outcomes[f"p_{name}@calibration"].to_numpy(float)
        np.testing.assert_allclose(got, ref, atol=2e-4)
        row = res.scores.set_index("model").loc[f"{name}@calibration"]
        o = res.outcomes["observed"].to_numpy(int)
        assert row["brier"] == pytest.approx(np.mean((ref - o) ** 2), abs=1e-4)
    # the PGV rule: the F1-best threshold on the calibration half (brute force over its PGVs) applied here
    cuts = np.unique(pgv_a)
    f1 = [2 * ((pgv_a >= c) & (obs_a == 1)).sum() / ((pgv_a >= c).sum() + obs_a.sum()) for c in cuts]
    best = cuts[int(np.argmax(f1))]
    pred = res.outcomes["pred_PGV rule@calibration"].to_numpy(int)
    lo = pgv_a[pgv_a < best].max() if (pgv_a < best).any() else -math.inf
    sure = (pgv_b >= best) | (pgv_b <= lo)  # tests outside the gap where a cut may lie
    assert (pred[sure] == (pgv_b[sure] >= best)).all()
    assert res.scores.set_index("model").loc["PGV rule@calibration", "f1"] == pytest.approx(
        2
        * ((pred == 1) & (res.outcomes["observed"] == 1)).sum()
        / (pred.sum() + res.outcomes["observed"].sum())
    )


def test_no_held_out_outcome_enters_the_fit(tmp_path: Path) -> None:
    """Flip every outcome of the held-out half: the @calibration predictions must not move (the
    out-of-fold ones, fitted on the held-out half itself, must)."""
    from pbr_xval.validation.campaign_report import add_calibration_baselines

    cal, held = _halves(tmp_path / "a")
    r1 = _result(held, 2)
    add_calibration_baselines(r1, f"{cal}:2", 1)  # the specimen given in the spec wins
    cal2, held2 = _halves(tmp_path / "b", flip_second=True)
    r2 = _result(held2, 2)
    add_calibration_baselines(r2, f"{cal2}:2", 1)
    for c in ("p_logistic(lnPGA,lnPGV)@calibration", "pred_PGA-and-PGV rule@calibration"):
        np.testing.assert_array_equal(r1.outcomes[c].to_numpy(), r2.outcomes[c].to_numpy())
    assert not np.allclose(r1.outcomes["p_logistic(lnPGA,lnPGV)"], r2.outcomes["p_logistic(lnPGA,lnPGV)"])
    assert r1.meta["calibration"]["specimen"] == 2


def test_validate_calibration_option(box_campaign_files, tmp_path: Path) -> None:
    """The option end to end on the synthetic box campaign (housner engine): refused before any run when
    wrong; with the campaign as its own calibration the models are in sample and say so."""
    from typer.testing import CliRunner

    from pbr_xval.cli import app

    csv, scn, _ = box_campaign_files
    out = tmp_path / "report"
    base = box_validate_args(csv, scn, out)
    runner = CliRunner()
    bad = runner.invoke(app, [*base, "--calibration", str(tmp_path / "nowhere.csv")])
    assert bad.exit_code == 2 and "--calibration" in bad.output and "not found" in bad.output
    assert not (out / "store").exists()  # refused before running
    one = csv.with_name("one_outcome.csv")  # same tests, every outcome 'stood'
    lines = csv.read_text().splitlines()
    one.write_text(
        "\n".join([lines[0], *(",".join([*r.split(",")[:4], "0", *r.split(",")[5:]]) for r in lines[1:])])
        + "\n"
    )
    bad = runner.invoke(app, [*base, "--calibration", str(one)])
    assert bad.exit_code == 2 and "one outcome only" in bad.output, bad.output
    assert not (out / "store").exists()
    res = runner.invoke(app, [*base, "--calibration", str(csv)])
    assert res.exit_code == 0, res.output
    lines = [ln for ln in res.output.splitlines() if ln.startswith("Brier logistic(lnPGA)@calibration ")]
    assert len(lines) == 1 and 0 <= float(lines[0].split()[2]) <= 1
    assert any(ln.strip().startswith("PGV rule@calibration  F1 ") for ln in res.output.splitlines())
    doc = json.loads((out / "validation.json").read_text())
    assert doc["calibration"]["tests"] == 6 and len(doc["calibration"]["shared_tests"]) == 6
    assert "in sample" in (out / "index.html").read_text()


def test_documented_rehearsal_baselines() -> None:
    """docs/validation.md, "A rehearsal of the held-out judgement": the best logistic law fitted on one
    record half of the calibration campaign, scored on the other — recomputed with scikit-learn's own
    pipeline from the lab sheet (the ensembles' columns are one-off measurements of stored runs)."""
    import re

    from sklearn.linear_model import LogisticRegression
    from sklearn.pipeline import make_pipeline
    from sklearn.preprocessing import StandardScaler

    from pbr_xval.validation.metrics import group_folds

    doc = (Path(__file__).resolve().parents[2] / "docs" / "validation.md").read_text()
    ex = pd.read_csv(SHAKE_TABLE / "experiments.csv")
    fold = group_folds(ex.motion.tolist(), 2)
    pga = ex.pga_g.to_numpy(float) * G0
    feats = {"ln PGA": [np.log(pga)], "ln PGV": [np.log(pga * ex.pgv_over_pga_s.to_numpy(float))]}
    feats["ln PGA, ln PGV"] = feats["ln PGA"] + feats["ln PGV"]
    for spec in (1, 2):
        o = ex[f"toppled_specimen{spec}"].to_numpy(int)
        for k in (0, 1):
            m = re.search(
                rf"\| SP{spec}, half {k} \((\d+) toppled\) \| [0-9.]+ \| ([0-9.]+) \(([^)]+)\) \|", doc
            )
            assert m, f"rehearsal row SP{spec}, half {k} missing"
            assert int(m.group(1)) == o[fold == k].sum()
            briers = {}
            for name, cols in feats.items():
                x = np.column_stack(cols)
                fit = make_pipeline(StandardScaler(), LogisticRegression(C=100.0)).fit(
                    x[fold != k], o[fold != k]
                )
                p = fit.predict_proba(x[fold == k])[:, 1]
                briers[name] = float(np.mean((p - o[fold == k]) ** 2))
            best = min(briers, key=briers.__getitem__)
            assert m.group(3) == best and float(m.group(2)) == pytest.approx(briers[best], abs=6e-4)
