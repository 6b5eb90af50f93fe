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
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from pbr_xval.atomic import write_text_atomic
from pbr_xval.hazard.fragility_functions import LognormalFragility
from pbr_xval.hazard.ims import G, im_label, oq_factor, oq_unit
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


def _flabel(im: str) -> str:
    """Axis label in the field's unit: ``PGA [g]``, ``PGV [cm/s]``."""
    return f"{im} [{oq_unit(im)}]"


_FIELD_KEYS = ("mean_im_before", "mean_im_after", "im05_before", "im95_before", "im05_after", "im95_after",
               "range_before", "range_after", "im_of_interest")  # fmt: skip


def field_summary(s: dict[str, Any], im: str) -> dict[str, Any]:
    """The summary with its IM values in the field's unit (g for PGA/SA, cm/s for PGV)."""
    k = oq_factor(im)
    return {key: (v / k if key in _FIELD_KEYS and isinstance(v, (int, float)) else v) for key, v in s.items()}


def _png(fig: Any) -> str:
    from pbr_xval.report.style import plt

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110, bbox_inches="tight")
    plt().close(fig)
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode("ascii")


def _fig_curves(c: Constraint, given_mean: Any = None) -> str:
    from pbr_xval.report.style import subplots

    fig, ax = subplots(figsize=(7.0, 4.8))
    k = oq_factor(c.im)
    x = c.grid / k
    for i, r in enumerate(c.rates):
        ax.plot(x, r, color=_GREY, lw=0.6, alpha=0.25 + 0.6 * c.prior[i] / c.prior.max(),
                label="branches (shade ∝ prior weight)" if i == 0 else None)  # fmt: skip
    if len(c.quantiles) >= 2:
        lo_q, hi_q = min(c.quantiles), max(c.quantiles)
        ax.fill_between(x, c.quantile(lo_q), c.quantile(hi_q), color=_GREY, alpha=0.18,
                        label=f"{lo_q:.0%}–{hi_q:.0%} before")  # fmt: skip
        ax.fill_between(x, c.quantile(lo_q, True), c.quantile(hi_q, True), color=_RED, alpha=0.18,
                        label=f"{lo_q:.0%}–{hi_q:.0%} after (constrained)")  # fmt: skip
    ax.plot(x, c.mean(), color="black", lw=2.0, ls="--", label="mean before")
    ax.plot(x, c.mean(True), color=_RED, lw=2.2, label="mean after (constrained)")
    if given_mean is not None:
        ax.plot(
            given_mean.levels / k, given_mean.rates, color="black", lw=1.2, ls=":", label="given mean (input)"
        )
    ax.axhline(
        c.rate_of_interest, color=_BLUE, lw=0.9, ls=":", label=f"rate of interest {c.rate_of_interest:g} /yr"
    )
    ax.set_xscale("log")
    ax.set_yscale("log")
    top = max(float(c.rates.max()), 1e-300)
    ax.set_ylim(max(top * 1e-6, c.rate_of_interest / 100), top * 2)
    ax.set_xlabel(_flabel(c.im))
    ax.set_ylabel(label("annual_rate"))
    ax.set_title("Site hazard before and after the rocks' survival")
    ax.legend(fontsize=8, loc="lower left")
    return _png(fig)


def _fig_fragility(rocks: list[RockInput], c: Constraint, draws: dict[str, Any] | None = None) -> str:
    from pbr_xval.report.style import subplots

    fig, ax = subplots(figsize=(7.0, 4.0))
    k = oq_factor(c.im)
    x = c.grid
    draws = draws or {}
    for i, r in enumerate(rocks):
        col = f"C{i}"
        f = r.fragility
        ax.plot(x / k, f.probability(x), color=col, lw=2, label=r.id)
        d = draws.get(r.id)
        if d is not None:
            p = np.array([m.probability(x) for m in d.members])
            ax.fill_between(x / k, np.quantile(p, 0.05, axis=0), np.quantile(p, 0.95, axis=0), color=col,
                            alpha=0.15, label=f"{r.id}: 5–95 % of the {len(d.members)} {d.method} draws")  # fmt: skip
        elif isinstance(f, LognormalFragility) and all(math.isfinite(v) and v > 0 for v in f.theta_ci):
            lo = LognormalFragility(f.im, f.id, theta=f.theta_ci[1], beta=f.beta)
            hi = LognormalFragility(f.im, f.id, theta=f.theta_ci[0], beta=f.beta)
            ax.fill_between(x / k, lo.probability(x), hi.probability(x), color=col, alpha=0.15,
                            label=f"{r.id}: θ interval at fitted β")  # fmt: skip
    ax.set_xscale("log")
    ax.set_xlabel(_flabel(c.im))
    ax.set_ylabel(f"P(topple | {c.im}) [–]")
    ax.set_ylim(-0.02, 1.02)
    ax.set_title("Rock fragilities")
    ax.legend(fontsize=8)
    return _png(fig)


