"""Plain functions behind ``pbr-xval report``, ``pbr-xval regress`` and ``pbr-xval demo``.

They return an exit code and print through a rich console, so the typer commands in
:mod:`pbr_xval.cli` stay thin.

Exit codes
----------
report / demo : 0 every section ran; 1 a section failed; 2 the study file is invalid or
    the examples are missing; 130 interrupted (what was computed is written).
regress : 0 every row within tolerance (skipped engines allowed unless ``strict``);
    1 a row out of tolerance, an engine error, or (strict) a skipped engine;
    2 the golden table is malformed or missing.
"""

from __future__ import annotations

import hashlib
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

__all__ = ["demo_command", "examples_dir", "regress_command", "report_command"]


def _console(console: Any) -> Any:
    if console is not None:
        return console
    from rich.console import Console

    return Console()


def _cmdline() -> str:
    argv = list(sys.argv)
    if argv:
        argv[0] = Path(argv[0]).name
    return " ".join(argv)


def report_command(
    study_path: Path,
    out_root: Path = Path("reports"),
    console: Any = None,
    *,
    quick: bool = False,
    progress: bool | None = None,
) -> int:
    """Run the study file ``study_path`` and write ``<out_root>/<name>/``; returns the exit code.

    ``quick`` applies each study's ``quick`` option table (smaller grids). ``progress``: a
    rich progress bar with ETA (default: when the console is a terminal).
    """
    from rich.markup import escape
    from rich.table import Table

    from pbr_xval.report import write_report
    from pbr_xval.study.spec import StudyFileError, is_failed, load_study_spec, run_study

    con = _console(console)
    study_path = Path(study_path)
    try:
        spec = load_study_spec(study_path, quick=quick)
    except StudyFileError as exc:
        con.print(f"[red]error:[/] {escape(str(exc))}")
        return 2
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix=f"pbr_xval_{spec.name}_") as work:
        show = progress if progress is not None else con.is_terminal
        results = run_study(spec, True if show else False, work_dir=Path(work), console=con)
        wall = time.perf_counter() - t0
        prov = {
            "title": spec.title,
            "description": spec.description,
            "command_line": _cmdline(),
            "study_file": str(study_path),
            "study_file_sha256": hashlib.sha256(study_path.read_bytes()).hexdigest(),
            "quick": quick,
            "wall_time_s": round(wall, 3),
            "engines_requested": "all" if spec.engines_all else list(spec.engines),
            "engines_used": list(spec.engines),
            "scenarios": [
                {
                    "name": s.scenario.name if s.scenario else s.label,
                    "label": s.label,
                    "hash": s.scenario.content_hash() if s.scenario else "",
                    "file": str(s.path) if s.path else f"{s.label}.toml (generated)",
                }
                for s in spec.scenarios
            ],
        }
        notes = list(spec.notes)
        if spec.interrupted:
            notes.append("the run was interrupted (Ctrl-C): the sections not run are marked")
        out = write_report(
            results,
            Path(out_root) / spec.name,
            provenance=prov,
            title=spec.title,
            description=spec.description,
            assets=spec.assets,
            notes=notes,
        )
    table = Table(title=f"{spec.title} — {wall:.0f} s")
    for col in ("section", "status", "wall s", "summary"):
        table.add_column(col)
    for r in results:
        bad = is_failed(r)
        status = f"[red]{r.provenance.get('status')}[/]" if bad else "[green]ok[/]"
        table.add_row(
            escape(r.title), status, f"{r.wall_time:.1f}", escape(r.summary[0] if r.summary else "")
        )
    con.print(table)
    for n in spec.notes:
        con.print(f"[dim]note: {escape(n)}[/]")
    con.print(
        f"report written to [bold]{escape(str(out / 'index.html'))}[/] (summary: {escape(str(out / 'summary.md'))})"
    )
    if spec.interrupted:
        return 130
    return 1 if any(is_failed(r) for r in results) else 0


def regress_command(
    golden: Path,
    update: bool,
    engines: list[str] | None,
    fast: bool,
    console: Any = None,
    *,
    strict: bool = False,
    markdown: Path | None = None,
) -> int:
    """Re-measure the golden table; print the diff; returns the exit code (see the module docstring).

    ``markdown``: also append the diff as Markdown to this file (e.g. ``$GITHUB_STEP_SUMMARY``).
    """
    from rich.markup import escape
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn
    from rich.table import Table

    from pbr_xval.study.regress import GoldenError, regress

    con = _console(console)
    if update and fast:
        con.print("[yellow]note:[/] --fast is ignored with --update (the values are measured in full)")
    try:
        with Progress(
            TextColumn("{task.description}"),
            BarColumn(),
            TimeElapsedColumn(),
            TextColumn("ETA"),
            TimeRemainingColumn(),
            console=con,
            transient=True,
            disable=not con.is_terminal,
        ) as bar:
            task = bar.add_task("regress", total=1.0)
            res = regress(
                golden,
                engines=engines or None,
                update=update,
                strict=strict,
                fast=fast,
                progress=lambda m, f: bar.update(task, completed=f, description=m[:60]),
            )
    except GoldenError as exc:
        con.print(f"[red]error:[/] {escape(str(exc))}")
        return 2
    colours = {"PASS": "green", "FAIL": "red", "ERROR": "red", "SKIP": "yellow"}
    table = Table(title=f"pbr-xval regress {golden}" + (" (fast check)" if res.fast else ""))
    for col in ("row", "expected ± tol", "measured", "delta", "status"):
        table.add_column(col)
    for r in res.table_rows():
        c = colours[r["status"]]
        table.add_row(escape(r["row"]), r["expected"], r["measured"], r["delta"], f"[{c}]{r['status']}[/]")
    con.print(table)
    for r in res.table_rows():
        if r["message"]:
            con.print(
                f"  [{colours[r['status']]}]{r['status']}[/] {escape(r['row'])}: {escape(r['message'])}"
            )
    c = res.counts
    con.print(
        f"{c['PASS']} passed, {c['FAIL']} failed, {c['ERROR']} errors, {c['SKIP']} skipped"
        + (" (strict: skipped engines fail)" if strict and c["SKIP"] else "")
    )
    if markdown is not None:
        with open(markdown, "a", encoding="utf-8") as f:
            f.write(res.markdown())
    if update:
        n = sum(r.measured is not None for r in res.rows)
        con.print(
            f"[bold]{golden}[/] rewritten: {n} threshold(s) updated; tolerances and notes kept. "
            "Review with `git diff` and commit."
        )
        # after an update the table holds the measured values: only errors fail
        return 1 if (c["ERROR"] or (strict and c["SKIP"])) else 0
    return res.exit_code


def examples_dir() -> Path:
    """The repository's ``examples`` folder (a source checkout; not part of the wheel)."""
    import pbr_xval

    return Path(pbr_xval.__file__).resolve().parents[1] / "examples"


def demo_command(out_root: Path = Path("reports"), quick: bool = False, console: Any = None) -> int:
    """Run ``examples/studies/demo.toml`` and write ``<out_root>/demo/``; returns the exit code."""
    from rich.markup import escape

    con = _console(console)
    ex = examples_dir()
    demo = ex / "studies" / "demo.toml"
    if not demo.is_file():
        con.print(
            f"[red]error:[/] the demo needs the repository's examples folder, expected {escape(str(demo))}. "
            "Run it from a source checkout (git clone ...; pip install -e .)."
        )
        return 2
    t0 = time.perf_counter()
    code = report_command(demo, out_root, con, quick=quick)
    con.print(f"demo finished in {time.perf_counter() - t0:.0f} s" + (" (quick)" if quick else ""))
    return code
