"""The verdict of a report: engine × case, each engine's number against the reference, with a mark.

A *case* is one comparison a reader cares about:

* a threshold study (``kind == "thresholds"``): each engine's minimum toppling value of the
  searched parameter against the published/closed-form value when the study names one
  (``reference``, e.g. Housner's 5.638 m/s²), else against the analytical reference engine's
  threshold, else — no analytical reference applies, e.g. a mesh rock — against the median of
  the engines (then the deviation measures disagreement between engines, not error);
* a fragility study (``kind == "fragility"``), per variant: the share of grid cells on which
  an engine and the analytical map disagree about toppling.

Every other study (azimuth, histories, extremes, speed–accuracy trade) gets a
:class:`~pbr_xval.study.verdicts.StudyVerdict` (:mod:`pbr_xval.study.verdicts`): what was run,
the answer across engines, each disagreement beyond tolerance in words, and a compact table.

Marks: ``pass`` (within tolerance), ``attention`` (beyond it), ``reference``, ``failed``,
``skipped``, ``none`` (never toppled in the scanned range). Tolerances (relative):

* :data:`TOL_ANALYTICAL` = 5e-4 for an analytical engine against the published value and
  :data:`TOL_NUMERICAL` = 2e-3 for a time-stepping engine against an analytical reference —
  the tolerances of the Housner conformance test (:mod:`pbr_xval.conformance`; measured
  worst: PyBullet −0.12 % at dt = 1 ms, margin 1.7×);
* :data:`TOL_BETWEEN_ENGINES` = 1e-2 between engines when no analytical reference applies
  (the notched-block conformance tolerance);
* each engine's own bisection bracket (± half-width / reference) is added to the tolerance,
  since the threshold is only known to within it;
* :data:`TOL_FRAGILITY_CELLS` = 10 % of the compared cells for a fragility map (measured
  worst on the committed curved-base maps: 2 of 48 cells = 4.2 %, PyBullet at r = 3.62 m).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from pbr_xval import units
from pbr_xval.study.base import StudyResult
from pbr_xval.study.verdicts import StudyVerdict, study_verdict

__all__ = [
    "TOL_ANALYTICAL",
    "TOL_BETWEEN_ENGINES",
    "TOL_FRAGILITY_CELLS",
    "TOL_NUMERICAL",
    "Case",
    "Cell",
    "Verdict",
    "build_verdict",
]

TOL_ANALYTICAL = 5e-4
TOL_NUMERICAL = 2e-3
TOL_BETWEEN_ENGINES = 1e-2
TOL_FRAGILITY_CELLS = 0.10
ANALYTICAL = ("housner", "curved_base")

MARKS = {"pass": "✓", "attention": "⚠", "reference": "ref", "failed": "✗", "skipped": "–", "none": "–"}


@dataclass
class Case:
    """One column of the verdict: what is compared, against what, with which tolerance."""

    key: str
    title: str
    quantity: str  # "threshold" | "fragility"
    unit: str = ""
    reference: float | None = None
    reference_text: str = ""
    tolerance_text: str = ""
    anchor: str = ""


@dataclass
class Cell:
    """One engine on one case."""

    engine: str
    case: str
    status: str  # pass | attention | reference | failed | skipped | none
    value: float | None = None
    value_text: str = ""
    deviation: float | None = None  # relative (threshold) or disagreeing fraction (fragility)
    deviation_text: str = ""
    tolerance: float | None = None
    n_sims: int | None = None
    wall_s: float | None = None
    message: str = ""

    @property
    def mark(self) -> str:
        return MARKS.get(self.status, "")

    @property
    def cost_text(self) -> str:
        parts = []
        if self.n_sims:
            parts.append(f"{self.n_sims} sims")
        if self.wall_s is not None and math.isfinite(self.wall_s):
            parts.append(f"{self.wall_s:.1f} s" if self.wall_s < 100 else f"{self.wall_s:.0f} s")
        return " · ".join(parts)


@dataclass
class Verdict:
    """Cases (columns), engines (rows), cells, and one sentence per finding."""

    cases: list[Case] = field(default_factory=list)
    engines: list[str] = field(default_factory=list)
    cells: dict[tuple[str, str], Cell] = field(default_factory=dict)
    headlines: list[str] = field(default_factory=list)  # one per case: the answer
    findings: list[str] = field(default_factory=list)  # one per disagreement / failure
    studies: list[StudyVerdict] = field(default_factory=list)  # the other studies' verdicts

    @property
    def disagreements(self) -> list[str]:
        """Every disagreement beyond tolerance and failure, in words (threshold cases, then studies)."""
        out = list(self.findings)
        for sv in self.studies:
            out += sv.disagreements
        return out

    @property
    def empty(self) -> bool:
        return not self.cases and not self.studies

    def cell(self, engine: str, case: str) -> Cell | None:
        return self.cells.get((engine, case))

    @property
    def n_attention(self) -> int:
        return sum(c.status in ("attention", "failed") for c in self.cells.values())

    def rows(self) -> list[dict[str, Any]]:
        """Long format (one dict per cell): for the terminal table and CSV."""
        out = []
        for case in self.cases:
            for eng in self.engines:
                c = self.cell(eng, case.key)
                if c is None:
                    continue
                out.append(
                    {
                        "case": case.title,
                        "engine": eng,
                        "value": c.value,
                        "unit": case.unit,
                        "value_text": c.value_text,
                        "deviation": c.deviation,
                        "deviation_text": c.deviation_text,
                        "tolerance": c.tolerance,
                        "status": c.status,
                        "n_sims": c.n_sims,
                        "wall_s": c.wall_s,
                        "cost": c.cost_text,
                        "reference": case.reference_text,
                        "message": c.message,
                    }
                )
        return out

    def markdown(self) -> list[str]:
        """The verdict as Markdown lines (summary.md)."""
        studies = [ln for sv in self.studies for ln in sv.markdown()]
        if not self.cases:
            return studies
        lines = [*[f"- {h}" for h in self.headlines], ""]
        if self.findings:
            lines += ["Disagreements beyond tolerance:", *[f"- {f}" for f in self.findings], ""]
        lines += [
            "| case | engine | value | deviation | tolerance | mark | cost |",
            "|---|---|---|---|---|---|---|",
        ]
        for r in self.rows():
            tol = "" if r["tolerance"] is None else f"±{r['tolerance']:.2%}"
            lines.append(
                f"| {r['case']} | {r['engine']} | {r['value_text']} | {r['deviation_text']} | {tol} | "
                f"{r['status']} | {r['cost']} |"
            )
        return [*lines, "", *studies]


# ------------------------------------------------------------------ helpers
def _f(x: Any) -> float | None:
    try:
        xf = float(x)
    except (TypeError, ValueError):
        return None
    return xf if math.isfinite(xf) else None


def fmt_value(x: float | None, unit: str = "", digits: int = 5) -> str:
    """``5.6386 m/s²``; ``—`` for None."""
    if x is None:
        return "—"
    s = f"{x:.{digits}g}"
    return f"{s} {unit}".strip()


def fmt_pct(x: float | None, digits: int = 2) -> str:
    if x is None:
        return "—"
    p = 100 * x
    if p != 0 and abs(p) < 10 ** (-digits):
        return f"{p:+.1e} %"
    return f"{p:+.{digits}f} %"


def _failed(r: StudyResult) -> bool:
    return isinstance(r.provenance, Mapping) and r.provenance.get("status") in ("failed", "interrupted")


def _scenario_label(r: StudyResult) -> str:
    p = r.provenance if isinstance(r.provenance, Mapping) else {}
    return str(p.get("scenario_label") or p.get("scenario_name") or p.get("scenario") or "")


# ------------------------------------------------------------------ cases
def _threshold_case(r: StudyResult, idx: int, anchor: str, v: Verdict) -> None:
    df = r.tables.get("thresholds")
    if df is None or df.empty:
        return
    p = r.provenance if isinstance(r.provenance, Mapping) else {}
    cfg = p.get("config") or {}
    param = str(cfg.get("param") or (df["param"].iloc[0] if "param" in df else "value"))
    mcol = next((c for c in df.columns if str(c).startswith("minimum")), None)
    tcol = next((c for c in df.columns if str(c).startswith("tolerance")), None)
    if mcol is None:
        return
    unit = units.unit(param)
    ref_engine = p.get("reference_engine")
    ref_value = _f(cfg.get("reference"))
    ok = df[df["status"] == "ok"]
    minima = {str(e): x for e, m in zip(ok["engine"], ok[mcol], strict=True) if (x := _f(m)) is not None}
    between = False
    if ref_value is not None:
        ref = ref_value
        ref_text = f"{fmt_value(ref, unit)} (closed form/published)"
        ref_name = f"the reference {fmt_value(ref, unit)}"
    elif ref_engine and ref_engine in minima:
        ref = minima[ref_engine]
        ref_text = f"{ref_engine} {fmt_value(ref, unit)} (analytical)"
        ref_name = f"{ref_engine}'s {fmt_value(ref, unit)}"
    elif minima:
        import statistics

        ref = statistics.median(minima.values())
        between = True
        ref_text = f"median of the engines {fmt_value(ref, unit)} (no analytical reference applies)"
        ref_name = f"the engines' median {fmt_value(ref, unit)}"
    else:
        ref = None
        ref_text = "no engine found a threshold"
        ref_name = ""
    qname = units.label(param, with_unit=False)
    label = _scenario_label(r)
    case = Case(
        key=f"c{idx}",
        title=f"{label}: {qname} threshold" if label else f"{qname} threshold",
        quantity="threshold",
        unit=unit,
        reference=ref,
        reference_text=ref_text,
        tolerance_text=(
            f"±{TOL_BETWEEN_ENGINES:.0%} between engines"
            if between
            else f"±{TOL_NUMERICAL:.1%} (analytical ±{TOL_ANALYTICAL:.2%})"
        )
        + " + search bracket",
        anchor=anchor,
    )
    v.cases.append(case)
    devs: list[tuple[str, float]] = []
    for _, row in df.iterrows():
        eng = str(row["engine"])
        if eng not in v.engines:
            v.engines.append(eng)
        n = int(row["n_simulations"]) if _f(row.get("n_simulations")) is not None else None
        wall = _f(row.get("wall_s"))
        st = str(row["status"])
        if st in ("skipped", "failed"):
            msg = str(row.get("message") or "")
            v.cells[(eng, case.key)] = Cell(
                eng, case.key, st, value_text=st, message=msg, n_sims=n, wall_s=wall
            )
            if st == "failed":
                v.findings.append(f"**{eng}** failed on *{case.title}*: {msg[:200]}")
            continue
        m = _f(row[mcol])
        if m is None:
            msg = str(row.get("message") or "")
            text = "topples at the lowest value" if st == "topples_at_lo" else "never toppled"
            v.cells[(eng, case.key)] = Cell(
                eng, case.key, "none", value_text=text, message=msg, n_sims=n, wall_s=wall
            )
            v.findings.append(f"**{eng}** on *{case.title}*: no minimum bracketed — {msg or text}.")
            continue
        hw = _f(row[tcol]) if tcol else None
        if ref is None:
            v.cells[(eng, case.key)] = Cell(
                eng, case.key, "none", m, fmt_value(m, unit), n_sims=n, wall_s=wall
            )
            continue
        dev = m / ref - 1.0
        base_tol = (
            TOL_BETWEEN_ENGINES if between else (TOL_ANALYTICAL if eng in ANALYTICAL else TOL_NUMERICAL)
        )
        tol = base_tol + (hw or 0.0) / ref
        is_ref = (not between) and ref_value is None and eng == ref_engine
        status = "reference" if is_ref else ("pass" if abs(dev) <= tol else "attention")
        v.cells[(eng, case.key)] = Cell(
            eng,
            case.key,
            status,
            m,
            fmt_value(m, unit),
            dev,
            "" if is_ref else fmt_pct(dev, 3 if abs(dev) < 0.01 else 2),
            None if is_ref else tol,
            n,
            wall,
        )
        if not is_ref:
            devs.append((eng, dev))
        if status == "attention":
            v.findings.append(
                f"**{eng}** on *{case.title}*: {fmt_value(m, unit)}, {fmt_pct(dev)} from {ref_name} — "
                f"beyond the ±{tol:.2%} tolerance."
            )
    if devs and ref is not None:
        worst = max(abs(d) for _, d in devs)
        n_att = sum(1 for e, _ in devs if v.cells[(e, case.key)].status == "attention")
        if between:
            lo = min(minima.values())
            hi = max(minima.values())
            v.headlines.append(
                f"*{case.title}*: {len(devs)} engines between {fmt_value(lo, unit)} and {fmt_value(hi, unit)} "
                f"(spread {hi / lo - 1:.1%}); no analytical reference applies"
                + (f", {n_att} beyond ±{TOL_BETWEEN_ENGINES:.0%} of the median." if n_att else ".")
            )
        else:
            v.headlines.append(
                f"*{case.title}*: "
                + (
                    f"every engine within {worst:.2%} of {ref_name}."
                    if not n_att
                    else f"{len(devs) - n_att} of {len(devs)} engines within tolerance of {ref_name}; "
                    f"largest deviation {worst:.2%}."
                )
            )


def _fragility_cases(r: StudyResult, idx: int, anchor: str, v: Verdict) -> None:
    ag = r.tables.get("fragility_agreement")
    if ag is None or ag.empty:
        return
    p = r.provenance if isinstance(r.provenance, Mapping) else {}
    ref = p.get("reference_engine")
    if not ref:  # nothing to compare the maps with
        return
    label = _scenario_label(r)
    cfg = p.get("config") or {}
    axes = " × ".join(units.label(str(cfg.get(k, k)), with_unit=False) for k in ("x", "y"))
    variants = list(dict.fromkeys(ag["variant"]))
    cells = r.tables.get("fragility_cells")
    for j, var in enumerate(variants):
        sub = ag[ag["variant"] == var]
        vtxt = "" if var == "base" else f" ({var})"
        case = Case(
            key=f"c{idx}_{j}",
            title=f"{label}: fragility map {axes}{vtxt}" if label else f"fragility map {axes}{vtxt}",
            quantity="fragility",
            unit="",
            reference_text=f"{ref} map ({'analytical' if ref in ANALYTICAL else 'engine'})",
            tolerance_text=f"≤ {TOL_FRAGILITY_CELLS:.0%} of cells disagree on toppling",
            anchor=anchor,
        )
        v.cases.append(case)
        n_bad = 0
        n_eng = 0
        ref_broken = ""
        if ref and cells is not None and not cells.empty:
            rc = cells[(cells["variant"] == var) & (cells["engine"] == ref)]
            bad = rc[rc["status"] != "ok"]
            if len(rc) and len(bad):
                ref_broken = f"{len(bad)} of {len(rc)} cells {bad['status'].iloc[0]}: {str(bad['message'].iloc[0])[:160]}"
                v.findings.append(f"The reference **{ref}** on *{case.title}*: {ref_broken}.")
        for _, row in sub.iterrows():
            eng = str(row["engine"])
            if eng not in v.engines:
                v.engines.append(eng)
            n_cells = int(row["n_cells"])
            wall = _f(row.get("wall_s"))
            if eng == ref:
                v.cells[(eng, case.key)] = Cell(
                    eng,
                    case.key,
                    "failed" if ref_broken else "reference",
                    None,
                    f"{n_cells} cells" + (" (failed)" if ref_broken else ""),
                    message=ref_broken,
                    n_sims=n_cells,
                    wall_s=wall,
                )
                continue
            agree = _f(row.get("agreement"))
            n_cmp = int(row.get("n_compared") or 0)
            if agree is None or n_cmp == 0:
                msg = "no cell where both this engine and the reference ran"
                v.cells[(eng, case.key)] = Cell(
                    eng,
                    case.key,
                    "none" if ref_broken else "failed",
                    value_text="no comparison",
                    message=msg,
                    n_sims=n_cells,
                    wall_s=wall,
                )
                if not ref_broken:
                    v.findings.append(f"**{eng}** on *{case.title}*: {msg} (see the section's notes).")
                    n_bad += 1
                    n_eng += 1
                continue
            n_dis = int(row["n_disagree"])
            frac = n_dis / n_cmp
            status = "pass" if frac <= TOL_FRAGILITY_CELLS else "attention"
            v.cells[(eng, case.key)] = Cell(
                eng,
                case.key,
                status,
                agree,
                f"agree {agree:.0%}",
                frac,
                f"{n_dis} of {n_cmp} cells differ",
                TOL_FRAGILITY_CELLS,
                n_cells,
                wall,
            )
            n_eng += 1
            if status == "attention":
                n_bad += 1
                v.findings.append(
                    f"**{eng}** on *{case.title}*: {n_dis} of {n_cmp} cells ({frac:.0%}) on the other side "
                    f"of the toppling line from {ref} — beyond {TOL_FRAGILITY_CELLS:.0%}."
                )
        if n_eng:
            v.headlines.append(
                f"*{case.title}*: "
                + (
                    f"every engine's map agrees with {ref} within {TOL_FRAGILITY_CELLS:.0%} of the cells."
                    if not n_bad
                    else f"{n_eng - n_bad} of {n_eng} engines agree with {ref} within {TOL_FRAGILITY_CELLS:.0%} "
                    "of the cells."
                )
            )


def build_verdict(results: Sequence[StudyResult], anchors: Iterable[str] | None = None) -> Verdict:
    """The verdict of ``results`` (see the module docstring); ``anchors``: section ids to link."""
    v = Verdict()
    anchors = list(anchors) if anchors is not None else [""] * len(results)
    for i, (r, a) in enumerate(zip(results, anchors, strict=False)):
        if _failed(r):
            v.findings.append(f"Section *{r.title}* did not complete ({r.provenance.get('status')}).")
            continue
        try:
            if r.kind == "thresholds":
                _threshold_case(r, i, a, v)
            elif r.kind == "fragility":
                _fragility_cases(r, i, a, v)
            else:
                sv = study_verdict(r, a)
                if sv is not None:
                    v.studies.append(sv)
        except (
            KeyError,
            ValueError,
            TypeError,
            AttributeError,
            IndexError,
        ) as exc:  # a malformed table must not sink the report
            v.findings.append(f"Section *{r.title}*: no verdict ({type(exc).__name__}: {exc}).")
    order = {n: i for i, n in enumerate(ANALYTICAL)}
    v.engines.sort(key=lambda e: (order.get(e, len(order)), 0))
    return v
