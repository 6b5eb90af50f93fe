"""Calibration of a specimen's uncertain parameters, cross-validated by earthquake record.

The physically uncertain scenario keys (shaking azimuth relative to the scan, friction,
contact settings …) are set on a coarse grid of variants. Each variant is a full scenario,
run through the same machinery as ``pbr-xval validate`` (one store: nothing is recomputed).

Cross-validation (nested, grouped by record, never by test): the records are dealt into
``folds`` groups (:func:`~pbr_xval.validation.metrics.group_folds`). For each fold, the variant
with the best F1 on the *screening tests of the other folds' records* is chosen, and its
predictions on *every* test of the held-out records are scored. The pooled held-out
predictions give the cross-validated F1. Screening on a named subset of tests (every
``stride``-th test of the campaign) keeps the grid affordable; the chosen variants are then run
on the held-out records in full.

Usage (from the repository root)::

    python -m pbr_xval.validation.calibrate ../shared/data/shake_table --specimen 1 \\
        --scenario examples/validation/sp1.toml --engine mujoco --out runs/calibrate_sp1 \\
        --grid excitation.azimuth_deg=335,0,30 --stride 3

A second stage varies other keys one at a time around the chosen base (``--one-at-a-time``,
e.g. ``--grid contact.friction_static=0.4 --grid contact.restitution=0.3``).
"""

from __future__ import annotations

import argparse
import json
import math
import re
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pbr_xval.atomic import write_text_atomic
from pbr_xval.validation.campaign import Baseline, Campaign, load_campaign
from pbr_xval.validation.metrics import group_folds, score

__all__ = ["cross_validate", "screening_subset", "variant_scenario"]


def screening_subset(campaign: Campaign, stride: int) -> list[str]:
    """Every ``stride``-th test of the campaign, in campaign order (the screening tests)."""
    return [t.test for t in campaign.tests[:: max(1, int(stride))]]


def _label(params: dict[str, Any]) -> str:
    return "__".join(f"{k.rsplit('.', 1)[-1]}={v}" for k, v in params.items())


def variant_scenario(base: Any, params: dict[str, Any]) -> Any:
    """A copy of scenario ``base`` with dotted ``params`` set and a name that says which.

    A variant equal to ``base`` is ``base`` itself (same name, so its stored runs are shared
    with ``pbr-xval validate`` on the base scenario).
    """
    if all(base.get_value(k) == v for k, v in params.items()):
        return base
    scn = base
    for k, v in params.items():
        scn = scn.with_value(k, v)
    name = re.sub(r"[^A-Za-z0-9_.\-]", "_", f"{base.name}__{_label(params)}")
    return scn.with_value("name", name)


def cross_validate(
    predictions: dict[str, pd.Series],
    observed: pd.Series,
    groups: pd.Series,
    screening: set[str],
    folds: int,
) -> tuple[pd.Series, list[dict[str, Any]]]:
    """Nested record-grouped cross-validation over variants.

    Parameters
    ----------
    predictions : variant label → predicted toppled (index: test; NaN where not run).
    observed, groups : index test → observed outcome / record name.
    screening : tests used to choose the variant (within the training records).
    folds : number of record folds.

    Returns
    -------
    held-out predictions (index test; NaN where the chosen variant was not run) and, per fold,
    the chosen variant and its training F1.
    """
    f = pd.Series(group_folds(groups.tolist(), folds), index=groups.index)
    held_pred = pd.Series(np.nan, index=observed.index)
    info = []
    for k in range(folds):
        train = [t for t in observed.index if f[t] != k and t in screening]
        best, best_f1 = None, -1.0
        for lab, p in predictions.items():
            ok = [t for t in train if not pd.isna(p.get(t, np.nan))]
            if len(ok) < len(train):  # a variant not run on every screening test cannot be chosen
                continue
            s = score(observed[ok].astype(bool), p[ok].astype(bool))
            f1 = -1.0 if math.isnan(s.f1) else s.f1
            if f1 > best_f1:
                best, best_f1 = lab, f1
        held = [t for t in observed.index if f[t] == k]
        if best is not None:
            held_pred[held] = predictions[best].reindex(held).to_numpy()
        info.append({"fold": k, "chosen": best, "train_f1": best_f1, "held_out_tests": len(held)})
    return held_pred, info


