"""Scoring a validation run and writing its report (CSV + a self-contained HTML page).

Physics predictions come from a fixed scenario (nothing is fitted on the campaign), so they
are scored on every test. The empirical baselines are threshold rules *fitted* on data, so
they are scored out of fold: the records are split into ``folds`` groups (group k-fold over
the earthquake record, :func:`~pbr_xval.validation.metrics.group_folds`) and each test is
predicted by the rule fitted on the records of the other folds.
"""

from __future__ import annotations

import base64
import html
import io
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pbr_xval.atomic import write_text_atomic
from pbr_xval.units import label
from pbr_xval.validation.campaign import G_STANDARD, Campaign
from pbr_xval.validation.metrics import Scores, fit_rule, group_folds, out_of_fold, score

__all__ = ["BASELINE_RULES", "ValidationResult", "evaluate", "write_report"]

#: name → features of the empirical rules ("toppled if every feature ≥ its threshold")
BASELINE_RULES: dict[str, tuple[str, ...]] = {
    "PGA rule": ("pga",),
    "PGV rule": ("pgv",),
    "PGA-and-PGV rule": ("pga", "pgv"),
}
FEATURE_UNITS = {"pga": "m/s²", "pgv": "m/s"}


@dataclass
class ValidationResult:
    """Everything the report shows. ``outcomes`` has one row per test; ``scores`` one per model."""

    outcomes: pd.DataFrame
    scores: pd.DataFrame
    engines: list[str]
    baseline_source: str
    folds: int
    rules_all: dict[str, str] = field(default_factory=dict)
    failures: dict[str, int] = field(default_factory=dict)
    meta: dict[str, Any] = field(default_factory=dict)


def _features(campaign: Campaign, outcomes: pd.DataFrame, source: str) -> dict[str, np.ndarray]:
    if source == "sheet":
        pga = outcomes["sheet_pga_m_s2"].to_numpy(float)
        return {"pga": pga, "pgv": pga * outcomes["sheet_pgv_over_pga_s"].to_numpy(float)}
    return {"pga": outcomes["pga_m_s2"].to_numpy(float), "pgv": outcomes["pgv_m_s"].to_numpy(float)}


