"""pbr_xval.validation.robustness: fragile tests, F1 per variant, what a guard may pin."""

from __future__ import annotations

import pandas as pd
import pytest

from pbr_xval.validation.robustness import f1_range, fragility_table, main, summarise


def _oc(pred: list[int]) -> pd.DataFrame:
    return pd.DataFrame({"test": ["1", "2", "3", "4"], "observed": [1, 1, 0, 0], "pred_e": pred})


def test_fragile_tests_are_those_any_variant_flips() -> None:
    t = fragility_table(
        {"base": _oc([1, 0, 0, 1]), "tilt": _oc([1, 1, 0, 1]), "dt+1%": _oc([1, 0, 0, 0])}, "e"
    )
    assert t["fragile"].tolist() == [False, True, False, True]
    s = summarise(t, ["base", "tilt", "dt+1%"])
    assert s["fragile"] == 2 and s["fragile_share"] == 0.5 and s["fragile_tests"] == ["2", "4"]
    assert s["robust_outcomes"] == {"1": 1, "3": 0}
    # F1 = 2TP / (2TP + FP + FN): base TP 1 FP 1 FN 1 → 0.5; tilt TP 2 FP 1 → 0.8; dt+1% TP 1 FN 1 → 2/3
    assert s["f1"] == pytest.approx({"base": 0.5, "tilt": 0.8, "dt+1%": 2 / 3})


def test_variants_are_checked_before_anything_runs(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        main(["x", "--scenario", "s.toml", "--engine", "housner", "--out", "o", "--variants", "base,wobble"])
    assert "wobble" in capsys.readouterr().err


def test_f1_range_over_the_fragile_tests() -> None:
    observed = {"1": 1, "2": 1, "3": 0, "4": 0, "5": 1}
    robust = {"1": 1, "3": 0, "4": 1}  # TP 1, FP 1
    lo, hi = f1_range(observed, robust, ["2", "5"])  # both topple in the lab
    assert lo == pytest.approx(2 / (2 + 1 + 2))  # both missed: TP 1, FP 1, FN 2
    assert hi == pytest.approx(6 / (6 + 1))  # both caught: TP 3, FP 1
    assert f1_range(observed, robust, []) == (pytest.approx(2 / 3), pytest.approx(2 / 3))