def central_range(c: Constraint, dens: np.ndarray, mass: float = 0.9) -> tuple[float, float]:
    """IM range (SI) holding the central ``mass`` of a contribution density over ln IM."""
    lx = np.log(c.grid)
    cum = np.r_[0.0, np.cumsum(0.5 * (dens[1:] + dens[:-1]) * np.diff(lx))]
    if not cum[-1] > 0:
        return (math.nan, math.nan)
    cum /= cum[-1]
    a, b = (1 - mass) / 2, (1 + mass) / 2
    return (float(np.exp(np.interp(a, cum, lx))), float(np.exp(np.interp(b, cum, lx))))


def _fig_contribution(rocks: list[RockInput], c: Constraint) -> str:
    from pbr_xval.report.style import subplots

    fig, ax = subplots(figsize=(7.0, 4.2))
    k = oq_factor(c.im)
    x = c.grid / k
    for i, r in enumerate(rocks):
        col = f"C{i}"
        d0 = c.contribution(r.fragility)
        ax.plot(x, d0, color=col, lw=2, label=f"{r.id}, prior mean hazard")
        d1 = c.contribution(r.fragility, True)
        ax.plot(x, d1, color=col, lw=1.2, ls="--", label=f"{r.id}, constrained")
        lo, hi = central_range(c, d0)
        if math.isfinite(lo):
            ax.axvspan(lo / k, hi / k, color=col, alpha=0.07)
    ax.set_xscale("log")
    ax.set_xlabel(_flabel(c.im))
    ax.set_ylabel("P_f(x)·|dλ/d ln x| [1/yr]")
    ax.set_title("Where the toppling rate comes from (area over ln IM = ν; shaded: central 90 %)")
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


def _write_tables(
    c: Constraint, rocks: list[RockInput], out: Path, unit: str, title: str,
    notes: list[str] | None, sources: list[str] | None,
) -> None:  # fmt: skip
    """curves.csv, branches.csv, contribution.csv and summary.json (SI, units in the column names);
    fills ``c.summary`` with the contribution ranges, truncation checks and warnings."""
    s = c.summary
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
    ucol = "im_" + unit.replace("/", "_").replace("²", "2")
    contrib = {ucol: c.grid}
    for rk in rocks:
        contrib[f"dnu_dlnim_{rk.id}_before_per_yr"] = c.contribution(rk.fragility)
        contrib[f"dnu_dlnim_{rk.id}_after_per_yr"] = c.contribution(rk.fragility, True)
    cl = ["# contribution to each rock's toppling rate: P_f(x)·|dλ/d ln x| of the mean hazard curve (1/yr per unit "
          "ln IM) before and after the constraint; its integral over ln IM is ν", ",".join(contrib)]  # fmt: skip
    cl += [",".join(f"{v[i]:.8g}" for v in contrib.values()) for i in range(c.grid.size)]
    write_text_atomic(out / "contribution.csv", "\n".join(cl) + "\n")
    s["contribution_90"] = {rk.id: list(central_range(c, c.contribution(rk.fragility))) for rk in rocks}
    s["truncation"] = [ck.to_dict() for ck in c.checks if ck.low_flag or ck.high_flag]
    s["truncation_worst_pf_low"] = max((ck.pf_low for ck in c.checks), default=math.nan)
    s["warnings"] = list(c.warnings)
    fu, k = oq_unit(c.im), oq_factor(c.im)
    headline = {"field_unit": fu, "im_at_rate_before": s["mean_im_before"] / k, "im_at_rate_after": s["mean_im_after"] / k,
                "im_change": s["mean_im_change"], "im_of_interest": s.get("im_of_interest", math.nan) / k,
                "rate_at_im_before_per_yr": s.get("mean_rate_before_at_im"), "rate_at_im_after_per_yr": s.get("mean_rate_after_at_im"),
                "rate_ratio_at_im": s.get("mean_rate_ratio_at_im")}  # fmt: skip
    summ = {"title": title, "im": c.im, "im_unit": unit, "joint": c.joint_mode, "headline_field_units": headline, **s,
            "assumptions": ASSUMPTIONS, "notes": notes or [], "sources": sources or []}  # fmt: skip
    write_text_atomic(out / "summary.json", json.dumps(summ, indent=2, default=float) + "\n")


