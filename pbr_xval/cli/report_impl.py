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

import contextlib
import hashlib
import os
import re
import sys
import tempfile
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

from pbr_xval.console import make_console

__all__ = [
    "demo_command",
    "examples_dir",
    "log_progress",
    "quiet_native_stdout",
    "regress_command",
    "report_command",
    "verdict_table",
]

#: seconds between two plain progress lines when the output is not a terminal
LOG_INTERVAL_S = 10.0

#: native start-up lines of engine libraries written straight to fd 1 (they break a progress bar)
BANNERS = (re.compile(r"^pybullet build time: "),)


def _cmdline() -> str:
    argv = list(sys.argv)
    if argv:
        argv[0] = Path(argv[0]).name
    return " ".join(argv)


def log_progress(
    console: Any, interval: float = LOG_INTERVAL_S, clock: Callable[[], float] = time.monotonic
) -> Callable[[str, float], None]:
    """A ``(message, fraction)`` progress callback printing plain lines (CI logs, batch jobs).

    A line is printed when a new section starts and otherwise at most every ``interval`` seconds:
    ``[  42 s]  37 % ETA 71 s  Housner block ...: thresholds: mujoco #7 ...``.
    """
    t0 = clock()
    state: dict[str, Any] = {"last": -float("inf"), "section": None}

    def cb(msg: str, frac: float) -> None:
        now = clock()
        section = msg.split(":", 1)[0]
        if section == state["section"] and now - state["last"] < interval and frac < 1.0:
            return
        state.update(last=now, section=section)
        el = now - t0
        eta = f"ETA {el / frac * (1 - frac):.0f} s" if 0.02 < frac < 1.0 else ""
        console.print(
            f"[{el:5.0f} s] {100 * frac:3.0f} % {eta:>10}  {msg}",
            markup=False,
            highlight=False,
            soft_wrap=True,
        )

    return cb


@contextlib.contextmanager
def quiet_native_stdout(console: Any) -> Iterator[None]:
    """Keep native start-up banners (engine libraries, also in worker processes) off the console.

    PyBullet writes ``pybullet build time: ...`` straight to fd 2 when it is imported (in this
    process and in every worker), which breaks a progress bar. While active, fds 1 and 2 are
    pipes read by a thread each: lines matching :data:`BANNERS` are dropped; any other line goes
    through ``console.print`` (above the bar) when the console is a terminal, else unchanged to
    the original stream. The console itself writes to a copy of its original fd. Does nothing
    for streams that are not the process's fds 1 and 2 (e.g. under pytest's capture).
    """
    streams = []
    for fd, stream in ((1, sys.stdout), (2, sys.stderr)):
        try:
            if stream.fileno() == fd:
                streams.append((fd, stream))
        except (AttributeError, OSError, ValueError):
            pass
    if not streams:
        yield
        return
    try:
        cfile = console.file
        cfd = cfile.fileno() if cfile in (sys.stdout, sys.stderr, sys.__stdout__, sys.__stderr__) else None
    except (AttributeError, OSError, ValueError):
        cfd = None
    original = getattr(console, "_file", None)
    live = bool(console.is_terminal)
    saved: dict[int, int] = {}
    threads: list[threading.Thread] = []
    own = None

    def pump(r: int, out_fd: int) -> None:
        with os.fdopen(r, "rb") as f:
            for raw in f:
                line = raw.decode("utf-8", "replace").rstrip("\n")
                if any(b.search(line) for b in BANNERS):
                    continue
                with contextlib.suppress(Exception):
                    if live:
                        console.print(line, markup=False, highlight=False, soft_wrap=True)
                    else:
                        os.write(out_fd, raw)

    for fd, stream in streams:
        stream.flush()
        saved[fd] = os.dup(fd)
        r, w = os.pipe()
        os.dup2(w, fd)
        os.close(w)
        th = threading.Thread(target=pump, args=(r, saved[fd]), name=f"pbr-xval-fd{fd}", daemon=True)
        th.start()
        threads.append(th)
    if cfd in saved:
        own = os.fdopen(
            os.dup(saved[cfd]), "w", buffering=1, encoding=getattr(cfile, "encoding", None) or "utf-8"
        )
        console.file = own
    try:
        yield
    finally:
        for _, stream in streams:
            with contextlib.suppress(Exception):
                stream.flush()
        with contextlib.suppress(Exception):  # C stdio buffers of native code
            import ctypes

            ctypes.CDLL(None).fflush(None)
        for fd, s in saved.items():
            os.dup2(s, fd)  # closes the pipe's write end held as fd: the pumps see EOF
        for th in threads:
            th.join(timeout=2.0)
        for s in saved.values():
            os.close(s)
        if own is not None:
            console.file = original
            own.close()