def evaluate(
    campaign: Campaign,
    rows: pd.DataFrame,
    motions: dict[str, Any],
    engines: list[str],
    *,
    folds: int = 4,
    baseline_source: str = "auto",
) -> ValidationResult:
    """Join simulation rows to the tests and score engines and baselines.

    Parameters
    ----------
    rows : catalog store rows (``test``, ``engine``, ``toppled``, ``status``, …).
    motions : test → :class:`~pbr_xval.validation.runner.MotionFile` (PGA m/s², PGV m/s of the
        corrected record).
    baseline_source : ``"sheet"`` (the lab sheet's PGA and PGV/PGA, when every test has them),
        ``"record"`` (the corrected records) or ``"auto"`` (sheet when available).
    """
    recs = []
    for t in campaign.tests:
        m = motions[t.test]
        r = {
            "test": t.test, "motion": t.motion, "observed": int(t.toppled),
            "pga_m_s2": m.pga, "pgv_m_s": m.pgv, "pgv_over_pga_s": m.pgv / m.pga if m.pga > 0 else math.nan,
            "duration_s": m.duration,
        }  # fmt: skip
        if "pga_g" in t.sheet:
            r["sheet_pga_m_s2"] = t.sheet["pga_g"] * G_STANDARD
        if "pgv_over_pga_s" in t.sheet:
            r["sheet_pgv_over_pga_s"] = t.sheet["pgv_over_pga_s"]
        recs.append(r)
    out = pd.DataFrame(recs)
    has_sheet = {"sheet_pga_m_s2", "sheet_pgv_over_pga_s"} <= set(out.columns) and bool(
        out[["sheet_pga_m_s2", "sheet_pgv_over_pga_s"]].notna().all().all()
    )
    if baseline_source == "auto":
        baseline_source = "sheet" if has_sheet else "record"
    if baseline_source == "sheet" and not has_sheet:
        raise ValueError("baseline source 'sheet' needs pga_g and pgv_over_pga_s for every test")
    n_groups = out["motion"].nunique()
    k = min(int(folds), n_groups)
    out["fold"] = group_folds(out["motion"].tolist(), k) if k >= 2 else 0

    score_rows = []
    failures = {}
    observed = out["observed"].to_numpy(bool)
    for eng in engines:
        sub = rows[rows["engine"] == eng].drop_duplicates("test", keep="last").set_index("test")
        pred = [sub.loc[t, "toppled"] if t in sub.index else None for t in out["test"]]
        status = [sub.loc[t, "status"] if t in sub.index else "missing" for t in out["test"]]
        out[f"pred_{eng}"] = [None if s != "ok" else int(bool(p)) for p, s in zip(pred, status, strict=True)]
        out[f"status_{eng}"] = status
        out[f"wall_s_{eng}"] = [
            float(sub.loc[t, "wall_s"]) if t in sub.index else math.nan for t in out["test"]
        ]
        ok = np.array([s == "ok" for s in status])
        failures[eng] = int((~ok).sum())
        p = np.array([bool(x) if x is not None else False for x in out[f"pred_{eng}"]])
        s = score(observed[ok], p[ok])
        score_rows.append(
            {"model": eng, "kind": "physics", "evaluated_on": "all tests (no fitting)", **s.to_dict()}
        )
    feats = _features(campaign, out, baseline_source)
    rules_all = {}
    for name, fs in BASELINE_RULES.items():
        if k >= 2:
            rule_pred, _ = out_of_fold(feats, observed, fs, out["fold"].to_numpy())
            where = f"out of fold ({k}-fold by record)"
        else:
            rule_pred = fit_rule(feats, observed, fs).predict(feats)
            where = "in sample (fewer than 2 records: no held-out part)"
        out[f"pred_{name}"] = rule_pred.astype(int)
        s = score(observed, rule_pred)
        score_rows.append({"model": name, "kind": "empirical", "evaluated_on": where, **s.to_dict()})
        rules_all[name] = fit_rule(feats, observed, fs).describe(FEATURE_UNITS)
    return ValidationResult(
        outcomes=out, scores=pd.DataFrame(score_rows), engines=list(engines),
        baseline_source=baseline_source, folds=k, rules_all=rules_all, failures=failures,
    )  # fmt: skip


# ------------------------------------------------------------------ output
def _plane_figure(res: ValidationResult) -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = res.outcomes
    n = max(1, len(res.engines))
    fig, axes = plt.subplots(1, n, figsize=(5.2 * n, 4.4), squeeze=False)
    x = out["pga_m_s2"].to_numpy(float)
    y = out["pgv_over_pga_s"].to_numpy(float)
    obs = out["observed"].to_numpy(bool)
    for ax, eng in zip(axes[0], res.engines or ["(none)"], strict=False):
        pred = out.get(f"pred_{eng}")
        for o, marker, name in ((True, "o", "toppled"), (False, "s", "stood")):
            sel = obs == o
            if pred is None:
                ax.scatter(
                    x[sel],
                    y[sel],
                    marker=marker,
                    facecolors="none",
                    edgecolors="0.4",
                    label=f"observed {name}",
                )
                continue
            pv = pred.to_numpy(object)
            right = sel & np.array([p is not None and bool(p) == o for p in pv])
            wrong = sel & np.array([p is not None and bool(p) != o for p in pv])
            none = sel & np.array([p is None for p in pv])
            ax.scatter(
                x[right], y[right], marker=marker, c="C2", s=24, label=f"observed {name}, predicted {name}"
            )
            ax.scatter(x[wrong], y[wrong], marker=marker, c="C3", s=24, label=f"observed {name}, predicted {'stood' if o else 'toppled'}")  # fmt: skip
            if none.any():
                ax.scatter(x[none], y[none], marker="x", c="0.3", s=24, label=f"observed {name}, run failed")
        if np.all(x[np.isfinite(x)] > 0) and np.nanmax(x) > 5 * np.nanmin(x):
            ax.set_xscale(
                "log"
            )  # table records of toppling tests carry impact spikes up to ~4× the sheet PGA
        ax.set_xlabel(label("pga"))
        ax.set_ylabel(label("pgv_over_pga"))
        ax.set_title(f"{eng}: predicted vs observed")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="upper right")
    fig.tight_layout()
    return fig