def _rock_rows(
    c: Constraint, rocks: list[RockInput], s: dict[str, Any], unc: Any, fv: Callable[..., str]
) -> list[list[str]]:
    """The rows of the page's rock table (fragility, age, toppling rate, survival)."""
    rock_rows = []
    for i, rk in enumerate(rocks):
        f = rk.fragility
        if isinstance(f, LognormalFragility):
            fr = f"θ = {fv(f.theta)}, β = {f.beta:.3g}"
            if all(math.isfinite(v) for v in f.theta_ci):
                fr += f"; 95 % θ ∈ [{fv(f.theta_ci[0])}, {fv(f.theta_ci[1])}], β ∈ [{f.beta_ci[0]:.3g}, {f.beta_ci[1]:.3g}]"
            if "vector_coef" in f.meta:
                fr += f" (vector fragility b = {f.meta['vector_coef']} under {f.meta['pgv_pga_model']})"
        else:
            fr = type(f).__name__
        age = f"{rk.age.mean:.0f} ± {rk.age.sd:.0f} yr ({rk.age.dist})"
        lo90, hi90 = s["contribution_90"][rk.id]
        row = [rk.id, fr, age, _fmt(float((c.prior * c.nu[:, i]).sum()), "1/yr", 3), f"{fv(lo90)} – {fv(hi90)}",
               _fmt(s["rock_survival"][rk.id], "", 3)]  # fmt: skip
        if unc is not None:
            if unc.methods[i] == "none":
                row += ["(fragility taken as known)", "–"]
            else:
                sh = unc.shares[rk.id]
                row += [f"{unc.ps_mean[i]:.3g} [{unc.ps_band[i, 0]:.3g}–{unc.ps_band[i, 1]:.3g}] ({unc.methods[i]}, "
                        f"{unc.n_draws[i]} draws; SE {unc.ps_se[i]:.1g})",
                        f"hazard {sh['hazard']:.0%}, fragility {sh['fragility']:.0%}, age {sh['age']:.0%}, "
                        f"interaction {sh['interaction']:.0%}"]  # fmt: skip
        rock_rows.append(row)
    return rock_rows


