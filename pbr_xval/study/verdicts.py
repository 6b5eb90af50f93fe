"""The verdict of every study that is not a threshold search or a fragility map.

It sits in the study layer (beside the studies whose tables it reads) so the validate and
constrain pages, which are written by study-layer modules, can show it too; the report writer
(:mod:`pbr_xval.report.verdict`) collects it for ``pbr-xval report``.

Each function reads a :class:`~pbr_xval.study.base.StudyResult`'s tables and returns a
:class:`StudyVerdict`: what was run (with units), the answer to the study's question across
engines, each place where engines disagree beyond tolerance (in words, with what the
disagreement goes with where the data says: regime, sliding, impacts), the tolerance and where
it comes from, and one compact table (at most a screen wide: the full tables stay data links).

Tolerances come from measured reference spreads:

* :data:`TOL_MESH_SPREAD` = 0.36 %: the engines' spread on the conformance mesh box
  (:func:`pbr_xval.conformance.check_mesh_box`: PyBullet 5.6187 vs MuJoCo 5.6387 m/s²), the
  closest conformance case to a scanned rock; it is added to each engine's own search bracket
  (the threshold search's resolution), so two levels disagree when they differ by more than
  0.36 % plus both brackets;
* histories: the engines' worst measured deviation from the exact Housner solution on the
  committed ``reports/housner`` (a = 5 m/s², dt 1 ms, faithful profiles): peak θ 0.94 %,
  impact times 9.0 ms, |θ − θ_ref| ≤ 0.018 α (all PyBullet); tolerances 1.5 %, 15 ms, 0.03 α;
* extremes: the study's ±1 % band (2.9× the worst conformance error, PyBullet −0.34 % on the
  mesh box); a cell outside it is re-measured by a threshold search (how far it is);
* speed–accuracy trade: ±0.2 %, the Housner conformance tolerance (measured worst −0.12 %);
* validation: a paired bootstrap over the tests of the F1 difference of two models (90 %
  interval): models differ beyond tolerance only where it excludes zero.
"""

from __future__ import annotations

import html
import itertools
import json
import math
import re
import statistics
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from pbr_xval.study.base import StudyResult

__all__ = [
    "HIST_IMPACT_S",
    "HIST_PART_ALPHA",
    "HIST_PEAK_REL",
    "TOL_MESH_SPREAD",
    "DirectionAgreement",
    "StudyVerdict",
    "VCell",
    "agreement",
    "azimuth_disagreements",
    "hazard_paragraph",
    "study_verdict",
    "validation_verdict",
    "verdict_html",
]

TOL_MESH_SPREAD = 0.0036
MESH_SPREAD_SOURCE = (
    "the engines' measured spread on the conformance mesh box (PyBullet 5.6187 – MuJoCo 5.6387 m/s²)"
)
HIST_PEAK_REL = 0.015
HIST_IMPACT_S = 0.015
HIST_PART_ALPHA = 0.03
HIST_SOURCE = (
    "1.6× the engines' worst measured deviation from the exact solution on the Housner block at "
    "a = 5 m/s² (reports/housner: peak θ 0.94 %, impact times 9.0 ms, |Δθ| 0.018 α, PyBullet)"
)
TRADE_TOL = 2e-3
TRADE_SOURCE = "the Housner conformance tolerance (measured worst −0.12 %, PyBullet at dt 1 ms)"
EXTREMES_SOURCE = (
    "the study's band around the reference threshold (±1 %: 2.9× the engines' worst measured "
    "conformance error, PyBullet −0.34 % on the mesh box)"
)


@dataclass
class VCell:
    """One cell of a verdict table: text and a mark (pass | attention | failed | reference | none | "")."""

    text: str
    status: str = ""
    title: str = ""


@dataclass
class StudyVerdict:
    """What one study found, for the first screen."""

    kind: str
    title: str
    anchor: str = ""
    ran: str = ""
    answer: list[str] = field(default_factory=list)
    tolerance: str = ""
    disagreements: list[str] = field(default_factory=list)
    header: list[str] = field(default_factory=list)
    rows: list[list[VCell]] = field(default_factory=list)
    data_link: str = ""

    def markdown(self) -> list[str]:
        out = [f"### {self.title}", ""]
        if self.ran:
            out += [f"Ran: {self.ran}", ""]
        out += [f"- {a}" for a in self.answer]
        if self.disagreements:
            out += ["", "Disagreements beyond tolerance:", *[f"- {d}" for d in self.disagreements]]
        else:
            out += ["", "No disagreement between engines beyond tolerance."]
        if self.tolerance:
            out += ["", f"Tolerance: {self.tolerance}"]
        if self.header and self.rows:
            out += ["", "| " + " | ".join(self.header) + " |", "|" + "---|" * len(self.header)]
            out += ["| " + " | ".join(c.text for c in r) + " |" for r in self.rows]
        return [*out, ""]


# ------------------------------------------------------------------ helpers
def _f(x: Any) -> float | None:
    try:
        v = float(x)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) else None


def _g(x: float | None, d: int = 4) -> str:
    return "—" if x is None else f"{x:.{d}g}"


def _pct(x: float, d: int = 1) -> str:
    return f"{100 * x:+.{d}f} %".replace("-", "−")


def _list(names: Iterable[str]) -> str:
    n = [str(x) for x in names]
    if len(n) <= 1:
        return "".join(n)
    return ", ".join(n[:-1]) + " and " + n[-1]


def agreement(levels: Mapping[str, tuple[float, float]], tol: float) -> tuple[list[str], list[str]]:
    """(agreeing engines, outliers) among ``levels`` = engine → (value, ± half-width).

    Two levels agree when |a − b| ≤ tol·min(a, b) + hw_a + hw_b. The agreeing set is the largest
    set of at least two engines that agree pairwise, when no other set of that size disjoint
    from it exists (two engines against two others is no consensus); among overlapping sets of
    that size, the one with the smaller spread. Otherwise every engine is returned as an outlier.
    """
    names = list(levels)
    if len(names) < 2:
        return names, []

    def ok(a: str, b: str) -> bool:
        (va, ha), (vb, hb) = levels[a], levels[b]
        return abs(va - vb) <= tol * min(abs(va), abs(vb)) + ha + hb

    for k in range(len(names), 1, -1):
        groups = [
            list(sub)
            for sub in itertools.combinations(names, k)
            if all(ok(a, b) for a, b in itertools.combinations(sub, 2))
        ]
        if not groups:
            continue

        def spread(g: list[str]) -> float:
            vals = [levels[x][0] for x in g]
            return max(vals) / min(vals) if min(vals) > 0 else math.inf

        best = min(groups, key=spread)
        if any(not set(g) & set(best) for g in groups):
            return [], names
        return best, [n for n in names if n not in best]
    return [], names