def _png(fig: Any) -> str:
    import matplotlib.pyplot as plt

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    plt.close(fig)
    return base64.b64encode(buf.getvalue()).decode()


def f1_lines(res: ValidationResult) -> list[str]:
    """``F1 <engine> <value>`` for every engine (the line format scripts read)."""
    s = res.scores.set_index("model")
    return [f"F1 {e} {s.loc[e, 'f1']:.4f}" for e in res.engines]


def write_report(res: ValidationResult, out: Path, meta: dict[str, Any]) -> dict[str, Path]:
    """Write ``outcomes.csv``, ``scores.csv``, ``validation.json`` and ``index.html`` (atomically)."""
    out.mkdir(parents=True, exist_ok=True)
    paths = {
        "outcomes": write_text_atomic(out / "outcomes.csv", res.outcomes.to_csv(index=False)),
        "scores": write_text_atomic(out / "scores.csv", res.scores.to_csv(index=False)),
    }
    doc = {
        **meta,
        "baseline_source": res.baseline_source,
        "folds": res.folds,
        "rules_fitted_on_all_tests": res.rules_all,
        "failed_runs": res.failures,
        "scores": json.loads(res.scores.to_json(orient="records")),
    }
    paths["json"] = write_text_atomic(out / "validation.json", json.dumps(doc, indent=2, default=str))
    img = _png(_plane_figure(res))
    sc = res.scores.copy()
    for c in ("accuracy", "precision", "recall", "f1"):
        sc[c] = sc[c].map(lambda v: "—" if v != v else f"{v:.3f}")
    cm_rows = "".join(
        f"<tr><td>{html.escape(str(r.model))}</td><td>{r.tp}</td><td>{r.fn}</td><td>{r.fp}</td><td>{r.tn}</td></tr>"
        for r in res.scores.itertuples()
    )
    meta_rows = "".join(
        f"<tr><th>{html.escape(str(k))}</th><td>{html.escape(str(v))}</td></tr>" for k, v in meta.items()
    )
    rules = "".join(f"<li>{html.escape(k)}: {html.escape(v)}</li>" for k, v in res.rules_all.items())
    fails = ", ".join(f"{k}: {v}" for k, v in res.failures.items())
    page = f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>pbr-xval validate: {html.escape(str(meta.get("scenario", "")))}</title>
<style>body{{font-family:sans-serif;max-width:1200px;margin:1em auto;padding:0 1em}}
table{{border-collapse:collapse;font-size:13px}}td,th{{border:1px solid #ccc;padding:2px 6px;text-align:right}}
th{{background:#f4f4f4}}</style></head><body>
<h1>Predictions scored against shake-table experiments</h1>
<table>{meta_rows}</table>
<h2>Scores</h2>
<p>Physics: a fixed scenario, scored on every test (runs that failed are left out: {html.escape(fails)}).
Empirical rules ("toppled if every feature ≥ its threshold", intensity measures from the
{html.escape(res.baseline_source)}): fitted on the calibration part and scored on the held-out part,
{res.folds}-fold by earthquake record (every test is predicted by a rule fitted on the other records).</p>
{sc.to_html(index=False, escape=True)}
<h3>Confusion matrices (positive = toppled)</h3>
<table><tr><th>model</th><th>TP (observed toppled, predicted toppled)</th><th>FN (observed toppled, predicted stood)</th>
<th>FP (observed stood, predicted toppled)</th><th>TN</th></tr>{cm_rows}</table>
<p>Rules fitted on all tests (for reference, not scored): </p><ul>{rules}</ul>
<h2>Outcomes on the PGA × PGV/PGA plane</h2>
<p>x: {html.escape(label("pga"))} of the corrected table record; y: {html.escape(label("pgv_over_pga"))}.
Green: predicted as observed; red: predicted wrongly; circles: observed toppled; squares: observed standing.</p>
<img alt="outcomes on the PGA x PGV/PGA plane" src="data:image/png;base64,{img}">
<h2>Per-test outcomes</h2>
{res.outcomes.to_html(index=False, escape=True, float_format=lambda v: f"{v:.4g}")}
</body></html>
"""
    paths["html"] = write_text_atomic(out / "index.html", page)
    return paths


__all__ += ["Scores", "f1_lines"]
