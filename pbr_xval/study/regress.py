"""Regression of toppling thresholds against a committed golden table.

A golden table is a CSV file with the columns

========== ==============================================================================
scenario   scenario file, relative to the CSV file
engine     engine name
profile    settings profile (empty: the engine's default)
param      dotted scenario key searched (e.g. ``excitation.amplitude``)
threshold  expected minimum toppling value, in the parameter's units
tolerance  allowed absolute deviation, same units
settings   optional JSON object of engine setting overrides, e.g. ``{"variant": "linearized"}``
note       optional free text (kept by ``--update``)
========== ==============================================================================

:func:`regress` re-measures every row with :func:`~pbr_xval.study.threshold_search.find_threshold`
on ``[threshold − m·tol, threshold + m·tol]`` (m = :data:`MARGIN_TOLS`), bisected until the
bracket is a tenth of the tolerance, and reports ``expected ± tol``, the measured value, the
difference and PASS/FAIL per row. ``fast=True`` only checks that the rock stands at
``threshold − tol`` and topples at ``threshold + tol`` (two simulations per row).

Statuses: ``PASS``; ``FAIL`` (outside the tolerance); ``ERROR`` (the engine failed, the
scenario is invalid, ...); ``SKIP`` (engine not installed — an error with ``strict``).
:func:`rewrite_golden` (``--update``) writes the measured values back, atomically, keeping the
tolerances, notes, row order and the rows it did not measure.
"""

from __future__ import annotations

import csv
import io
import json
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

__all__ = [
    "GOLDEN_COLUMNS",
    "GoldenError",
    "GoldenRow",
    "RegressResult",
    "RowResult",
    "read_golden",
    "regress",
    "rewrite_golden",
]

GOLDEN_COLUMNS = ("scenario", "engine", "profile", "param", "threshold", "tolerance", "settings", "note")
REQUIRED = ("scenario", "engine", "profile", "param", "threshold", "tolerance")
#: the search range is threshold ± MARGIN_TOLS × tolerance
MARGIN_TOLS = 4.0
#: the final bracket half-width is at most tolerance / BRACKET_DIV
BRACKET_DIV = 10.0


class GoldenError(ValueError):
    """The golden table is malformed; the message names the file, the row and the column."""


@dataclass
class GoldenRow:
    line: int  # 1-based line number in the CSV (header = 1)
    scenario: str
    engine: str
    profile: str
    param: str
    threshold: float
    tolerance: float
    settings: dict[str, Any] = field(default_factory=dict)
    note: str = ""
    raw: dict[str, str] = field(default_factory=dict)

    @property
    def label(self) -> str:
        bits = [Path(self.scenario).stem, self.engine]
        if self.profile:
            bits.append(self.profile)
        if self.settings:
            bits.append(",".join(f"{k}={v}" for k, v in self.settings.items()))
        return f"row {self.line}: " + " / ".join(bits)


@dataclass
class RowResult:
    row: GoldenRow
    status: str  # PASS, FAIL, ERROR, SKIP
    measured: float | None = None
    bracket: float | None = None  # ± half-width of the measured value
    message: str = ""
    n_simulations: int = 0
    wall_time: float = 0.0

    @property
    def delta(self) -> float | None:
        return None if self.measured is None else self.measured - self.row.threshold


