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

__all__ = [
    "BASELINE_RULES",
    "CALIBRATION_SUFFIX",
    "ValidationResult",
    "add_calibration_baselines",
    "calibration_source",
    "campaign_ims",
    "evaluate",
    "write_report",
]

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


def _features(outcomes: pd.DataFrame, source: str) -> dict[str, np.ndarray]:
    """The rules' and logistic laws' intensity measures of the rows of ``outcomes``: PGA (m/s²) and PGV
    (m/s), shape (tests,), from the lab sheet (``source == "sheet"``) or the corrected records."""
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
    motions : test → :class:`~pbr_xval.validation.execution.MotionFile` (PGA m/s², PGV m/s of the
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
    feats = _features(out, baseline_source)
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
    _add_probabilistic(out, score_rows, feats, k)  # brier/log_loss/auc columns; logistic baselines
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


def _calibration_note(res: ValidationResult) -> str:
    """The HTML sentence on the ``…@calibration`` models (``--calibration``), or nothing."""
    c = res.meta.get("calibration")
    if not c:
        return ""
    shared = (
        f"; {len(c['shared_tests'])} of its tests are also here (in sample for those)"
        if c["shared_tests"]
        else ""
    )
    return (
        f"<p>Models ending in <code>{CALIBRATION_SUFFIX}</code>: the rules and logistic laws fitted on every "
        f"test of {html.escape(str(c['campaign']))} (specimen {c['specimen']}: {c['tests']} tests, "
        f"{c['toppled']} toppled{html.escape(shared)}) and applied unchanged to these tests — no test "
        "scored here entered their fit.</p>"
    )


def write_report(res: ValidationResult, out: Path, meta: dict[str, Any]) -> dict[str, Path]:
    """Write ``outcomes.csv``, ``scores.csv``, ``bands.csv``, ``validation.json`` and ``index.html`` (atomically)."""
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
        **({"transferred": res.meta["transferred"]} if "transferred" in res.meta else {}),
        **({"calibration": res.meta["calibration"]} if "calibration" in res.meta else {}),
    }
    paths["json"] = write_text_atomic(out / "validation.json", json.dumps(doc, indent=2, default=str))
    img = _png(_plane_figure(res))
    prob = _probabilistic_section(res, out)  # issue 22: Brier, log loss, AUC; reliability; P on the plane
    bands = band_table(res)
    paths["bands"] = write_text_atomic(out / "bands.csv", bands.to_csv(index=False))
    sc = res.scores.copy()
    for c in ("accuracy", "precision", "recall", "f1", *PROB_COLUMNS):
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
    from pbr_xval.study.verdicts import validation_block  # issue 24: the verdict on the first screen

    verdict = validation_block(res.scores, res.outcomes, res.engines, meta)
    page = f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>pbr-xval validate: {html.escape(str(meta.get("scenario", "")))}</title>