def verdict_table(verdict: Any, title: str = "Verdict") -> list[Any]:
    """The verdict as rich tables, one per case (titled with the case and its reference), with the numbers."""
    from rich.markup import escape
    from rich.table import Table

    colours = {"pass": "green", "attention": "yellow", "failed": "red", "reference": "cyan"}
    out = []
    for case in verdict.cases:
        t = Table(
            title=f"{title}: {escape(case.title)}",
            caption=escape(f"vs {case.reference_text}; tolerance {case.tolerance_text}"),
            title_justify="left",
            caption_justify="left",
        )
        for col, just in (
            ("engine", "left"),
            ("value", "right"),
            ("deviation", "right"),
            ("tolerance", "right"),
            ("verdict", "left"),
            ("sims", "right"),
            ("wall s", "right"),
        ):
            t.add_column(col, justify=just)  # type: ignore[arg-type]
        for eng in verdict.engines:
            c = verdict.cell(eng, case.key)
            if c is None:
                continue
            t.add_row(
                escape(eng),
                escape(c.value_text),
                escape(c.deviation_text),
                "" if c.tolerance is None else f"±{100 * c.tolerance:.2f} %",
                f"[{colours.get(c.status, 'dim')}]{c.status}[/]",
                "" if c.n_sims is None else str(c.n_sims),
                "" if c.wall_s is None else f"{c.wall_s:.1f}",
            )
        out.append(t)
    return out


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
    from pbr_xval.study.study_file import StudyFileError, is_failed, load_study_spec, run_study

    con = make_console(console)
    study_path = Path(study_path)
    try:
        spec = load_study_spec(study_path, quick=quick)
    except StudyFileError as exc:
        con.print(f"[red]error:[/] {escape(str(exc))}")
        return 2
    from pbr_xval.atomic import check_output_dir
    from pbr_xval.errors import OutputPathError

    try:  # before the study runs, not after
        check_output_dir(Path(out_root) / spec.name, "--out")
    except OutputPathError as exc:
        con.print(f"[red]error:[/] {escape(str(exc))}", soft_wrap=True, highlight=False)
        return 2
    from pbr_xval.report.describe import describe_scenario
    from pbr_xval.report.verdict import build_verdict

    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix=f"pbr_xval_{spec.name}_") as work:
        show = progress if progress is not None else con.is_terminal
        with quiet_native_stdout(con):
            results = run_study(spec, True if show else log_progress(con), work_dir=Path(work), console=con)
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
                    "summary": describe_scenario(s.scenario) if s.scenario else "",
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
    table = Table(title=f"{spec.title} — {wall:.0f} s", title_justify="left")
    for col in ("section", "status", "wall s"):
        table.add_column(col, overflow="fold")
    for r in results:
        bad = is_failed(r)
        status = f"[red]{r.provenance.get('status')}[/]" if bad else "[green]ok[/]"
        table.add_row(escape(r.title), status, f"{r.wall_time:.1f}")
    con.print(table)
    verdict = build_verdict(results)
    for t in verdict_table(verdict):
        con.print(t)
    for h in verdict.headlines:
        con.print(f"  {_plain(h)}", markup=False, highlight=False)
    for f in verdict.findings:
        con.print(f"  [yellow]![/] {escape(_plain(f))}")
    for n in spec.notes:
        con.print(f"[dim]note: {escape(n)}[/]")
    con.print(
        f"report written to [bold]{escape(str(out / 'index.html'))}[/] (summary: {escape(str(out / 'summary.md'))})"
    )
    if spec.interrupted:
        return 130
    return 1 if any(is_failed(r) for r in results) else 0


def _plain(md: str) -> str:
    """Markdown emphasis removed (``**x**``, ``*x*``, backticks) for the terminal."""
    return re.sub(r"\*\*(.+?)\*\*|\*(.+?)\*|`(.+?)`", lambda m: next(g for g in m.groups() if g), md)


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

    con = make_console(console)
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
    counts = res.counts
    con.print(
        f"{counts['PASS']} passed, {counts['FAIL']} failed, {counts['ERROR']} errors, {counts['SKIP']} skipped"
        + (" (strict: skipped engines fail)" if strict and counts["SKIP"] else "")
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
        return 1 if (counts["ERROR"] or (strict and counts["SKIP"])) else 0
    return res.exit_code


def examples_dir() -> Path:
    """The repository's ``examples`` folder (a source checkout; not part of the wheel)."""
    import pbr_xval

    return Path(pbr_xval.__file__).resolve().parents[1] / "examples"


def demo_command(out_root: Path = Path("reports"), quick: bool = False, console: Any = None) -> int:
    """Run ``examples/studies/demo.toml`` and write ``<out_root>/demo/``; returns the exit code."""
    from rich.markup import escape

    con = make_console(console)
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
    if code != 2:  # bad input: the one error line says it all
        con.print(f"demo finished in {time.perf_counter() - t0:.0f} s" + (" (quick)" if quick else ""))
    return code