@dataclass
class RegressResult:
    golden: Path
    rows: list[RowResult]
    strict: bool = False
    fast: bool = False
    updated: bool = False

    @property
    def counts(self) -> dict[str, int]:
        out = {"PASS": 0, "FAIL": 0, "ERROR": 0, "SKIP": 0}
        for r in self.rows:
            out[r.status] = out.get(r.status, 0) + 1
        return out

    @property
    def ok(self) -> bool:
        c = self.counts
        return c["FAIL"] == 0 and c["ERROR"] == 0 and (not self.strict or c["SKIP"] == 0)

    @property
    def exit_code(self) -> int:
        """0: every measured row within tolerance; 1: a row out of tolerance, an engine error,
        or (``strict``) a skipped engine."""
        return 0 if self.ok else 1

    def table_rows(self) -> list[dict[str, str]]:
        out = []
        for r in self.rows:
            g = r.row
            if r.measured is None:
                meas = "—"
            elif self.fast:
                meas = f"in [{g.threshold - g.tolerance:.6g}, {g.threshold + g.tolerance:.6g}]"
            else:
                meas = f"{r.measured:.6g}"
                if r.bracket:
                    meas += f" ± {r.bracket:.2g}"
            delta = "" if (r.delta is None or self.fast) else f"{r.delta:+.4g}"
            out.append(
                {
                    "row": g.label,
                    "expected": f"{g.threshold:.6g} ± {g.tolerance:.3g}",
                    "measured": meas,
                    "delta": delta,
                    "status": r.status,
                    "message": r.message,
                }
            )
        return out

    def diff_text(self) -> str:
        """A plain-text table (fixed width) for logs."""
        rows = self.table_rows()
        cols = ["row", "expected", "measured", "delta", "status"]
        w = {c: max([len(c)] + [len(r[c]) for r in rows]) for c in cols}
        lines = ["  ".join(c.ljust(w[c]) for c in cols), "  ".join("-" * w[c] for c in cols)]
        for r in rows:
            lines.append("  ".join(r[c].ljust(w[c]) for c in cols).rstrip())
            if r["message"]:
                lines.append(f"    {r['message']}")
        c = self.counts
        lines.append(
            f"{c['PASS']} passed, {c['FAIL']} failed, {c['ERROR']} errors, {c['SKIP']} skipped"
            + (" (strict: skips count as failures)" if self.strict and c["SKIP"] else "")
        )
        return "\n".join(lines)

    def markdown(self) -> str:
        """The diff as a Markdown table (for $GITHUB_STEP_SUMMARY or a merge-request note)."""
        c = self.counts
        head = "PASS" if self.ok else "FAIL"
        lines = [
            f"### pbr-xval regress: {head} — `{self.golden}`",
            "",
            f"{c['PASS']} passed, {c['FAIL']} failed, {c['ERROR']} errors, {c['SKIP']} skipped"
            + (" (fast check)" if self.fast else ""),
            "",
            "| row | expected ± tol | measured | delta | status |",
            "|---|---|---|---|---|",
        ]
        for r in self.table_rows():
            st = r["status"] if r["status"] in ("PASS", "SKIP") else f"**{r['status']}**"
            msg = f" — {r['message']}" if r["message"] else ""
            lines.append(f"| {r['row']} | {r['expected']} | {r['measured']} | {r['delta']} | {st}{msg} |")
        return "\n".join(lines) + "\n"


