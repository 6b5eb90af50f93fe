"""The ``pbr-xval constrain`` report: one self-contained HTML page plus CSV/JSON tables.

Written into ``out/``: ``index.html`` (figures embedded as PNG data URIs), ``curves.csv`` (mean and
fractile hazard curves before and after, 1/yr, on the common IM grid), ``branches.csv`` (prior and
posterior weights, toppling rates, survival probabilities), ``summary.json``. Every file is written
atomically (:mod:`pbr_xval.atomic`).
"""

from __future__ import annotations

import base64
import html
import io
import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from pbr_xval.atomic import write_text_atomic
from pbr_xval.hazard.fragility import LognormalFragility
from pbr_xval.hazard.ims import G, im_label, oq_unit
from pbr_xval.hazard.survival import Constraint, RockInput
from pbr_xval.units import label

__all__ = ["ASSUMPTIONS", "write_report"]

ASSUMPTIONS = [
    "Poisson occurrence: earthquakes exceeding each IM level arrive as a stationary Poisson process "
    "with the hazard curve's annual rate, over the whole exposure time.",
    "Each event topples a rock with probability P_f(IM), independently of earlier events (no damage "
    "accumulation); the rock's fragility is for this site's pedestal and the hazard for the same site.",
    "Survival P_s = E_T[exp(−T ∫ P_f |dλ|)], the expectation over the exposure-age distribution.",
    "Several rocks: independent given the hazard (joint survival = product) unless 'shared-events' is chosen.",
    "Branch reweighting: w'_b ∝ w_b · P(all rocks survived | branch b); fractiles use OpenQuake's "
    "weighted-quantile convention (interpolation in cumulative weight).",
    "Events below the hazard curve's lowest level topple nothing; above its highest level the curve "
    "continues its last power law ('powerlaw' tail) or stops ('cut').",
]

_RED, _GREY, _BLUE = "#c0392b", "#7f8c8d", "#1f4e79"


def _png(fig: Any) -> str:
    from pbr_xval.report.style import plt

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110, bbox_inches="tight")
    plt().close(fig)
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode("ascii")


def _fig_curves(c: Constraint, given_mean: Any = None) -> str:
    from pbr_xval.report.style import subplots

    fig, ax = subplots(figsize=(7.0, 4.8))
    x = c.grid
    for i, r in enumerate(c.rates):
        ax.plot(x, r, color=_GREY, lw=0.6, alpha=0.25 + 0.6 * c.prior[i] / c.prior.max(),
                label="branches (shade ∝ prior weight)" if i == 0 else None)  # fmt: skip
    lo_q, hi_q = min(c.quantiles), max(c.quantiles)
    ax.fill_between(x, c.quantile(lo_q), c.quantile(hi_q), color=_GREY, alpha=0.18,
                    label=f"{lo_q:.0%}–{hi_q:.0%} before")  # fmt: skip
    ax.fill_between(x, c.quantile(lo_q, True), c.quantile(hi_q, True), color=_RED, alpha=0.18,
                    label=f"{lo_q:.0%}–{hi_q:.0%} after (constrained)")  # fmt: skip
    ax.plot(x, c.mean(), color="black", lw=2.0, ls="--", label="mean before")
    ax.plot(x, c.mean(True), color=_RED, lw=2.2, label="mean after (constrained)")
    if given_mean is not None:
        ax.plot(
            given_mean.levels, given_mean.rates, color="black", lw=1.2, ls=":", label="given mean (input)"
        )
    ax.axhline(
        c.rate_of_interest, color=_BLUE, lw=0.9, ls=":", label=f"rate of interest {c.rate_of_interest:g} /yr"
    )
    ax.set_xscale("log")
    ax.set_yscale("log")
    top = max(float(c.rates.max()), 1e-300)
    ax.set_ylim(max(top * 1e-6, c.rate_of_interest / 100), top * 2)
    ax.set_xlabel(im_label(c.im))
    ax.set_ylabel(label("annual_rate"))
    ax.set_title("Site hazard before and after the rocks' survival")
    ax.legend(fontsize=8, loc="lower left")
    return _png(fig)


def _fig_fragility(rocks: list[RockInput], c: Constraint) -> str:
    from pbr_xval.report.style import subplots

    fig, ax = subplots(figsize=(7.0, 4.0))
    x = c.grid
    for i, r in enumerate(rocks):
        col = f"C{i}"
        f = r.fragility
        ax.plot(x, f.probability(x), color=col, lw=2, label=r.id)
        if isinstance(f, LognormalFragility) and all(math.isfinite(v) and v > 0 for v in f.theta_ci):
            lo = LognormalFragility(f.im, f.id, theta=f.theta_ci[1], beta=f.beta)
            hi = LognormalFragility(f.im, f.id, theta=f.theta_ci[0], beta=f.beta)
            ax.fill_between(x, lo.probability(x), hi.probability(x), color=col, alpha=0.15,
                            label=f"{r.id}: θ interval at fitted β")  # fmt: skip
    ax.set_xscale("log")
    ax.set_xlabel(im_label(c.im))
    ax.set_ylabel(f"P(topple | {c.im}) [–]")
    ax.set_ylim(-0.02, 1.02)
    ax.set_title("Rock fragilities")
    ax.legend(fontsize=8)
    return _png(fig)