def write_report(c: Constraint, rocks: list[RockInput], out: str | Path, title: str = "constrain",
                 notes: list[str] | None = None, sources: list[str] | None = None,
                 given_mean: Any = None, unc: Any = None, draws: dict[str, Any] | None = None) -> Path:  # fmt: skip
    """Write the report files into ``out``; returns the path of ``index.html``.

    ``given_mean`` (a :class:`~pbr_xval.hazard.curves.HazardCurve`): an input mean curve drawn for
    reference when the hazard came as fractiles. ``unc``: the
    :class:`~pbr_xval.hazard.fragility_draws.UncertaintyResult` of the rocks' fragility draws
    (``draws``, rock id → :class:`~pbr_xval.hazard.fragility_draws.FragilityDraws`), shown beside the
    fitted fragilities' figures. The page gives IMs in the field's units (g for PGA and SA, cm/s for
    PGV); the files are SI with the unit in each column name."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    s = c.summary
    unit = im_label(c.im).split("[")[1].rstrip("]")
    _write_tables(c, rocks, out, unit, title, notes, sources)
    fu, k = oq_unit(c.im), oq_factor(c.im)
    # page (IMs in the field's unit) -------------------------------------------------------
    r = c.rate_of_interest

    def fv(v: Any, d: int = 3) -> str:
        return f"{v / k:.{d}g} {fu}" if isinstance(v, (int, float)) and math.isfinite(v) else "–"

    rock_rows = _rock_rows(c, rocks, s, unc, fv)
    br_rows = [[n, f"{c.prior[b]:.4f}", f"{c.posterior[b]:.4f}"] + ([f"{unc.posterior[b]:.4f}"] if unc is not None else [])
               + [f"{c.joint[b]:.3g}"] + [f"{c.survival[b, i]:.3g}" for i in range(len(c.rock_ids))]
               for b, n in enumerate(c.branch_names)]  # fmt: skip
    x0 = s.get("im_of_interest", math.nan)
    rr = s.get("mean_rate_ratio_at_im", math.nan)
    res_rows = [
        [f"{c.im} of the mean hazard curve at λ = {r:g} /yr", fv(s["mean_im_before"]), fv(s["mean_im_after"]),
         f"{100 * s['mean_im_change']:+.1f} %" if math.isfinite(s["mean_im_change"]) else "–"],
        [f"mean annual rate of exceeding {c.im} = {fv(x0)}" + ("" if s.get("im_of_interest_given") else " (the prior mean at λ)"),
         _fmt(s.get("mean_rate_before_at_im", math.nan), "1/yr", 3), _fmt(s.get("mean_rate_after_at_im", math.nan), "1/yr", 3),
         f"× {rr:.3g}" if math.isfinite(rr) else "–"],
        [f"5–95 % range of the branches' {c.im} at λ = {r:g} /yr",
         f"{fv(s['im05_before'])} – {fv(s['im95_before'])}", f"{fv(s['im05_after'])} – {fv(s['im95_after'])}",
         f"width × {s['range_ratio']:.3g}" if math.isfinite(s["range_ratio"]) else "one branch: no range"],
    ]  # fmt: skip
    if unc is not None:
        lo, hi = unc.mean_im_after_band
        rlo, rhi = unc.rate_after_at_im_band
        res_rows += [
            [f"… with the fragilities' uncertainty ({c.im} at λ = {r:g} /yr; 5–95 % over draws)", fv(s["mean_im_before"]),
             f"{fv(unc.mean_im_after)} [{fv(lo)} – {fv(hi)}]",
             f"{100 * (unc.mean_im_after / s['mean_im_before'] - 1):+.1f} %" if math.isfinite(s["mean_im_before"]) else "–"],
            [f"… with the fragilities' uncertainty (rate at {fv(x0)})", _fmt(s.get("mean_rate_before_at_im", math.nan), "1/yr", 3),
             f"{_fmt(unc.rate_after_at_im, '1/yr', 3)} [{_fmt(rlo, '', 3)} – {_fmt(rhi, '', 3)}]",
             f"× {unc.rate_after_at_im / s['mean_rate_before_at_im']:.3g}" if math.isfinite(unc.rate_after_at_im) else "–"],
        ]  # fmt: skip
    tr_rows = []
    for rk in rocks:
        cs = [ck for ck in c.checks if ck.rock == rk.id]
        w_lo = max(cs, key=lambda ck: ck.pf_low)
        w_hi = max(cs, key=lambda ck: ck.top_share)
        pf_txt = f"{fv(w_lo.x_low)}: P_f = {w_lo.pf_low:.2g}"
        if unc is not None and rk.id in unc.pf_low_95 and unc.methods[rocks.index(rk)] != "none":
            pf_txt += f" (≤ {unc.pf_low_95[rk.id]:.2g} in 95 % of the draws)"
        tr_rows.append([rk.id, pf_txt, f"{w_lo.ps:.3g} / {w_lo.ps_extended:.3g}",
                        f"{fv(w_hi.x_high)} ({w_hi.tail}): 1 − P_f = {1 - w_hi.pf_high:.2g}, λ = {w_hi.rate_high:.2g}/yr",
                        f"{w_hi.top_share:.2g}"])  # fmt: skip
    figs = [(_fig_curves(c, given_mean), "Hazard curves: branches (grey), mean and 5–95 % band before (black, grey) and after (red)."),
            (_fig_contribution(rocks, c), "Contribution to each rock's toppling rate, P_f(x)·|dλ/d ln x| of the mean hazard "
             "curve before (solid) and after (dashed) the constraint; the area under a curve over ln IM is the rock's toppling rate."),
            (_fig_weights(c), "Prior and posterior branch weights."),
            (_fig_fragility(rocks, c, draws), "Fragility of each rock (band: 5–95 % of its draws, or the fit's θ interval at its β).")]  # fmt: skip
    fig_html = "".join(f'<figure><img src="{u}" alt="{html.escape(cap)}"><figcaption>{html.escape(cap)}</figcaption></figure>'
                       for u, cap in figs)  # fmt: skip
    warn = "".join(f'<p class="warning"><b>WARNING</b>: {html.escape(w)}</p>' for w in c.warnings)
    rock_head = ["rock", "fragility", "exposure age", "toppling rate ν (prior mean)", f"{c.im} range of 90 % of ν",
                 "P_s (prior mean, fitted fragility)"] + (
        ["P_s with the fragility's uncertainty [5–95 %]", "variance shares of exp(−νT)"] if unc is not None else [])  # fmt: skip
    li = "".join(f"<li>{html.escape(a)}</li>" for a in ASSUMPTIONS + (notes or []))
    src = "".join(f"<li><code>{html.escape(x)}</code></li>" for x in sources or [])
    # issue 24: a one-paragraph verdict on the first screen (text from pbr_xval.study.verdicts)
    from pbr_xval.study.verdicts import hazard_paragraph

    nb = len(c.branch_names)
    verdict = hazard_paragraph(field_summary(s, c.im), c.im, fu, r, nb, len(rocks), c.joint_mode)
    tr_head = ["rock", "lowest level: P_f", "P_s as computed / with the lowest segment continued below",
               "highest level", "most the tail above can change −ln P_s"]  # fmt: skip
    br_head = (["branch", "prior w", "posterior w"] + (["posterior w (fragility draws)"] if unc is not None else [])
               + ["P(all survive)"] + [f"P_s {x}" for x in c.rock_ids])  # fmt: skip
    jm = c.joint_mode
    body = f"""<h1>{html.escape(title)}: precarious rocks constrain the site hazard</h1>