@dataclass
class DirectionAgreement:
    """The engines' toppling levels in one shaking direction."""

    phi: float
    levels: dict[str, float]
    halfwidths: dict[str, float]
    agreeing: list[str]
    outliers: list[str]
    bound: float | None = None

    @property
    def spread(self) -> float:
        v = list(self.levels.values())
        return max(v) / min(v) - 1 if v and min(v) > 0 else math.nan

    @property
    def median(self) -> float:
        return statistics.median(self.levels.values())

    @property
    def consensus(self) -> float:
        base = self.agreeing or list(self.levels)
        return statistics.fmean(self.levels[e] for e in base)

    def deviation(self, engine: str) -> float:
        return self.levels[engine] / self.consensus - 1


def azimuth_disagreements(df: Any, tol: float = TOL_MESH_SPREAD) -> list[DirectionAgreement]:
    """Per direction of an ``azimuth`` table: the agreeing engines and the outliers (see :func:`agreement`).

    Levels are the PGA at each engine's minimum toppling value (m/s²) with its ± search
    tolerance; engines without a bracketed level are left out of that direction.
    """
    out = []
    for phi, sub in df.groupby("phi_deg", sort=True):
        levels: dict[str, float] = {}
        hws: dict[str, float] = {}
        bound = None
        for _, r in sub.iterrows():
            v = _f(r.get("pga_at_minimum_m_s2"))
            if v is None:
                continue
            levels[str(r["engine"])] = v
            hws[str(r["engine"])] = _f(r.get("pga_tolerance_m_s2")) or 0.0
            bound = _f(r.get("bound_m_s2"))
        if not levels:
            continue
        ag, outl = agreement({e: (levels[e], hws[e]) for e in levels}, tol)
        out.append(DirectionAgreement(float(phi), levels, hws, ag, outl, bound))
    return out


def _phi(x: float) -> str:
    return f"φ = {x:g}°"