def _fig_weights(c: Constraint) -> str:
    from pbr_xval.report.style import subplots

    fig, ax = subplots(figsize=(7.0, 3.4))
    k = np.arange(len(c.branch_names))
    ax.bar(k - 0.2, c.prior, 0.4, color=_GREY, label="prior weight")
    ax.bar(k + 0.2, c.posterior, 0.4, color=_RED, label="posterior weight")
    ax.set_xticks(k, c.branch_names, rotation=45, ha="right", fontsize=8)
    ax.set_xlabel("hazard branch [–]")
    ax.set_ylabel("weight [–]")
    ax.legend(fontsize=8)
    ax.set_title("Logic-tree weights reweighted by the joint survival likelihood")
    return _png(fig)


def _fmt(v: float, unit: str = "", d: int = 4) -> str:
    if v is None or not isinstance(v, (int, float)) or not math.isfinite(v):
        return "–"
    return f"{v:.{d}g}" + (f" {unit}" if unit else "")


def _oq(v: float, im: str) -> str:
    k = 0.01 if im == "PGV" else G
    return _fmt(v / k, oq_unit(im), 3) if math.isfinite(v) else "–"


def _table(head: list[str], rows: list[list[str]]) -> str:
    h = "".join(f"<th>{html.escape(x)}</th>" for x in head)
    b = "".join("<tr>" + "".join(f"<td>{html.escape(str(x))}</td>" for x in r) + "</tr>" for r in rows)
    return f"<table><thead><tr>{h}</tr></thead><tbody>{b}</tbody></table>"


