"""Predictions scored against physical experiments: shake-table campaigns, metrics, baselines, reports."""

from __future__ import annotations

from pbr_xval.validation.campaign import (
    Baseline,
    Campaign,
    CampaignError,
    Test,
    baseline_correct,
    load_campaign,
)
from pbr_xval.validation.metrics import Rule, Scores, fit_rule, group_folds, out_of_fold, score

__all__ = [
    "Baseline",
    "Campaign",
    "CampaignError",
    "Rule",
    "Scores",
    "Test",
    "baseline_correct",
    "fit_rule",
    "group_folds",
    "load_campaign",
    "out_of_fold",
    "score",
]