# ------------------------------------------------------------------ azimuth
def _azimuth(r: StudyResult) -> StudyVerdict:
    df = r.tables["azimuth"]
    p = r.provenance or {}
    cfg = p.get("config") or {}
    engines = list(dict.fromkeys(str(e) for e in df["engine"]))
    dirs = azimuth_disagreements(df)
    rel = cfg.get("rel_tol")
    sv = StudyVerdict("azimuth", r.title)
    sv.ran = (
        f"{p.get('scenario', '')}: minimum toppling {cfg.get('param', 'level')} per shaking azimuth, as the "
        f"PGA of the motion at that level (m/s²), on {df['phi_deg'].nunique()} azimuths "
        f"({_g(float(df['phi_deg'].min()))}°–{_g(float(df['phi_deg'].max()))}°) × {len(engines)} engines "
        f"({', '.join(engines)})" + (f"; search rel. tol {rel:g}" if rel else "")
    )
    sv.tolerance = (
        f"two levels agree within {100 * TOL_MESH_SPREAD:.2f} % ({MESH_SPREAD_SOURCE}) plus both engines' "
        "search brackets (the threshold search's resolution, ± column of the table); an engine is "
        "beyond tolerance where it is outside the largest group of engines that agree pairwise"
    )
    if not dirs:
        sv.answer.append("No engine bracketed a toppling level in any direction.")
        return sv
    weakest = min(dirs, key=lambda d: d.median)
    per_eng = {}
    for e in engines:
        have = [(d.levels[e], d.phi) for d in dirs if e in d.levels]
        if have:
            per_eng[e] = min(have)
    bound_txt = (
        f", {weakest.median / weakest.bound:.2g}× its quasi-static uplift bound {_g(weakest.bound, 3)} m/s²"
        if weakest.bound
        else ""
    )
    sv.answer.append(
        f"**Weakest direction {_phi(weakest.phi)}**: median level {_g(weakest.median, 3)} m/s² (PGA){bound_txt}; "
        "each engine's weakest: "
        + ", ".join(f"{e} {_phi(ph)} ({_g(v, 3)} m/s²)" for e, (v, ph) in per_eng.items())
        + "."
    )
    n_bad = [d for d in dirs if d.outliers]
    spreads = [d.spread for d in dirs if math.isfinite(d.spread)]
    worst = max(dirs, key=lambda d: d.spread if math.isfinite(d.spread) else -1)
    sv.answer.append(
        f"Engines agree within tolerance at {len(dirs) - len(n_bad)} of {len(dirs)} directions; "
        f"spread across engines {100 * (min(spreads)):.1f} %–{100 * (max(spreads)):.1f} % (largest at {_phi(worst.phi)})."
        if spreads
        else "One engine only: no comparison."
    )
    has_regime = "regime_above" in df.columns
    regimes = {}
    if has_regime:
        for _, row in df.iterrows():
            regimes[(str(row["engine"]), float(row["phi_deg"]))] = row
    count: dict[str, list[int]] = {}
    for d in dirs:
        if not d.outliers:
            continue
        if d.agreeing:
            lo_, hi_ = min(d.levels[e] for e in d.agreeing), max(d.levels[e] for e in d.agreeing)
            rng = f"{_g(lo_, 4)} m/s²" if _g(lo_, 4) == _g(hi_, 4) else f"{_g(lo_, 4)}–{_g(hi_, 4)} m/s²"
            parts = []
            for e in sorted(d.outliers, key=lambda x: d.levels[x]):
                dev = d.levels[e] / statistics.fmean(d.levels[a] for a in d.agreeing) - 1
                count.setdefault(e, [0, 0])[0 if dev < 0 else 1] += 1
                parts.append(f"**{e}** {_g(d.levels[e], 4)} m/s² ({_pct(dev, 1)})")
            text = (
                f"**{_phi(d.phi)}**: {_list(parts)} against {_list(d.agreeing)} ({rng}); "
                f"spread {100 * d.spread:.0f} %"
            )
        else:
            vals = ", ".join(f"**{e}** {_g(v, 4)}" for e, v in sorted(d.levels.items(), key=lambda kv: kv[1]))
            text = f"**{_phi(d.phi)}**: no two engines agree ({vals} m/s²); spread {100 * d.spread:.0f} %"
            for e in d.outliers:
                count.setdefault(e, [0, 0])
        if has_regime:
            why = _regime_words(d, regimes)
            if why:
                text += f"; {why}"
        sv.disagreements.append(text + ".")
    # systematic outliers, and what their deviation goes with
    bounds = sorted(d.bound for d in dirs if d.bound)
    for e, (below, above) in sorted(count.items(), key=lambda kv: -sum(kv[1])):
        n = below + above
        if n < max(2, len(dirs) // 2):
            continue
        side = "below" if below >= above else "above"
        text = (
            f"**{e}** is outside the agreeing engines at {n} of {len(dirs)} directions, {side} them at "
            f"{max(below, above)}: a systematic difference of the engine, not of one direction"
        )
        if len(bounds) >= 4:
            mid = statistics.median(bounds)
            devs = [
                (d.bound, d.deviation(e))
                for d in dirs
                if d.bound and e in d.levels and d.agreeing and e not in d.agreeing
            ]
            narrow = [x for b, x in devs if b <= mid]
            wide = [x for b, x in devs if b > mid]
            if narrow and wide:
                mn, mw = statistics.fmean(narrow), statistics.fmean(wide)
                if abs(mn) > 2 * abs(mw) or abs(mw) > 2 * abs(mn):
                    text += (
                        f"; it deviates by {_pct(mn, 0)} on average where the direction's uplift bound is ≤ "
                        f"{mid:.3g} m/s² (narrow base: the rock tips on a short lever) and by {_pct(mw, 0)} where "
                        "it is higher — the disagreement depends on the contact geometry of the direction"
                    )
        sv.disagreements.append(text + ".")
    if n_bad and len(n_bad) < len(dirs):
        b_bad = [d.bound for d in n_bad if d.bound]
        b_ok = [d.bound for d in dirs if not d.outliers and d.bound]
        if b_bad and b_ok:
            mb, mo = statistics.fmean(b_bad), statistics.fmean(b_ok)
            if abs(mb / mo - 1) > 0.15:
                sv.disagreements.append(
                    f"The disagreements go with the direction's uplift bound: mean {mb:.3g} m/s² where engines "
                    f"disagree, {mo:.3g} m/s² where they agree ("
                    + (
                        "narrow-base directions, where the rock tips on a short lever"
                        if mb < mo
                        else "wide-base directions"
                    )
                    + ")."
                )
    # compact table: engines × directions
    phis = [d.phi for d in dirs]
    sv.header = ["engine", *[f"{p_:g}°" for p_ in phis], "weakest φ"]
    for e in engines:
        row = [VCell(e)]
        for d in dirs:
            if e not in d.levels:
                row.append(VCell("—", "none"))
                continue
            st = "attention" if e in d.outliers else "pass"
            row.append(VCell(_g(d.levels[e], 3), st, f"± {_g(d.halfwidths[e], 2)} m/s²"))
        row.append(VCell(f"{per_eng[e][1]:g}°" if e in per_eng else "—"))
        sv.rows.append(row)
    sv.rows.append(
        [
            VCell("spread"),
            *[VCell(f"{100 * d.spread:.0f} %", "attention" if d.outliers else "") for d in dirs],
            VCell(""),
        ]
    )
    if any(d.bound for d in dirs):
        sv.rows.append([VCell("uplift bound"), *[VCell(_g(d.bound, 3)) for d in dirs], VCell("")])
    sv.header[0] = "engine · PGA [m/s²]"
    return sv


#: slip below this (m) is contact creep, not sliding, in the words of a disagreement
SLIP_WORTH_SAYING_M = 1e-3


def _regime_words(d: DirectionAgreement, rows: Mapping[tuple[str, float], Any]) -> str:
    """What the outliers' rocks did just above their levels, where it differs from the agreeing
    engines': airborne (jumped), slid ≥ 1 mm, the number of impacts before toppling."""

    def feats(e: str) -> dict[str, Any] | None:
        r = rows.get((e, d.phi))
        if r is None:
            return None
        reg = str(r.get("regime_above") or "")
        m_air = re.search(r"jumped \(([\d.e+-]+) s airborne\)", reg)
        m_slid = re.search(r"slid ([\d.e+-]+) m", reg)
        slid = float(m_slid.group(1)) if m_slid else 0.0
        imp = _f(r.get("impacts_above"))
        return {
            "air": float(m_air.group(1)) if m_air else None,
            "slid": slid if slid >= SLIP_WORTH_SAYING_M else None,
            "impacts": int(imp) if imp is not None and imp >= 0 else None,
        }

    out_f = {e: feats(e) for e in d.outliers}
    ref_f = [f for e in d.agreeing if (f := feats(e)) is not None]
    if not d.agreeing or not ref_f:
        return ""
    words = []
    for e, f in out_f.items():
        if f is None:
            continue
        bits = []
        if f["air"] is not None and all(g["air"] is None for g in ref_f):
            bits.append(f"its rock left the pedestal ({f['air']:.2g} s airborne), the others' did not")
        if f["slid"] is not None and all(g["slid"] is None for g in ref_f):
            bits.append(f"it slid {1e3 * f['slid']:.2g} mm, the others < 1 mm")
        imps = {g["impacts"] for g in ref_f}
        if f["impacts"] is not None and len(imps) == 1 and f["impacts"] not in imps:
            bits.append(f"{f['impacts']} impacts before toppling vs {next(iter(imps))}")
        if bits:
            words.append(f"{e}: " + ", ".join(bits))
    return ("just above the levels — " + "; ".join(words)) if words else ""


# ------------------------------------------------------------------ histories
def _parting(theta: Any, base: str, engines: Sequence[str], tol: float) -> dict[str, float | None]:
    """First time each engine's θ/α leaves the ``base`` engine's by more than ``tol`` (None: never)."""
    import numpy as np

    out: dict[str, float | None] = {}
    b = theta[theta["engine"] == base]
    if b.empty:
        return out
    tb, yb = b["t"].to_numpy(float), b["theta_over_alpha"].to_numpy(float)
    for e in engines:
        if e == base:
            continue
        s = theta[theta["engine"] == e]
        if s.empty:
            continue
        t, y = s["t"].to_numpy(float), s["theta_over_alpha"].to_numpy(float)
        sel = (t >= tb[0]) & (t <= tb[-1])
        diff = np.abs(y[sel] - np.interp(t[sel], tb, yb))
        idx = np.nonzero(diff > tol)[0]
        out[e] = float(t[sel][idx[0]]) if idx.size else None
    return out


def _histories(r: StudyResult) -> StudyVerdict:
    m = r.tables["histories_metrics"]
    theta = r.tables.get("histories_theta")
    p = r.provenance or {}
    ref = p.get("reference_engine")
    ok = m[m["status"] == "ok"] if "status" in m else m
    engines = [str(e) for e in ok["engine"]]
    sv = StudyVerdict("histories", r.title)
    vals = ", ".join(f"{k} = {v:g}" for k, v in (p.get("values") or {}).items()) or "as given"
    sv.ran = (
        f"{p.get('scenario', '')} ({vals}) once on each of {len(m)} engines ({', '.join(map(str, m['engine']))}); "
        "rocking angle θ/α (α: critical tilt), impacts (returns through θ = 0, s), final state"
    )
    sv.tolerance = (
        f"peak θ ±{100 * HIST_PEAK_REL:.1f} %, impact times ±{HIST_IMPACT_S * 1e3:.0f} ms, histories part where "
        f"|Δθ| > {HIST_PART_ALPHA:g} α — {HIST_SOURCE}"
    )
    if ok.empty:
        sv.answer.append("No engine completed the run.")
        return sv
    by = {str(row["engine"]): row for _, row in ok.iterrows()}
    peaks = {e: float(by[e]["peak_theta_over_alpha"]) for e in engines}
    if ref and ref in by:
        base, base_txt = ref, f"the analytical {ref}"
    else:
        base = sorted(peaks, key=lambda e: peaks[e])[len(peaks) // 2]
        base_txt = f"{base} (the engine with the median peak: no analytical reference applies)"
    sv.answer.append(f"Compared with {base_txt}.")
    bp = peaks[base]
    peak_dev = {e: peaks[e] / bp - 1 if bp > 0 else math.nan for e in engines}
    imp_dt: dict[str, list[float | None]] = {}
    for e in engines:
        imp_dt[e] = []
        for i in (1, 2, 3):
            a, b = _f(by[e].get(f"impact{i}_t_s")), _f(by[base].get(f"impact{i}_t_s"))
            imp_dt[e].append(None if a is None or b is None else a - b)
    n_imp = {e: sum(_f(by[e].get(f"impact{i}_t_s")) is not None for i in (1, 2, 3)) for e in engines}
    final = {
        e: (f"toppled at {float(by[e]['toppled_at_s']):.3f} s" if bool(by[e].get("toppled")) else "stood")
        for e in engines
    }
    parts = _parting(theta, base, engines, HIST_PART_ALPHA) if theta is not None and len(theta) else {}
    worst_peak = max((abs(v) for e, v in peak_dev.items() if e != base and math.isfinite(v)), default=0.0)
    all_dt = [abs(x) for e in engines if e != base for x in imp_dt[e] if x is not None]
    same_final = len(set(final_state.split(" at")[0] for final_state in final.values())) == 1
    sv.answer.append(
        f"Peak tilt: {_list(f'{e} {peaks[e]:.3f} α' for e in engines)}; largest difference {100 * worst_peak:.2f} %. "
        f"Impacts (first three): largest time difference {max(all_dt, default=0.0) * 1e3:.1f} ms. "
        f"Final state: {'the same for every engine' if same_final else 'engines differ'} "
        f"({', '.join(f'{e} {final[e]}' for e in engines)})."
    )
    parted = {e: t for e, t in parts.items() if t is not None}
    sv.answer.append(
        "The histories stay within tolerance of each other to the end of the run."
        if not parted
        else "The histories part (|Δθ| > "
        f"{HIST_PART_ALPHA:g} α from {base}): "
        + ", ".join(f"{e} at t = {t:.3f} s" for e, t in parted.items())
        + "."
    )
    regime = {e: str(by[e].get("regime") or "") for e in engines} if "regime" in ok else {}
    for e in engines:
        if e == base:
            continue
        bits = []
        if math.isfinite(peak_dev[e]) and abs(peak_dev[e]) > HIST_PEAK_REL:
            bits.append(f"peak tilt {_pct(peak_dev[e])} ({peaks[e]:.3f} vs {bp:.3f} α)")
        bad_imp = [(i + 1, x) for i, x in enumerate(imp_dt[e]) if x is not None and abs(x) > HIST_IMPACT_S]
        if bad_imp:
            bits.append("impact " + ", ".join(f"{i} {x * 1e3:+.0f} ms" for i, x in bad_imp))
        if n_imp[e] != n_imp[base]:
            bits.append(f"{n_imp[e]} impacts recorded vs {n_imp[base]}")
        if final[e].split(" at")[0] != final[base].split(" at")[0]:
            bits.append(f"{final[e]} where {base} {final[base]}")
        if e in parted:
            bits.append(f"parts from {base} at t = {parted[e]:.3f} s")
        if bits:
            text = f"**{e}** vs {base}: " + "; ".join(bits)
            if regime and regime.get(e) and regime.get(e) != regime.get(base):
                text += f" — its rock {regime[e]}, {base}'s {regime.get(base) or '?'}"
            sv.disagreements.append(text + ".")
    sv.header = [
        "engine",
        "final state",
        "peak θ/α",
        "Δ peak",
        "impact 1 [s]",
        "impact 2 [s]",
        "impact 3 [s]",
        "parts at [s]",
    ]
    for e in engines:
        dev = peak_dev[e]
        row = [
            VCell(e + (" (ref)" if e == base else "")),
            VCell(final[e], "" if final[e].split(" at")[0] == final[base].split(" at")[0] else "attention"),
            VCell(f"{peaks[e]:.4f}"),
            VCell(
                "" if e == base else _pct(dev, 2),
                "" if e == base else ("attention" if abs(dev) > HIST_PEAK_REL else "pass"),
            ),
        ]
        for i in range(3):
            t = _f(by[e].get(f"impact{i + 1}_t_s"))
            x = imp_dt[e][i]
            txt = (
                "—" if t is None else f"{t:.3f}" + ("" if e == base or x is None else f" ({x * 1e3:+.0f} ms)")
            )
            st = "" if e == base or x is None else ("attention" if abs(x) > HIST_IMPACT_S else "pass")
            row.append(VCell(txt, st))
        pt = parts.get(e)
        row.append(
            VCell(
                "" if e == base else ("never" if pt is None else f"{pt:.3f}"),
                "" if e == base else ("attention" if pt is not None else "pass"),
            )
        )
        sv.rows.append(row)
    return sv


# ------------------------------------------------------------------ extremes
def _extremes(r: StudyResult) -> StudyVerdict:
    df = r.tables["extremes_matrix"]
    p = r.provenance or {}
    sv = StudyVerdict("extremes", r.title)
    if df.empty:
        sv.answer.append("No cell ran.")
        return sv
    engines = list(dict.fromkeys(str(e) for e in df["engine"]))
    cases = list(dict.fromkeys(str(c) for c in df["case"]))
    desc = p.get("case_descriptions") or {}
    sv.ran = (
        f"{len(cases)} extreme cases of the Housner block ({', '.join(cases)}) × {len(engines)} engines "
        f"({', '.join(engines)}); each cell judged against the reference threshold (m/s²: analytical "
        "5.638 by similarity, or the housner engine's search), a sliding, rest or peak-tilt criterion"
    )
    sv.tolerance = EXTREMES_SOURCE + "; the peak case ±1 % of housner's peak |θ|"
    counts = df["class"].value_counts().to_dict()
    sv.answer.append(
        f"{len(df)} cells: "
        + ", ".join(f"{k} {v}" for k, v in sorted(counts.items(), key=lambda kv: -kv[1]))
        + "."
    )
    per = []
    for e in engines:
        sub = df[df["engine"] == e]
        n_app = int((sub["class"] != "not_applicable").sum())
        n_ok = int((sub["class"] == "ok").sum())
        per.append(f"{e} {n_ok}/{n_app}")
    sv.answer.append("Right (ok) of the cells it could run, per engine: " + ", ".join(per) + ".")
    for c in cases:
        sub = df[df["case"] == c]
        cls = {str(row["engine"]): row for _, row in sub.iterrows()}
        bad = {e: row for e, row in cls.items() if row["class"] not in ("ok", "not_applicable")}
        good = [e for e, row in cls.items() if row["class"] == "ok"]
        for e, row in bad.items():
            text = (
                f"**{e}** on *{c}*"
                + (f" ({desc[c]})" if c in desc else "")
                + f": **{row['class']}** — {_extreme_detail(row)}"
            )
            if good:
                text += f"; right: {', '.join(good)}"
            sv.disagreements.append(text + ".")
    sv.header = ["case", "reference [m/s²]", *engines]
    for c in cases:
        sub = df[df["case"] == c]
        ref = _f(sub["reference_m_s2"].iloc[0]) if "reference_m_s2" in sub else None
        row = [VCell(c, "", desc.get(c, "")), VCell(_g(ref, 5) if ref is not None else "—")]
        cells = {str(x["engine"]): x for _, x in sub.iterrows()}
        for e in engines:
            x = cells.get(e)
            if x is None:
                row.append(VCell("", "none"))
                continue
            k = str(x["class"])
            st = {"ok": "pass", "not_applicable": "none"}.get(
                k, "failed" if k in ("crash", "nan", "failed", "timeout") else "attention"
            )
            row.append(VCell(_extreme_short(x), st, str(x.get("detail") or "")))
        sv.rows.append(row)
    return sv


def _extreme_short(x: Any) -> str:
    """The class and, in a few characters, how far: ``ok ±1.00 %``, ``biased +4.65 %``, ``ok slid 0.12 m``."""
    k = str(x["class"])
    if k == "not_applicable":
        return "n/a"
    err = _f(x.get("threshold_rel_error"))
    if err is not None:
        return f"{k} {_pct(err, 2)}"
    d = str(x.get("detail") or "")
    m = re.match(r"stands at −([\d.]+)%, topples at \+([\d.]+)%", d)
    if m:
        return f"{k}: within ±{m.group(1)} %"
    m = re.match(r"slid ([\d.e+-]+) m", d)
    if m:
        return f"{k}: slid {m.group(1)} m"
    m = re.search(r"\(([+-][\d.]+%)( vs reference)?\)", d)
    if m:
        return f"{k}: {m.group(1).replace('%', ' %')}"
    return k


def _extreme_detail(x: Any) -> str:
    d = str(x.get("detail") or "")
    thr, err = _f(x.get("threshold_m_s2")), _f(x.get("threshold_rel_error"))
    if thr is not None and err is not None:
        d += f"; its threshold {thr:.5g} m/s², {_pct(err, 2)} from the reference"
    return d


# ------------------------------------------------------------------ tradeoff
def _tradeoff(r: StudyResult) -> StudyVerdict:
    df = r.tables["tradeoff_points"]
    recs = r.tables.get("tradeoff_recommendations")
    p = r.provenance or {}
    ref = _f(p.get("reference"))
    sv = StudyVerdict("tradeoff", r.title)
    engines = list(dict.fromkeys(str(e) for e in df["engine"])) if "engine" in df else []
    sv.ran = (
        f"{p.get('scenario', '')}: threshold of {p.get('param', '?')} for {len(df)} settings points "
        f"(time step s × profile × solver iterations) on {len(engines)} engines ({', '.join(engines)}); "
        f"reference {_g(ref, 5)} m/s² ({p.get('reference_source', '')}); cost = wall time per simulation (s)"
    )
    sv.tolerance = f"±{100 * TRADE_TOL:.1f} % from the reference — {TRADE_SOURCE}"
    if ref is None or df.empty or "status" not in df:
        sv.answer.append("No point was run.")
        return sv
    budgets = sorted({float(b) for b in recs["budget"]}) if recs is not None and len(recs) else []
    sv.header = [
        "engine",
        "best |error|",
        "within ±0.2 % (cheapest)",
        *[f"≤ {100 * b:.1f} %" for b in budgets],
    ]
    for e in engines:
        sub = df[df["engine"] == e]
        ok = sub[sub["status"] == "ok"]
        errs = ok["abs_rel_error"].astype(float) if len(ok) else None
        best = ok.loc[errs.idxmin()] if errs is not None and len(ok) else None
        within = ok[ok["abs_rel_error"].astype(float) <= TRADE_TOL] if len(ok) else ok
        cheap = within.sort_values("wall_s_per_sim").iloc[0] if len(within) else None
        row = [VCell(e)]
        if best is None:
            row.append(VCell("no threshold", "failed"))
        else:
            row.append(
                VCell(
                    f"{float(best['rel_error']):+.3%} ({best['setting']})",
                    "pass" if float(best["abs_rel_error"]) <= TRADE_TOL else "attention",
                )
            )
        row.append(
            VCell(f"{cheap['setting']} ({float(cheap['wall_s_per_sim']):.3g} s/sim)", "pass")
            if cheap is not None
            else VCell("none", "attention")
        )
        for b in budgets:
            assert recs is not None  # budgets come from it
            rr = recs[(recs["engine"] == e) & (recs["budget"].astype(float) == b)]
            if len(rr) and rr["setting"].iloc[0] is not None and str(rr["setting"].iloc[0]) != "nan":
                row.append(
                    VCell(f"{rr['setting'].iloc[0]} ({float(rr['wall_s_per_sim'].iloc[0]):.3g} s/sim)")
                )
            else:
                row.append(VCell("none", "attention"))
        sv.rows.append(row)
        if best is not None and float(best["abs_rel_error"]) > TRADE_TOL:
            sv.disagreements.append(
                f"**{e}**: no setting tried reaches ±{100 * TRADE_TOL:.1f} % of {ref:.5g} m/s² (best {float(best['rel_error']):+.2%} "
                f"at {best['setting']})."
            )
        out = sub[sub["status"] == "out_of_range"]
        for prof, g in out.groupby("profile"):
            notes = sorted(set(str(n) for n in g["note"]))
            sv.disagreements.append(
                f"**{e}** profile *{prof}*: {len(g)} of {int((sub['profile'] == prof).sum())} settings give no threshold "
                f"in the searched range ({'; '.join(notes)[:160]})."
            )
        far = ok[ok["abs_rel_error"].astype(float) > 0.05]
        if len(far):
            sv.disagreements.append(
                f"**{e}**: {len(far)} setting(s) more than 5 % off ("
                + ", ".join(
                    f"{s} {float(x):+.1%}" for s, x in zip(far["setting"], far["rel_error"], strict=True)
                )[:240]
                + ")."
            )
    fine = []
    for e in engines:
        ok = df[(df["engine"] == e) & (df["status"] == "ok")]
        if len(ok):
            c = ok.sort_values("wall_s_per_sim").iloc[0]
            fine.append(f"{e} {float(c['wall_s_per_sim']):.3g} s/sim at {float(c['rel_error']):+.2%}")
    sv.answer.append(
        "Cheapest setting within ±0.2 %: "
        + ", ".join(f"{row[0].text} {row[2].text}" for row in sv.rows)
        + "."
    )
    if fine:
        sv.answer.append("Cheapest point per engine, whatever its error: " + ", ".join(fine) + ".")
    return sv


# ------------------------------------------------------------------ dispatch
_KINDS = {"azimuth": _azimuth, "histories": _histories, "extremes": _extremes, "tradeoff": _tradeoff}


def study_verdict(r: StudyResult, anchor: str = "") -> StudyVerdict | None:
    """The verdict of ``r`` (None for kinds with their own verdict: thresholds, fragility)."""
    fn = _KINDS.get(r.kind)
    if fn is None:
        return None
    sv = fn(r)
    sv.anchor = anchor
    return sv


# ------------------------------------------------------------------ validation
def _bootstrap_f1_diff(obs: Any, a: Any, b: Any, n: int = 2000, seed: int = 0) -> tuple[float, float]:
    """90 % interval of F1(a) − F1(b) over tests resampled with replacement (paired)."""
    import numpy as np

    rng = np.random.default_rng(seed)
    k = len(obs)
    if k == 0:
        return (math.nan, math.nan)
    idx = rng.integers(0, k, size=(n, k))
    o, pa, pb = obs[idx], a[idx], b[idx]

    def f1(p: Any) -> Any:
        tp = (o & p).sum(1)
        fp = (~o & p).sum(1)
        fn = (o & ~p).sum(1)
        den = 2 * tp + fp + fn
        return np.where(den > 0, 2 * tp / np.maximum(den, 1), 0.0)

    d = f1(pa) - f1(pb)
    return float(np.quantile(d, 0.05)), float(np.quantile(d, 0.95))


def _num(x: Any) -> float | None:
    if isinstance(x, bool):
        return float(x)
    return _f(x)


def _score_text(v: Any) -> str:
    import numpy as np

    if isinstance(v, np.generic):
        v = v.item()
    if isinstance(v, float):
        if not math.isfinite(v):
            return "—"
        return f"{v:.0f}" if v.is_integer() and abs(v) > 1 else f"{v:.3f}"
    return str(v)


def validation_verdict(scores: Any, outcomes: Any, engines: Sequence[str]) -> StudyVerdict:
    """Each model's scores side by side; where physics engines predict different outcomes."""
    import numpy as np

    sv = StudyVerdict("validate", "Predictions scored against the shake-table outcomes")
    models = [str(m) for m in scores["model"]]
    n_top = int(outcomes["observed"].sum()) if "observed" in outcomes else 0
    sv.ran = (
        f"{len(outcomes)} shake-table tests ({n_top} toppled) on {outcomes['motion'].nunique() if 'motion' in outcomes else '?'} "
        f"records; {len(engines)} physics engine(s) ({', '.join(engines)}) and {len(models) - len(engines)} empirical rule(s)"
    )
    sv.tolerance = (
        "two models' F1 differ beyond tolerance when the 90 % paired-bootstrap interval of their "
        "difference over the tests (2,000 resamples) excludes zero — the measured spread of F1 on this campaign"
    )
    cols = [c for c in scores.columns if c != "model"]
    sv.header = ["model", *cols]
    for _, r in scores.iterrows():
        row = [VCell(str(r["model"]))]
        for c in cols:
            row.append(VCell(_score_text(r[c])))
        sv.rows.append(row)
    if "f1" in scores:
        best = scores.loc[scores["f1"].astype(float).idxmax()]
        sv.answer.append(
            "F1: "
            + ", ".join(f"{m} {float(f):.3f}" for m, f in zip(scores["model"], scores["f1"], strict=True))
            + f"; best {best['model']}."
        )
    obs = outcomes["observed"].to_numpy(bool) if "observed" in outcomes else np.zeros(0, bool)
    preds = {}
    for m in models:
        col = f"pred_{m}"
        if col in outcomes:
            v = outcomes[col].to_numpy(object)
            valid = np.array([_num(x) is not None for x in v])
            # a probability (an ensemble's share of toppling runs) predicts toppling at ≥ 0.5
            preds[m] = (valid, np.array([(_num(x) or 0.0) >= 0.5 for x in v]))
    for a, b in itertools.combinations([m for m in engines if m in preds], 2):
        va, pa = preds[a]
        vb, pb = preds[b]
        both = va & vb
        diff = both & (pa != pb)
        if diff.any():
            tests = outcomes["test"].astype(str).to_numpy()[diff]
            right_a = int((pa[diff] == obs[diff]).sum())
            lo, hi = _bootstrap_f1_diff(obs[both], pa[both], pb[both])
            sig = lo > 0 or hi < 0
            sv.disagreements.append(
                f"**{a}** and **{b}** predict different outcomes on {int(diff.sum())} of {int(both.sum())} tests "
                f"({', '.join(tests[:8])}{'…' if len(tests) > 8 else ''}): {a} right on {right_a}, {b} on "
                f"{int(diff.sum()) - right_a}; F1 difference {lo:+.3f} to {hi:+.3f} (90 %) — "
                + ("beyond tolerance." if sig else "within tolerance.")
            )
    rules = [m for m in models if m not in engines and m in preds]
    if rules and engines and "f1" in scores:
        f1 = dict(zip(scores["model"].astype(str), scores["f1"].astype(float), strict=True))
        best_rule = max(rules, key=lambda m: f1.get(m, -1))
        for e in engines:
            if e not in preds:
                continue
            ve, pe = preds[e]
            vr, pr = preds[best_rule]
            both = ve & vr
            lo, hi = _bootstrap_f1_diff(obs[both], pe[both], pr[both])
            if lo > 0 or hi < 0:
                sv.disagreements.append(
                    f"**{e}** vs the best empirical rule *{best_rule}*: F1 {f1[e]:.3f} vs {f1[best_rule]:.3f}, "
                    f"difference {lo:+.3f} to {hi:+.3f} (90 %) — the physics is "
                    + ("better" if lo > 0 else "worse")
                    + " beyond tolerance."
                )
    return sv


# ------------------------------------------------------------------ hazard
def hazard_paragraph(
    s: Mapping[str, Any], im: str, unit: str, rate: float, n_branches: int, n_rocks: int, joint: str
) -> str:
    """A one-paragraph verdict of a ``constrain`` run from its summary numbers (plain text)."""

    def g(x: Any, d: int = 3) -> str:
        v = _f(x)
        return "–" if v is None else f"{v:.{d}g}"

    before, after = _f(s.get("mean_im_before")), _f(s.get("mean_im_after"))
    lo, hi = _f(s.get("im05_before")), _f(s.get("im95_before"))
    change = _f(s.get("mean_im_change"))
    txt = (
        f"Verdict: {n_rocks} rock(s) still standing constrain {n_branches} hazard branches on {im} "
        f"(joint survival {joint}; probability all survived under the prior hazard {g(s.get('prior_joint_survival'))}). "
    )
    if before is not None and after is not None and change is not None:
        txt += (
            f"At the rate of interest {rate:g} /yr the mean hazard's {im} moves from {g(before)} to {g(after)} {unit} "
            f"({100 * change:+.1f} %)"
        )
        if lo is not None and hi is not None and hi > lo:
            frac = abs(after - before) / (hi - lo)
            txt += (
                f", {100 * frac:.0f} % of the prior 5–95 % branch spread ({g(lo)}–{g(hi)} {unit}, the tolerance: the "
                "measured spread of the branches) — "
                + ("a constraint beyond that spread." if frac > 1 else "a shift within the branches' spread.")
            )
        else:
            txt += "."
        rr = _f(s.get("range_ratio"))
        if rr is not None:
            txt += f" The 5–95 % range is {'narrowed' if rr < 1 else 'widened'} ×{rr:.3g}."
    return txt


# ------------------------------------------------------------------ html for pages without the template
def _cell_html(c: VCell, tag: str = "td") -> str:
    cls = f' class="{c.status}"' if c.status else ""
    title = f' title="{html.escape(c.title)}"' if c.title else ""
    return f"<{tag}{cls}{title}>{html.escape(c.text)}</{tag}>"


_MD_BOLD = re.compile(r"\*\*(.+?)\*\*")
_MD_CODE = re.compile(r"`([^`]+)`")
_MD_EM = re.compile(r"(?<![\w*])\*(?!\s)([^*]+?)\*(?![\w*])")


def md_inline(text: str) -> Any:
    """Escape, then render the inline Markdown the summaries use: **bold**, *em*, `code`."""
    from markupsafe import Markup

    s = html.escape(str(text), quote=False)
    codes: list[str] = []

    def keep(m: re.Match[str]) -> str:
        codes.append(m.group(1))
        return f"\x00{len(codes) - 1}\x00"

    s = _MD_CODE.sub(keep, s)
    s = _MD_BOLD.sub(r"<strong>\1</strong>", s)
    s = _MD_EM.sub(r"<em>\1</em>", s)
    s = re.sub(r"\x00(\d+)\x00", lambda m: f"<code>{codes[int(m.group(1))]}</code>", s)
    return Markup(s)


def _md(text: str) -> str:
    return str(md_inline(text))


#: settings shown first in an engine's one-line summary
KEY_SETTINGS = (
    "profile",
    "timestep",
    "variant",
    "solver",
    "lcp_solver",
    "iterations",
    "num_solver_iterations",
    "pgs_iterations",
    "cone",
    "collision",
    "collision_detector",
    "ground_motion",
)


def _txt(v: Any) -> str:
    if isinstance(v, float):
        return f"{v:g}"
    if isinstance(v, list | tuple):
        return json.dumps(v, default=str)
    return str(v)


def settings_short(by_study: Mapping[str, Any]) -> str:
    """One line of an engine's settings: key settings first; values that differ between studies listed."""
    merged: dict[str, list[str]] = {}
    for st in by_study.values():
        if not isinstance(st, Mapping):
            continue
        for k, v in st.items():
            if isinstance(v, Mapping) or v is None:
                continue
            txt = f"{v:g} s" if k == "timestep" and isinstance(v, float) else _txt(v)
            vals = merged.setdefault(str(k), [])
            if txt not in vals:
                vals.append(txt)
    if not merged:
        return "settings not recorded"
    keys = [k for k in KEY_SETTINGS if k in merged] + sorted(k for k in merged if k not in KEY_SETTINGS)
    return ", ".join(f"{k} {' / '.join(merged[k])}" for k in keys)


def verdict_html(sv: StudyVerdict, engines_html: str = "") -> str:
    """The verdict block as HTML (for the validate and constrain pages, which are not templated)."""
    dis = (
        '<ul class="findings disagreements">'
        + "".join(f"<li>{_md(d)}</li>" for d in sv.disagreements)
        + "</ul>"
        if sv.disagreements
        else '<p class="small disagreements">No disagreement between engines beyond tolerance.</p>'
    )
    table = ""
    if sv.header and sv.rows:
        table = (
            '<table class="sv"><thead><tr>'
            + "".join(f"<th>{html.escape(h)}</th>" for h in sv.header)
            + "</tr></thead><tbody>"
            + "".join("<tr>" + "".join(_cell_html(c) for c in r) + "</tr>" for r in sv.rows)
            + "</tbody></table>"
        )
    return (
        f'<section id="verdict" class="study-verdict" data-kind="{html.escape(sv.kind)}">'
        f"<h2>Verdict</h2>{engines_html}"
        f'<p class="small">Ran: {html.escape(sv.ran)}</p>'
        + '<ul class="headlines">'
        + "".join(f"<li>{_md(a)}</li>" for a in sv.answer)
        + "</ul><h3>Disagreement beyond tolerance</h3>"
        + dis
        + table
        + f'<p class="small">Tolerance: {html.escape(sv.tolerance)}</p></section>'
    )


def jsonable(sv: StudyVerdict) -> dict[str, Any]:
    d = {k: v for k, v in sv.__dict__.items() if k != "rows"}
    d["rows"] = [[c.text for c in r] for r in sv.rows]
    return json.loads(json.dumps(d, default=str))


def engines_panel_html(
    engines: Sequence[str], overrides: Mapping[str, Any] | None, scenario_path: Any = None
) -> str:
    """ "Engines and settings": each engine, its versions and its effective settings (profile
    defaults ← the scenario's ``[engines.<name>]`` ← ``overrides``), for the un-templated pages."""
    items = []
    scene = None
    if scenario_path:
        try:
            from pbr_xval.scenario import load_scenario
            from pbr_xval.scene import compile_scene

            scene = compile_scene(load_scenario(scenario_path))
        except Exception:
            scene = None
    for name in engines:
        try:
            from pbr_xval.engine import get_engine

            eng = get_engine(str(name))
            vers = ", ".join(f"{k} {v}" for k, v in sorted(eng.versions().items()) if k != "numpy")
            if scene is not None:
                from pbr_xval.runner import effective_settings

                st = effective_settings(eng, scene, dict(overrides or {}))
            else:
                st = {**eng.default_settings(), **dict(overrides or {})}
            txt = settings_short({"run": st})
        except Exception as exc:
            vers, txt = "versions not recorded", f"settings not recorded ({exc})"
        items.append(
            f'<li class="one" title="{html.escape(txt)}"><strong>{html.escape(str(name))}</strong> '
            f"{html.escape(vers)} — {html.escape(txt)}</li>"
        )
    if not items:
        items.append('<li class="none">No engine ran.</li>')
    return (
        '<div id="engines-panel" class="small"><h3>Engines and settings</h3><ul>'
        + "".join(items)
        + "</ul></div>"
    )


VERDICT_CSS = (
    "#verdict{margin:.5em 0 1em}#verdict ul{margin:.2em 0;padding-left:1.2em}"
    "#engines-panel ul{margin:0;padding-left:1.1em}#engines-panel li.one{white-space:nowrap;overflow:hidden;"
    "text-overflow:ellipsis}#engines-panel h3{margin:.2em 0;font-size:1em}"
    "td.pass{background:#eef8ee}td.attention{background:#fff3dd}td.failed{background:#fde8e8}"
    ".small{font-size:.88em;color:#444}"
    # the page's figures and wide tables stay within its width (a wide table scrolls in place)
    "img{max-width:100%;height:auto}table.dataframe{display:block;max-width:100%;overflow-x:auto}"
)


def validation_block(scores: Any, outcomes: Any, engines: Sequence[str], meta: Mapping[str, Any]) -> str:
    """The validate page's first screen: engines and settings, then the verdict (HTML + its CSS)."""
    sv = validation_verdict(scores, outcomes, engines)
    panel = engines_panel_html(engines, meta.get("engine_settings") or {}, meta.get("scenario"))
    return f"<style>{VERDICT_CSS}</style>" + verdict_html(sv, panel)