def main(argv: list[str] | None = None) -> int:
    from pbr_xval.scenario import load_scenario
    from pbr_xval.validation.campaign_report import evaluate
    from pbr_xval.validation.execution import run_campaign

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("campaign", type=Path)
    ap.add_argument("--specimen", type=int, required=True)
    ap.add_argument("--scenario", type=Path, required=True)
    ap.add_argument("--engine", required=True)
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument(
        "--grid", action="append", default=[], help="key=v1,v2,... (repeatable; cartesian product)"
    )
    ap.add_argument(
        "--one-at-a-time",
        action="store_true",
        help="variants: the base and each grid value alone (no product)",
    )
    ap.add_argument("--stride", type=int, default=3, help="screening tests: every N-th test")
    ap.add_argument("--folds", type=int, default=4)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--full", action="append", default=[], help="variant labels to run on every test")
    ap.add_argument("--stage", choices=["screen", "heldout", "report"], default="report")
    a = ap.parse_args(argv)

    camp = load_campaign(a.campaign, a.specimen)
    base = load_scenario(a.scenario)
    grid: list[dict[str, Any]] = [{}]
    for g in a.grid:
        key, _, vals = g.partition("=")
        if a.one_at_a_time:  # the base plus each value of each key alone
            grid += [{key: json.loads(v)} for v in vals.split(",")]
        else:  # cartesian product
            grid = [{**p, key: json.loads(v)} for p in grid for v in vals.split(",")]
    variants = {(_label(p) or "base"): variant_scenario(base, p) for p in grid}
    screening = screening_subset(camp, a.stride)
    baseline = Baseline()
    obs = pd.Series({t.test: int(t.toppled) for t in camp.tests})
    groups = pd.Series({t.test: t.motion for t in camp.tests})

    def run(lab: str, tests: list[str]) -> pd.Series:
        sub = camp.select(tests)
        rows, _motions, _ = run_campaign(
            sub, variants[lab], [a.engine], a.out, baseline=baseline, workers=a.workers, progress=False
        )
        ok = rows[rows["status"] == "ok"].drop_duplicates("test", keep="last").set_index("test")
        return ok["toppled"].astype(float).reindex(tests)

    preds: dict[str, pd.Series] = {}
    for lab in variants:  # screening: cheap, every variant
        preds[lab] = run(lab, screening).reindex(obs.index)
    if a.stage == "screen":
        print(json.dumps({lab: int(p.notna().sum()) for lab, p in preds.items()}))
        return 0
    held, info = cross_validate(preds, obs, groups, set(screening), a.folds)
    # run the chosen variant of each fold on its held-out records in full
    fidx = pd.Series(group_folds(groups.tolist(), a.folds), index=groups.index)
    for fi in info:
        if fi["chosen"] is None:
            continue
        tests = [t for t in obs.index if fidx[t] == fi["fold"]]
        p = run(fi["chosen"], tests)
        preds[fi["chosen"]] = preds[fi["chosen"]].combine_first(p.reindex(obs.index))
    for lab in a.full:
        preds[lab] = preds[lab].combine_first(run(lab, list(obs.index)).reindex(obs.index))
    held, info = cross_validate(preds, obs, groups, set(screening), a.folds)
    ok = held.notna()
    cv = score(obs[ok].astype(bool), held[ok].astype(bool))
    # baselines on the same folds (rules refitted per fold on the training records)
    from pbr_xval.validation.execution import prepare_motions

    motions = prepare_motions(camp, baseline, a.out / "motions")
    res = evaluate(camp, pd.DataFrame(columns=["test", "engine"]), motions, [], folds=a.folds)
    sens = {}
    for lab, p in preds.items():
        on = [t for t in screening if not pd.isna(p.get(t))]
        s_scr = score(obs[on].astype(bool), p[on].astype(bool))
        full = [t for t in obs.index if not pd.isna(p.get(t))]
        s_full = score(obs[full].astype(bool), p[full].astype(bool))
        sens[lab] = {
            "screening_f1": s_scr.f1,
            "screening_n": s_scr.n,
            "f1_all_run": s_full.f1,
            "n_run": s_full.n,
        }
    doc = {
        "specimen": a.specimen,
        "engine": a.engine,
        "scenario": str(a.scenario),
        "grid": grid,
        "screening": f"every {a.stride}th test ({len(screening)} tests)",
        "folds": a.folds,
        "fold_choices": info,
        "cv": {**cv.to_dict(), "n_missing": int((~ok).sum())},
        "variants": sens,
        "baselines": json.loads(res.scores.to_json(orient="records")),
        "baseline_correction": baseline.describe(),
    }
    write_text_atomic(a.out / "calibration.json", json.dumps(doc, indent=2, default=str))
    print(json.dumps(doc, indent=2, default=str))
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