# ------------------------------------------------------------------ reading
def read_golden(path: str | Path) -> tuple[list[GoldenRow], list[str]]:
    """Rows of a golden table and its header (column order, kept by :func:`rewrite_golden`)."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as exc:
        raise GoldenError(f"{path}: cannot read golden table ({exc.strerror})") from None
    reader = csv.DictReader(io.StringIO(text))
    header = list(reader.fieldnames or [])
    missing = [c for c in REQUIRED if c not in header]
    if missing:
        raise GoldenError(
            f"{path}: missing column(s) {missing}; expected columns: {', '.join(GOLDEN_COLUMNS)}"
        )
    unknown = [c for c in header if c not in GOLDEN_COLUMNS]
    if unknown:
        raise GoldenError(
            f"{path}: unknown column(s) {unknown}; expected columns: {', '.join(GOLDEN_COLUMNS)}"
        )
    rows = []
    for raw in reader:
        line = reader.line_num
        if not any((v or "").strip() for v in raw.values()):
            continue

        def num(col: str, _raw: dict[str, str] = raw, _line: int = line) -> float:
            try:
                v = float(_raw[col])
            except (TypeError, ValueError):
                raise GoldenError(
                    f"{path}: line {_line}: column '{col}': expected a number (found {_raw[col]!r})"
                ) from None
            if not math.isfinite(v):
                raise GoldenError(
                    f"{path}: line {_line}: column '{col}': expected a finite number (found {_raw[col]!r})"
                )
            return v

        settings: dict[str, Any] = {}
        st = (raw.get("settings") or "").strip()
        if st:
            try:
                settings = json.loads(st)
            except json.JSONDecodeError as exc:
                raise GoldenError(
                    f"{path}: line {line}: column 'settings': not valid JSON ({exc.msg}): {st!r}"
                ) from None
            if not isinstance(settings, dict):
                raise GoldenError(
                    f"{path}: line {line}: column 'settings': expected a JSON object (found {st!r})"
                )
        thr, tol = num("threshold"), num("tolerance")
        if tol <= 0:
            raise GoldenError(f"{path}: line {line}: column 'tolerance': must be > 0 (found {tol})")
        if thr - MARGIN_TOLS * tol <= 0:
            raise GoldenError(f"{path}: line {line}: tolerance {tol} too large for threshold {thr}")
        for col in ("scenario", "engine", "param"):
            if not (raw.get(col) or "").strip():
                raise GoldenError(f"{path}: line {line}: column '{col}': empty")
        rows.append(
            GoldenRow(
                line=line,
                scenario=raw["scenario"].strip(),
                engine=raw["engine"].strip(),
                profile=(raw.get("profile") or "").strip(),
                param=raw["param"].strip(),
                threshold=thr,
                tolerance=tol,
                settings=settings,
                note=raw.get("note") or "",
                raw={k: (v or "") for k, v in raw.items() if k is not None},
            )
        )
    return rows, header


# ------------------------------------------------------------------ measuring
def _measure(row: GoldenRow, base: Path, fast: bool, wide: bool) -> RowResult:
    from pbr_xval.engine import EngineNotAvailable, EngineSettingsError, NotApplicable, get_engine
    from pbr_xval.scenario import ScenarioError, load_scenario
    from pbr_xval.study.threshold_search import find_threshold

    t0 = time.perf_counter()
    try:
        get_engine(row.engine)
    except EngineNotAvailable as exc:
        return RowResult(row, "SKIP", message=f"engine not available: {exc}")
    try:
        scn = load_scenario(base / row.scenario)
    except ScenarioError as exc:
        return RowResult(row, "ERROR", message=f"scenario: {exc}")
    settings = dict(row.settings)
    if row.profile:
        settings["profile"] = row.profile
    thr, tol = row.threshold, row.tolerance
    try:
        if fast:
            from pbr_xval.runner import run_scene
            from pbr_xval.scene import compile_scene

            flags = []
            for v in (thr - tol, thr + tol):
                traj = run_scene(compile_scene(scn.with_value(row.param, v)), row.engine, settings)
                if not traj.ok:
                    return RowResult(
                        row,
                        "ERROR",
                        message=f"engine failed at {row.param} = {v:.6g}: {traj.message}",
                        wall_time=time.perf_counter() - t0,
                    )
                flags.append(traj.toppled)
            n = 2
            dt = time.perf_counter() - t0
            if not flags[0] and flags[1]:
                return RowResult(row, "PASS", measured=thr, bracket=tol, n_simulations=n, wall_time=dt)
            why = []
            if flags[0]:
                why.append(f"topples already at {thr - tol:.6g} (threshold lower than expected − tol)")
            if not flags[1]:
                why.append(f"stands at {thr + tol:.6g} (threshold higher than expected + tol)")
            return RowResult(row, "FAIL", message="; ".join(why), n_simulations=n, wall_time=dt)

        margin = MARGIN_TOLS * tol
        lo, hi = thr - margin, thr + margin
        n_grid = 3
        if wide:  # --update: the value may have moved far; search a broad range
            lo, hi, n_grid = max(thr * 0.5, thr - 50 * margin), thr + 50 * margin, 12
        rel_tol = (2.0 * tol / BRACKET_DIV) / hi
        res = find_threshold(
            scn,
            row.engine,
            row.param,
            lo=lo,
            hi=hi,
            n_grid=n_grid,
            rel_tol=rel_tol,
            settings=settings,
            all_transitions=False,
        )
    except (EngineSettingsError, NotApplicable, ScenarioError) as exc:
        return RowResult(
            row, "ERROR", message=f"{type(exc).__name__}: {exc}", wall_time=time.perf_counter() - t0
        )
    except Exception as exc:  # engine crash or failed trajectory
        return RowResult(
            row, "ERROR", message=f"{type(exc).__name__}: {exc}", wall_time=time.perf_counter() - t0
        )
    dt = time.perf_counter() - t0
    if res.grid_toppled.size and res.grid_toppled[0]:
        return RowResult(
            row,
            "FAIL",
            message=f"topples already at the bottom of the search range ({lo:.6g})",
            n_simulations=res.n_simulations,
            wall_time=dt,
        )
    if res.minimum is None:
        return RowResult(
            row,
            "FAIL",
            message=f"never topples up to the top of the search range ({hi:.6g})",
            n_simulations=res.n_simulations,
            wall_time=dt,
        )
    m = float(res.minimum)
    status = "PASS" if abs(m - thr) <= tol else "FAIL"
    msg = "" if status == "PASS" else f"|delta| {abs(m - thr):.4g} > tolerance {tol:.4g}"
    return RowResult(
        row,
        status,
        measured=m,
        bracket=res.tolerance,
        message=msg,
        n_simulations=res.n_simulations,
        wall_time=dt,
    )


def regress(
    golden: str | Path,
    engines: Sequence[str] | None = None,
    update: bool = False,
    *,
    strict: bool = False,
    fast: bool = False,
    progress: Callable[[str, float], None] | None = None,
) -> RegressResult:
    """Re-measure every row of the golden table ``golden`` (see the module docstring).

    Parameters
    ----------
    engines : only rows of these engines (None: all rows).
    update : write the measured thresholds back into ``golden`` (atomically; rows that were
        not measured, tolerances and notes are kept). Uses a wide search range.
    strict : a skipped (not installed) engine makes the result fail.
    fast : two-point check per row (stands at threshold − tol, topples at threshold + tol).
    progress : called with (message, fraction done).
    """
    golden = Path(golden)
    rows, _header = read_golden(golden)
    if engines:
        rows = [r for r in rows if r.engine in set(engines)]
    base = golden.resolve().parent
    out: list[RowResult] = []
    for i, row in enumerate(rows):
        if progress is not None:
            progress(row.label, i / max(len(rows), 1))
        res = _measure(row, base, fast=fast and not update, wide=update)
        out.append(res)
    if progress is not None:
        progress("done", 1.0)
    result = RegressResult(golden=golden, rows=out, strict=strict, fast=fast and not update)
    if update:
        rewrite_golden(golden, [r for r in out if r.measured is not None])
        result.updated = True
    return result


def _round_for(tol: float, value: float) -> str:
    """``value`` with enough decimals for a twentieth of the tolerance."""
    decimals = max(0, math.ceil(-math.log10(tol / 20.0)))
    return f"{value:.{decimals}f}"


def rewrite_golden(golden: str | Path, measured: Sequence[RowResult]) -> Path:
    """Write ``measured`` thresholds into ``golden`` (atomically), keeping everything else."""
    from pbr_xval.atomic import write_text_atomic

    golden = Path(golden)
    rows, header = read_golden(golden)
    by_line = {r.row.line: r for r in measured}
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=header, lineterminator="\n")
    w.writeheader()
    for row in rows:
        raw = dict(row.raw)
        r = by_line.get(row.line)
        if r is not None and r.measured is not None:
            raw["threshold"] = _round_for(row.tolerance, r.measured)
        w.writerow({k: raw.get(k, "") for k in header})
    write_text_atomic(golden, buf.getvalue())
    return golden