def write_report(c: Constraint, rocks: list[RockInput], out: str | Path, title: str = "constrain",
                 notes: list[str] | None = None, sources: list[str] | None = None,
                 given_mean: Any = None) -> Path:  # fmt: skip
    """Write the report files into ``out``; returns the path of ``index.html``.

    ``given_mean`` (a :class:`~pbr_xval.hazard.curves.HazardCurve`): an input mean curve drawn for
    reference when the hazard came as fractiles."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    s = c.summary
    unit = im_label(c.im).split("[")[1].rstrip("]")
    # tables ------------------------------------------------------------------------------
    cols = {
        "im_" + unit.replace("/", "_").replace("²", "2"): c.grid,
        "mean_before": c.mean(),
        "mean_after": c.mean(True),
    }
    for q in c.quantiles:
        cols[f"q{q:g}_before"] = c.quantile(q)
        cols[f"q{q:g}_after"] = c.quantile(q, True)
    lines = ["# annual exceedance rates (1/yr) on the common IM grid (" + c.im + ", " + unit + ")",
             ",".join(cols)] + [",".join(f"{v[i]:.8g}" for v in cols.values()) for i in range(c.grid.size)]  # fmt: skip
    write_text_atomic(out / "curves.csv", "\n".join(lines) + "\n")
    bl = ["branch,prior_weight,posterior_weight,joint_survival," + ",".join(
        f"nu_{r}_per_yr,survival_{r}" for r in c.rock_ids)]  # fmt: skip
    for b, name in enumerate(c.branch_names):
        bl.append(f"{name},{c.prior[b]:.8g},{c.posterior[b]:.8g},{c.joint[b]:.8g}," + ",".join(
            f"{c.nu[b, i]:.8g},{c.survival[b, i]:.8g}" for i in range(len(c.rock_ids))))  # fmt: skip
    write_text_atomic(out / "branches.csv", "\n".join(bl) + "\n")
    summ = {"title": title, "im": c.im, "im_unit": unit, "joint": c.joint_mode, **s, "assumptions": ASSUMPTIONS,
            "notes": notes or [], "sources": sources or []}  # fmt: skip
    write_text_atomic(out / "summary.json", json.dumps(summ, indent=2, default=float) + "\n")
    # page --------------------------------------------------------------------------------
    r = c.rate_of_interest
    rock_rows = []
    for i, rk in enumerate(rocks):
        f = rk.fragility
        if isinstance(f, LognormalFragility):
            fr = f"θ = {_fmt(f.theta, unit)} ({_oq(f.theta, c.im)}), β = {f.beta:.3g}"
            if all(math.isfinite(v) for v in f.theta_ci):
                fr += f"; 95 % θ ∈ [{_fmt(f.theta_ci[0])}, {_fmt(f.theta_ci[1])}], β ∈ [{f.beta_ci[0]:.3g}, {f.beta_ci[1]:.3g}]"
        else:
            fr = type(f).__name__
        age = f"{rk.age.mean:.0f} ± {rk.age.sd:.0f} yr ({rk.age.dist})"
        rock_rows.append([rk.id, fr, age, _fmt(float((c.prior * c.nu[:, i]).sum()), "1/yr", 3),
                          _fmt(s["rock_survival"][rk.id], "", 3)])  # fmt: skip
    br_rows = [[n, f"{c.prior[b]:.4f}", f"{c.posterior[b]:.4f}", f"{c.joint[b]:.3g}"]
               + [f"{c.survival[b, i]:.3g}" for i in range(len(c.rock_ids))] for b, n in enumerate(c.branch_names)]  # fmt: skip
    res_rows = [
        [f"{c.im} of the mean hazard curve at λ = {r:g} /yr", f"{_fmt(s['mean_im_before'], unit)} ({_oq(s['mean_im_before'], c.im)})",
         f"{_fmt(s['mean_im_after'], unit)} ({_oq(s['mean_im_after'], c.im)})", f"{100 * s['mean_im_change']:+.1f} %"],
        [f"5–95 % range of the branches' {c.im} at λ = {r:g} /yr",
         f"{_fmt(s['im05_before'])} – {_fmt(s['im95_before'], unit)}", f"{_fmt(s['im05_after'])} – {_fmt(s['im95_after'], unit)}",
         f"width × {s['range_ratio']:.3g}" if math.isfinite(s["range_ratio"]) else "–"],
        [f"mean annual rate of exceeding {_fmt(s['mean_im_before'], unit)}", _fmt(r, "1/yr", 3),
         _fmt(s.get("mean_rate_after_at_that_im", math.nan), "1/yr", 3),
         f"× {s.get('mean_rate_after_at_that_im', math.nan) / r:.3g}" if math.isfinite(s.get("mean_rate_after_at_that_im", math.nan)) else "–"],
    ]  # fmt: skip
    figs = [(_fig_curves(c, given_mean), "Hazard curves: branches (grey), mean and 5–95 % band before (black, grey) and after (red)."),
            (_fig_weights(c), "Prior and posterior branch weights."),
            (_fig_fragility(rocks, c), "Fragility of each rock (band: the fit's θ interval at its β, when known).")]  # fmt: skip
    fig_html = "".join(f'<figure><img src="{u}" alt="{html.escape(cap)}"><figcaption>{html.escape(cap)}</figcaption></figure>'
                       for u, cap in figs)  # fmt: skip
    li = "".join(f"<li>{html.escape(a)}</li>" for a in ASSUMPTIONS + (notes or []))
    src = "".join(f"<li><code>{html.escape(x)}</code></li>" for x in sources or [])
    body = f"""<h1>{html.escape(title)}: precarious rocks constrain the site hazard</h1>
<p>{len(c.branch_names)} hazard branches on {c.im}, {len(rocks)} rock(s), joint survival: <b>{c.joint_mode}</b>.
Probability that all rocks survived under the prior hazard: <b>{s["prior_joint_survival"]:.3g}</b>.</p>
<h2>Result at the rate of interest</h2>
{_table(["quantity", "before", "after", "change"], res_rows)}
{fig_html}
<h2>Rocks</h2>
{_table(["rock", "fragility", "exposure age", "toppling rate ν (prior mean)", "P_s (prior mean)"], rock_rows)}
<h2>Branches</h2>
{_table(["branch", "prior w", "posterior w", "P(all survive)"] + [f"P_s {x}" for x in c.rock_ids], br_rows)}
<h2>Assumptions</h2><ul>{li}</ul>
<h2>Inputs</h2><ul>{src}</ul>
<p>Tables: <code>curves.csv</code>, <code>branches.csv</code>, <code>summary.json</code>.</p>"""
    page = f"""<!doctype html><html lang="en"><head><meta charset="utf-8"><title>{html.escape(title)}</title>
<style>body{{font-family:system-ui,sans-serif;max-width:1000px;margin:2em auto;padding:0 1em;color:#222}}
table{{border-collapse:collapse;margin:1em 0;font-size:14px}}td,th{{border:1px solid #ccc;padding:4px 8px;text-align:left}}
th{{background:#f3f3f3}}figure{{margin:1.5em 0}}img{{max-width:100%}}figcaption{{font-size:13px;color:#555}}</style>
</head><body>{body}</body></html>"""
    return write_text_atomic(out / "index.html", page)