<p id="verdict" class="study-verdict" data-kind="hazard">{html.escape(verdict)}</p>
<p>{nb} hazard branches on {c.im}, {len(rocks)} rock(s), joint survival: <b>{jm}</b>.
Probability that all rocks survived under the prior hazard: <b>{s["prior_joint_survival"]:.3g}</b>.</p>
{warn}
<h2>Result: the IM at the rate of interest, the rate at a fixed IM</h2>
{_table(["quantity", "before", "after", "change"], res_rows)}
{fig_html}
<h2>Rocks</h2>
{_table(rock_head, rock_rows)}
<p>Variance shares: first-order shares of the variance of the conditional survival exp(−ν(branch, fragility)·T)
over the hazard branch (prior weights), the fragility draw and the exposure age; P_s is its mean.</p>
<h2>Do the hazard curves span the fragilities?</h2>
<p>Events below a curve's lowest level count as toppling nothing (P_s is then an upper bound); above its last
level the tail is extrapolated ('powerlaw') or absent ('cut'). Worst branch per rock; refused above P_f = 0.01 at
the lowest level, or, for a cut tail, above 0.01 in −ln P_s, unless allowed.</p>
{_table(tr_head, tr_rows)}
<h2>Branches</h2>
{_table(br_head, br_rows)}
<h2>Assumptions</h2><ul>{li}</ul>
<h2>Inputs</h2><ul>{src}</ul>
<p>Tables (SI, units in the column names): <code>curves.csv</code>, <code>contribution.csv</code>, <code>branches.csv</code>,
<code>summary.json</code> (<code>headline_field_units</code> in {fu}).</p>"""
    page = f"""<!doctype html><html lang="en"><head><meta charset="utf-8"><title>{html.escape(title)}</title>
<style>body{{font-family:system-ui,sans-serif;max-width:1000px;margin:2em auto;padding:0 1em;color:#222}}
table{{border-collapse:collapse;margin:1em 0;font-size:14px}}td,th{{border:1px solid #ccc;padding:4px 8px;text-align:left}}
th{{background:#f3f3f3}}.warning{{background:#fdecea;border:2px solid #c0392b;padding:8px}}figure{{margin:1.5em 0}}img{{max-width:100%}}figcaption{{font-size:13px;color:#555}}</style>
</head><body>{body}</body></html>"""
    return write_text_atomic(out / "index.html", page)