<style>body{{font-family:sans-serif;max-width:1200px;margin:1em auto;padding:0 1em}}
table{{border-collapse:collapse;font-size:13px}}td,th{{border:1px solid #ccc;padding:2px 6px;text-align:right}}
th{{background:#f4f4f4}}</style></head><body>
<h1>Predictions scored against shake-table experiments</h1>
{verdict}
<details><summary>Run details</summary><table>{meta_rows}</table></details>
<h2>Scores</h2>
<p>Physics: a fixed scenario, scored on every test (runs that failed are left out: {html.escape(fails)}).
Empirical rules ("toppled if every feature ≥ its threshold", intensity measures from the
{html.escape(res.baseline_source)}): fitted on the calibration part and scored on the held-out part,
{res.folds}-fold by earthquake record (every test is predicted by a rule fitted on the other records).</p>
{_calibration_note(res)}
{sc.to_html(index=False, escape=True)}
<h3>Confusion matrices (positive = toppled)</h3>
<table><tr><th>model</th><th>TP (observed toppled, predicted toppled)</th><th>FN (observed toppled, predicted stood)</th>
<th>FP (observed stood, predicted toppled)</th><th>TN</th></tr>{cm_rows}</table>
<p>Rules fitted on all tests (for reference, not scored): </p><ul>{rules}</ul>
{prob}
{_bands_section(bands)}
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


# ------------------------------------------------------------------ errors by band of PGV/PGA (issue 22)
#: bands of PGV/PGA in :func:`band_table`: equal counts of tests (quantiles)
N_BANDS = 4


def band_table(res: ValidationResult, n_bands: int = N_BANDS) -> pd.DataFrame:
    """Observed topples against each model's per band of PGV/PGA — where a model's errors sit.

    A level error (a rock too stable everywhere: its critical angle, its support) moves every band
    alike; an error whose sign changes from band to band (too fragile to short-period shaking, too
    stable to longer periods) is a frequency dependence that no level fixes (docs/validation.md,
    "Why is the model rock too stable?"). PGV/PGA (s) is that of the rules' intensity measures
    (``res.baseline_source``: the lab sheet or the corrected records); the band edges are its
    quantiles over the tests (``n_bands`` bands of about equal counts; fewer where values tie).

    Returns
    -------
    DataFrame, one row per band: ``pgv_over_pga_lo_s``, ``pgv_over_pga_hi_s`` (s; the first band
    includes its lower edge), ``tests``, ``observed`` (topples), then per model its topples in the
    band: a deterministic engine's or rule's predicted count (``pred_<model>`` summed over its
    scored tests; failed runs count as no prediction) and a probabilistic model's expected count
    (``p_<model>`` summed: the ensemble, the logistic laws, the transferred law).
    """
    oc = res.outcomes
    col = "sheet_pgv_over_pga_s" if res.baseline_source == "sheet" else "pgv_over_pga_s"
    columns = ["pgv_over_pga_lo_s", "pgv_over_pga_hi_s", "tests", "observed"]
    models = [c for c in oc.columns if c.startswith(("pred_", "p_"))]
    ratio = pd.to_numeric(oc[col], errors="coerce").to_numpy(float) if col in oc else np.full(len(oc), np.nan)
    ok = np.isfinite(ratio)
    if not ok.any():
        return pd.DataFrame(columns=columns + [c.split("_", 1)[1] for c in models])
    edges = np.unique(np.quantile(ratio[ok], np.linspace(0.0, 1.0, n_bands + 1)))
    if edges.size == 1:
        edges = np.array([edges[0], edges[0]])
    band = np.clip(np.searchsorted(edges, ratio, side="left") - 1, 0, edges.size - 2)
    obs = oc["observed"].to_numpy(float)
    counts = {c.split("_", 1)[1]: pd.to_numeric(oc[c], errors="coerce").to_numpy(float) for c in models}
    rows = []
    for b in range(edges.size - 1):
        m = ok & (band == b)
        row: dict[str, Any] = {
            "pgv_over_pga_lo_s": float(edges[b]),
            "pgv_over_pga_hi_s": float(edges[b + 1]),
            "tests": int(m.sum()),
            "observed": int(obs[m].sum()),
        }
        row.update({name: float(np.nansum(v[m])) for name, v in counts.items()})
        rows.append(row)
    return pd.DataFrame(rows)


def _bands_section(bands: pd.DataFrame) -> str:
    if bands.empty:
        return ""
    shown = bands.copy()
    for c in shown.columns[4:]:
        shown[c] = shown[c].map(lambda v: f"{v:.1f}")
    shown.insert(
        0,
        "PGV/PGA band [s]",
        [f"{lo:.3f}–{hi:.3f}" for lo, hi in zip(bands.iloc[:, 0], bands.iloc[:, 1], strict=True)],
    )
    shown = shown.drop(columns=["pgv_over_pga_lo_s", "pgv_over_pga_hi_s"]).rename(
        columns={"tests": "tests [–]", "observed": "observed topples [–]"}
    )
    return (
        "<h2>Errors by band of PGV/PGA</h2><p>Observed topples against each model's predicted (0/1 models) or "
        "expected (probabilistic models: the sum of P) topples per band of PGV/PGA (the rules' intensity "
        "measures; bands of about equal test counts; data in bands.csv). A model too stable or too fragile "
        "everywhere errs the same way in every band; an error that changes sign from band to band is a "
        "frequency dependence that no change of level (critical angle, support) removes.</p>"
        f"{shown.to_html(index=False, escape=True)}"
    )


__all__ += ["N_BANDS", "band_table"]


# ------------------------------------------------------------------ probabilistic scores (issue 22)
#: columns of scores.csv added by the probabilistic scores (every model: 0/1 predictions included)
PROB_COLUMNS = ("brier", "log_loss", "auc")


def _prob_cols(observed: np.ndarray, p: np.ndarray) -> dict[str, float]:
    """Brier, log loss, AUC (:func:`~pbr_xval.validation.scores.probabilistic_scores`); NaN with no test."""
    from pbr_xval.validation.scores import probabilistic_scores

    if observed.size == 0:
        return dict.fromkeys(PROB_COLUMNS, math.nan)
    s = probabilistic_scores(observed, p)
    return {c: s[c] for c in PROB_COLUMNS}


def _prob_row(name: str, kind: str, where: str, observed: np.ndarray, p: np.ndarray) -> dict[str, Any]:
    ok = np.isfinite(p)
    s = score(observed[ok].astype(bool), p[ok] >= 0.5)
    return {
        "model": name,
        "kind": kind,
        "evaluated_on": where,
        **s.to_dict(),
        **_prob_cols(observed[ok], p[ok]),
    }


def _add_probabilistic(
    out: pd.DataFrame, score_rows: list[dict[str, Any]], feats: dict[str, np.ndarray], k: int
) -> None:
    """Brier / log loss / AUC of every 0/1 model so far, then the logistic baselines (out of fold)."""
    from pbr_xval.validation.scores import logistic_baselines

    obs = out["observed"].to_numpy(int)
    for row in score_rows:
        col = out[f"pred_{row['model']}"]
        ok = col.notna().to_numpy()
        row.update(_prob_cols(obs[ok], col[ok].to_numpy(float)))
    usable = all(np.all(np.isfinite(v) & (v > 0)) for v in feats.values())
    if k < 2 or not usable or len(set(obs.tolist())) < 2:
        return  # no held-out part, a zero or missing intensity measure, or one outcome only
    where = f"out of fold ({k}-fold by record)"
    for name, p in logistic_baselines(feats["pga"], feats["pgv"], obs, out["fold"].to_numpy()).items():
        out[f"p_{name}"] = p
        score_rows.append(_prob_row(name, "logistic", where, obs, p))


def add_model(res: ValidationResult, name: str, p: Any, *, kind: str, evaluated_on: str) -> None:
    """Add a probabilistic model to a result: column ``p_<name>`` of the outcomes and a scores row.

    Parameters
    ----------
    name : the model's name, printed in ``Brier <name> <value>`` (spaces become ``_`` there).
    p : (n,) P(topple) [–] per test in the order of ``res.outcomes``; NaN for a test without a
        prediction (e.g. every member failed): left out of the scores.
    kind : e.g. ``"ensemble"``, ``"transferred"``; evaluated_on : how it was held out.

    The row carries F1 and the confusion counts at P ≥ 0.5, and Brier / log loss / AUC.
    """
    q = np.asarray(p, dtype=float)
    if q.shape != (len(res.outcomes),):
        raise ValueError(f"p {q.shape}: expected one probability per test ({len(res.outcomes)})")
    res.outcomes[f"p_{name}"] = q
    row = _prob_row(name, kind, evaluated_on, res.outcomes["observed"].to_numpy(int), q)
    res.scores = pd.concat([res.scores[res.scores["model"] != name], pd.DataFrame([row])], ignore_index=True)


def campaign_ims(camp: Campaign, source: str, baseline: Any = None) -> tuple[np.ndarray, np.ndarray]:
    """The intensity measures of a campaign's tests as the rules use them: (PGA m/s², PGV m/s), (n,) each.

    ``source`` ``"sheet"``: the lab sheet's PGA (g → m/s² with standard gravity) and PGA·(PGV/PGA);
    ``"record"``: peak |a| and peak |v| of each record after ``baseline`` (a
    :class:`~pbr_xval.validation.campaign.Baseline`; the default one if None), v by the trapezoid rule.
    """
    from pbr_xval.validation.campaign import Baseline, baseline_correct, record_pgv

    if source == "sheet":
        pga = np.array([t.sheet["pga_g"] * G_STANDARD for t in camp.tests])
        return pga, pga * np.array([t.sheet["pgv_over_pga_s"] for t in camp.tests])
    base = baseline or Baseline()
    ims = []
    for t in camp.tests:
        acc, dt = baseline_correct(*t.raw_acceleration(), base)
        ims.append((float(np.max(np.abs(acc))), record_pgv(acc, dt)))
    pga, pgv = (np.array(c) for c in zip(*ims, strict=True))
    return pga, pgv


#: suffix of the models fitted on another campaign (``--calibration``): ``logistic(lnPGA)@calibration``
CALIBRATION_SUFFIX = "@calibration"


def calibration_source(spec: str, specimen: int) -> tuple[str, int]:
    """``--calibration CAMPAIGN[:SPECIMEN]`` → (campaign path, specimen); ``specimen`` when none is given."""
    head, sep, tail = spec.rpartition(":")
    return (head, int(tail)) if sep and tail.strip().isdigit() else (spec, int(specimen))


def add_calibration_baselines(
    res: ValidationResult, spec: str, specimen: int, *, baseline: Any = None
) -> dict[str, Any]:
    """Add the empirical baselines fitted on *another* campaign: ``--calibration CAMPAIGN[:SPECIMEN]``.

    The split a held-out evaluation needs: the threshold rules and the three logistic laws are fitted
    on every test of the calibration campaign (e.g. the calibration half of a shake-table campaign)
    and applied, unchanged, to this campaign's tests (e.g. the held-out half) — no test of this
    campaign enters a fit. They join the scores as ``<model>@calibration`` (``PGV rule@calibration``,
    ``logistic(lnPGA,lnPGV)@calibration``) beside the out-of-fold ones, with F1 at P ≥ 0.5 and
    Brier / log loss / AUC. The intensity measures are the rules' (``res.baseline_source``; the
    calibration campaign's records corrected with ``baseline``). ``SPECIMEN`` defaults to
    ``specimen``. Returns what the report records (the campaign, its specimen and size, the tests
    both campaigns share — in sample for those — and each rule as fitted).
    """
    from pbr_xval.validation.campaign import load_campaign
    from pbr_xval.validation.scores import LOGISTIC_MODELS, _ln_ims, fit_logistic

    src_path, src_spec = calibration_source(spec, specimen)
    camp = load_campaign(src_path, src_spec)
    pga, pgv = campaign_ims(camp, res.baseline_source, baseline)
    obs = np.array([int(t.toppled) for t in camp.tests])
    if len(set(obs.tolist())) < 2:
        raise ValueError(f"{src_path}: specimen {src_spec} has one outcome only; the baselines need both")
    target = _features(res.outcomes, res.baseline_source)  # this campaign's tests, same IMs
    shared = sorted({t.test for t in camp.tests} & set(res.outcomes["test"].astype(str)))
    where = f"fitted on every test of {src_path} (specimen {src_spec}, {len(obs)} tests)"
    if shared:
        where += f"; {len(shared)} test(s) of this campaign among them (in sample)"
    o = res.outcomes["observed"].to_numpy(int)
    rows, rules = [], {}
    src_feats = {"pga": pga, "pgv": pgv}
    for name, fs in BASELINE_RULES.items():
        rule = fit_rule(src_feats, obs.astype(bool), fs)
        pred = rule.predict(target).astype(int)
        col = name + CALIBRATION_SUFFIX
        res.outcomes[f"pred_{col}"] = pred
        rows.append(_prob_row(col, "empirical", where, o, pred.astype(float)))  # its 0/1 as P
        rules[col] = rule.describe(FEATURE_UNITS)
    usable = all(np.all(np.isfinite(v) & (v > 0)) for v in (pga, pgv, target["pga"], target["pgv"]))
    fits = {}
    if usable:  # else (a zero or missing IM has no logarithm) the rules only, as evaluate() does
        ln_s, ln_t = _ln_ims(pga, pgv), _ln_ims(target["pga"], target["pgv"])
        for name, feats in LOGISTIC_MODELS.items():
            fit = fit_logistic(np.column_stack([ln_s[f] for f in feats]), obs)
            p = fit.predict(np.column_stack([ln_t[f] for f in feats]))
            col = name + CALIBRATION_SUFFIX
            res.outcomes[f"p_{col}"] = p
            rows.append(_prob_row(col, "logistic", where, o, p))
            fits[col] = {"features": list(feats), "intercept": fit.intercept, "coef": list(fit.coef)}
    res.scores = pd.concat(
        [res.scores[~res.scores["model"].isin([r["model"] for r in rows])], pd.DataFrame(rows)],
        ignore_index=True,
    )
    info = {
        "campaign": str(src_path),
        "specimen": src_spec,
        "tests": len(obs),
        "toppled": int(obs.sum()),
        "shared_tests": shared,
        "rules": rules,
        "logistic": fits,
    }
    res.meta["calibration"] = info
    return info


def add_transferred(
    res: ValidationResult, target_scenario: Path, spec: str, *, baseline: Any = None
) -> dict[str, Any]:
    """Add the transferred baseline (:func:`~pbr_xval.validation.scores.transferred_baseline`).

    ``spec`` is ``CAMPAIGN:SPECIMEN:SCENARIO`` (the ``--transfer`` value): the source campaign,
    the source specimen and its scenario (for its geometry). The intensity measures are those of
    the rules (``res.baseline_source``: the lab sheet's, or the corrected records' under
    ``baseline``, a :class:`~pbr_xval.validation.campaign.Baseline`); the geometry of both rocks is
    α_min over all directions (:meth:`~pbr_xval.validation.scores.RockGeometry.from_scenario`).
    Returns what the report records (the fit, both geometries).
    """
    from pbr_xval.validation.campaign import load_campaign
    from pbr_xval.validation.scores import RockGeometry, transferred_baseline

    parts = spec.split(":")
    if len(parts) < 3 or not parts[-2].strip().isdigit():
        raise ValueError(f"--transfer {spec!r}: expected CAMPAIGN:SPECIMEN:SCENARIO (e.g. data:2:sp2.toml)")
    src_campaign, src_specimen, src_scenario = ":".join(parts[:-2]), int(parts[-2]), Path(parts[-1])
    camp = load_campaign(src_campaign, src_specimen)
    pga, pgv = campaign_ims(camp, res.baseline_source, baseline)
    source = pd.DataFrame({"pga": pga, "pgv": pgv, "observed": [int(t.toppled) for t in camp.tests]})
    o = res.outcomes
    if res.baseline_source == "sheet":
        t_pga = o["sheet_pga_m_s2"].to_numpy(float)
        target = pd.DataFrame({"pga": t_pga, "pgv": t_pga * o["sheet_pgv_over_pga_s"].to_numpy(float)})
    else:
        target = pd.DataFrame({"pga": o["pga_m_s2"].to_numpy(float), "pgv": o["pgv_m_s"].to_numpy(float)})
    g_t = RockGeometry.from_scenario(target_scenario)
    g_s = RockGeometry.from_scenario(src_scenario)
    tr = transferred_baseline(target, source, g_t, g_s)
    add_model(
        res, "transferred", tr.p, kind="transferred",
        evaluated_on=f"fitted on specimen {src_specimen} of {src_campaign} (no test of this specimen)",
    )  # fmt: skip
    info = {
        "source": spec,
        "features": "x1 = ln(PGA/(g tan α_min)), x2 = ln(PGV·p/(g tan α_min))",
        "intercept": tr.fit.intercept,
        "coef": list(tr.fit.coef),
        "target_geometry": {"alpha_deg": math.degrees(g_t.alpha), "R_m": g_t.R, "p_rad_s": g_t.p},
        "source_geometry": {"alpha_deg": math.degrees(g_s.alpha), "R_m": g_s.R, "p_rad_s": g_s.p},
    }
    res.meta["transferred"] = info
    return info


def brier_lines(res: ValidationResult) -> list[str]:
    """``Brier <model> <value>`` for every model of the scores (engines, rules, baselines, ensemble).

    A model name's spaces are written as ``_`` (``PGA rule`` → ``PGA_rule``), so every line splits
    into three fields.
    """
    return [f"Brier {str(r.model).replace(' ', '_')} {r.brier:.4f}" for r in res.scores.itertuples()]


def _prob_models(res: ValidationResult) -> list[str]:
    return [c[2:] for c in res.outcomes.columns if c.startswith("p_")]


def reliability_figure(res: ValidationResult, n_bins: int = 10) -> Any:
    """Reliability diagram of every probabilistic model (one panel each), with the count per bin."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from pbr_xval.validation.scores import reliability

    models = _prob_models(res) or ["(none)"]
    ncol = min(3, len(models))
    nrow = -(-len(models) // ncol)
    fig, axes = plt.subplots(nrow, ncol, figsize=(4.4 * ncol, 4.2 * nrow), squeeze=False)
    obs = res.outcomes["observed"].to_numpy(int)
    for ax, m in zip(axes.ravel(), models, strict=False):
        ax.plot([0, 1], [0, 1], color="0.6", ls="--", lw=1, label="perfectly calibrated")
        if m in _prob_models(res):
            p = res.outcomes[f"p_{m}"].to_numpy(float)
            ok = np.isfinite(p)
            rel = reliability(obs[ok], p[ok], n_bins=n_bins)
            ax.plot(rel["mean_predicted"], rel["observed_frequency"], "o-", color="C0", label=m)
            for r in rel.itertuples():
                ax.annotate(
                    f"{r.n}",
                    (r.mean_predicted, r.observed_frequency),
                    textcoords="offset points",
                    xytext=(4, -10),
                    fontsize=7,
                )
        ax.set_xlim(-0.02, 1.02)
        ax.set_ylim(-0.02, 1.02)
        ax.set_xlabel("predicted P(topple) [–]")
        ax.set_ylabel("observed frequency [–]")
        ax.set_title(f"{m} (numbers: tests per bin)", fontsize=9)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="upper left")
    for ax in axes.ravel()[len(models) :]:
        ax.set_visible(False)
    fig.tight_layout()
    return fig


def probability_plane_figure(res: ValidationResult) -> Any:
    """P(topple) of every probabilistic model on the PGA × PGV/PGA plane (colour = P; marker = observed)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    models = _prob_models(res) or ["(none)"]
    ncol = min(3, len(models))
    nrow = -(-len(models) // ncol)
    fig, axes = plt.subplots(
        nrow, ncol, figsize=(5.0 * ncol + 1.0, 4.2 * nrow), squeeze=False, layout="constrained"
    )
    out = res.outcomes
    x = out["pga_m_s2"].to_numpy(float)
    y = out["pgv_over_pga_s"].to_numpy(float)
    obs = out["observed"].to_numpy(bool)
    from matplotlib.lines import Line2D

    handles = [
        Line2D([], [], ls="", marker=mk, mfc="0.85", mec="k", label=f"observed {name}")
        for mk, name in (("o", "toppled"), ("s", "stood"))
    ]
    sc = None
    for ax, m in zip(axes.ravel(), models, strict=False):
        p = out[f"p_{m}"].to_numpy(float) if f"p_{m}" in out else np.full(x.size, math.nan)
        for o, marker, name in ((True, "o", "observed toppled"), (False, "s", "observed stood")):
            sel = obs == o
            sc = ax.scatter(
                x[sel],
                y[sel],
                c=p[sel],
                cmap="viridis",
                vmin=0,
                vmax=1,
                marker=marker,
                s=26,
                edgecolors="k",
                linewidths=0.3,
                label=name,
            )
        if np.all(x[np.isfinite(x)] > 0) and np.nanmax(x) > 5 * np.nanmin(x):
            ax.set_xscale("log")
        ax.set_xlabel(label("pga"))
        ax.set_ylabel(label("pgv_over_pga"))
        ax.set_title(m, fontsize=9)
        ax.grid(alpha=0.3)
        ax.legend(handles=handles, fontsize=7, loc="upper right")
    for ax in axes.ravel()[len(models) :]:
        ax.set_visible(False)
    if sc is not None:
        fig.colorbar(sc, ax=axes.ravel().tolist(), label="P(topple) [–]")
    return fig


def _probabilistic_section(res: ValidationResult, out: Path) -> str:
    """The HTML of the probabilistic scores: table, reliability diagram, P on the plane (+ reliability.csv)."""
    from pbr_xval.validation.scores import LOG_LOSS_EPS, reliability

    sc = res.scores[["model", "kind", "brier", "log_loss", "auc", "f1", "n"]].copy()
    for c in ("brier", "log_loss", "auc", "f1"):
        sc[c] = sc[c].map(lambda v: "—" if v != v else f"{v:.3f}")
    sc.columns = ["model", "kind", "Brier [–]", "log loss [nats]", "ROC AUC [–]", "F1 at P ≥ 0.5", "n"]
    obs = res.outcomes["observed"].to_numpy(int)
    rel = []
    for m in _prob_models(res):
        p = res.outcomes[f"p_{m}"].to_numpy(float)
        ok = np.isfinite(p)
        if ok.any():
            rel.append(reliability(obs[ok], p[ok]).assign(model=m))
    if rel:
        write_text_atomic(out / "reliability.csv", pd.concat(rel, ignore_index=True).to_csv(index=False))
    figs = ""
    if _prob_models(res):
        figs = (
            "<h3>Reliability diagram</h3><p>Tests binned by predicted P (10 equal bins; data in reliability.csv); "
            "a calibrated model lies on the diagonal.</p>"
            f'<img alt="reliability diagram" src="data:image/png;base64,{_png(reliability_figure(res))}">'
            "<h3>P(topple) on the PGA × PGV/PGA plane</h3><p>Colour: predicted P(topple); circles: observed "
            "toppled; squares: observed standing.</p>"
            f'<img alt="P(topple) on the PGA x PGV/PGA plane" src="data:image/png;base64,{_png(probability_plane_figure(res))}">'
        )
    return (
        "<h2>Probabilistic scores</h2>"
        f"<p>Brier score (mean squared error of P), log loss (P clipped to [{LOG_LOSS_EPS:g}, 1 − {LOG_LOSS_EPS:g}]: "
        "a wrong 0/1 prediction costs 6.9 nats), ROC AUC and F1 at P ≥ 0.5, with scikit-learn's metrics. "
        "Deterministic engines and rules are scored with their 0/1 predictions. Logistic baselines: "
        "logistic regressions on ln PGA, ln PGV and both (weak L2 penalty, C = 100 on standardised "
        f"features), out of fold by record on the rules' {res.folds} folds.</p>"
        f"{sc.to_html(index=False, escape=True)}{figs}"
    )


__all__ += [
    "PROB_COLUMNS",
    "add_model",
    "add_transferred",
    "brier_lines",
    "probability_plane_figure",
    "reliability_figure",
]
