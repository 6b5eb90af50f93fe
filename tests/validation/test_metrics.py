"""Scores against hand-computed confusion matrices; threshold rules on campaigns with a known best rule."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pbr_xval.validation.metrics import fit_rule, group_folds, out_of_fold, score


def test_scores_match_a_hand_computed_confusion_matrix() -> None:
    obs = [1, 1, 1, 0, 0, 0, 1, 0]
    pred = [1, 0, 1, 1, 0, 0, 1, 0]
    s = score(obs, pred)
    # by hand: TP = tests 0, 2, 6; FN = test 1; FP = test 3; TN = tests 4, 5, 7
    assert (s.tp, s.fn, s.fp, s.tn) == (3, 1, 1, 3)
    assert s.accuracy == pytest.approx(6 / 8)
    assert s.precision == pytest.approx(3 / 4)
    assert s.recall == pytest.approx(3 / 4)
    assert s.f1 == pytest.approx(2 * 3 / (2 * 3 + 1 + 1))


def test_scores_of_a_second_matrix_and_undefined_ratios() -> None:
    s = score([1, 1, 0, 0, 0], [0, 0, 0, 0, 1])  # TP 0, FN 2, FP 1, TN 2
    assert (s.tp, s.fn, s.fp, s.tn) == (0, 2, 1, 2)
    assert s.f1 == 0.0 and s.precision == 0.0 and s.recall == 0.0
    assert s.accuracy == pytest.approx(2 / 5)
    none = score([0, 0, 0], [0, 0, 0])  # nothing toppled, nothing predicted: precision/recall/F1 undefined
    assert math.isnan(none.precision) and math.isnan(none.recall) and math.isnan(none.f1)
    assert none.accuracy == 1.0
    with pytest.raises(ValueError, match="same length"):
        score([1, 0], [1])


def test_single_threshold_rule_recovers_the_known_threshold() -> None:
    pga = np.arange(1.0, 21.0)  # 1 … 20 m/s²
    obs = pga >= 11.0  # the true rule: toppled from 11 up
    rule = fit_rule({"pga": pga}, obs, ["pga"])
    assert rule.thresholds == (10.5,)  # midpoint between 10 and 11
    assert score(obs, rule.predict({"pga": pga})).f1 == 1.0


def test_two_feature_rule_recovers_both_thresholds() -> None:
    a, b = np.meshgrid(np.arange(1.0, 11.0), np.arange(0.1, 1.05, 0.1), indexing="ij")
    a, b = a.ravel(), b.ravel()
    obs = (a >= 6.0) & (b >= 0.45)
    rule = fit_rule({"pga": a, "pgv": b}, obs, ["pga", "pgv"])
    assert rule.thresholds[0] == pytest.approx(5.5)
    assert rule.thresholds[1] == pytest.approx(0.45)
    assert score(obs, rule.predict({"pga": a, "pgv": b})).f1 == 1.0
    # neither single rule can be perfect on this campaign
    for f, v in (("pga", a), ("pgv", b)):
        single = fit_rule({f: v}, obs, [f])
        assert score(obs, single.predict({f: v})).f1 < 1.0


def test_noisy_threshold_is_the_f1_optimum() -> None:
    pga = np.array([1, 2, 3, 4, 5, 6, 7, 8], float)
    obs = np.array([0, 0, 1, 0, 1, 1, 1, 1], bool)  # one early topple at 3, one stand at 4
    rule = fit_rule({"pga": pga}, obs, ["pga"])
    # by hand: threshold 2.5 → TP 6, FP 1, FN 0: F1 12/13; 4.5 → TP 5, FN 1: F1 10/11 < 12/13
    assert rule.thresholds == (2.5,)


def test_group_folds_keep_records_together_and_balance() -> None:
    groups = [f"rec{i % 7}" for i in range(40)]
    folds = group_folds(groups, 4)
    for g in set(groups):
        assert len({f for f, gg in zip(folds, groups, strict=True) if gg == g}) == 1
    sizes = np.bincount(folds, minlength=4)
    assert sizes.min() >= 5 and sizes.max() <= 12
    # independent of row order
    order = np.random.default_rng(0).permutation(40)
    again = group_folds([groups[i] for i in order], 4)
    assert all(again[k] == folds[i] for k, i in enumerate(order))
    with pytest.raises(ValueError, match="cannot make"):
        group_folds(["a", "b"], 3)


def test_out_of_fold_rules_never_see_the_held_out_record() -> None:
    # record r's tests all topple at PGA ≥ 5; one record ("odd") topples from 2 up
    pga = np.tile(np.arange(1.0, 9.0), 5)
    groups = np.repeat(["r0", "r1", "r2", "r3", "odd"], 8).tolist()
    obs = np.where(np.array(groups) == "odd", pga >= 2, pga >= 5)
    folds = group_folds(groups, 5)  # one record per fold
    pred, rules = out_of_fold({"pga": pga}, obs, ["pga"], folds)
    odd = np.array(groups) == "odd"
    # the rule used on "odd" was fitted on the four regular records only: threshold 4.5
    assert rules[int(folds[odd][0])].thresholds == (4.5,)
    assert np.array_equal(pred[odd], pga[odd] >= 4.5)
