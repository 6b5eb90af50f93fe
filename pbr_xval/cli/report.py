"""``pbr-xval report | regress | demo``: studies, golden-table regression, the main job."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from pbr_xval.cli._app import app, console


@app.command()
def report(
    study: Annotated[Path, typer.Argument(help="study file (TOML), e.g. examples/studies/housner.toml")],
    out: Annotated[Path, typer.Option(help="reports folder; the report goes to <out>/<name>/")] = Path(
        "reports"
    ),
    quick: Annotated[bool, typer.Option(help="apply each study's [quick] options (smaller grids)")] = False,
) -> None:
    """Run a study file across engines and write reports/<name>/ (index.html, summary.md, CSV, Parquet)."""
    from pbr_xval.cli.report_impl import report_command

    code = report_command(study, out, console, quick=quick)
    if code:
        raise typer.Exit(code)


@app.command()
def regress(
    golden: Annotated[
        Path, typer.Argument(help="golden threshold table (CSV), e.g. examples/golden/thresholds.csv")
    ],
    update: Annotated[bool, typer.Option(help="re-measure and rewrite the thresholds on purpose")] = False,
    engine: Annotated[list[str] | None, typer.Option("--engine", "-e", help="only these engines")] = None,
    fast: Annotated[
        bool, typer.Option(help="two simulations per row: stands at value−tol, topples at value+tol")
    ] = False,
    strict: Annotated[bool, typer.Option(help="a missing engine is a failure")] = False,
    markdown: Annotated[
        Path | None, typer.Option(help="append the diff as Markdown (e.g. $GITHUB_STEP_SUMMARY)")
    ] = None,
) -> None:
    """Re-measure every golden toppling threshold; exit 1 with a readable diff if one leaves its tolerance."""
    from pbr_xval.cli.report_impl import regress_command

    code = regress_command(golden, update, engine, fast, console, strict=strict, markdown=markdown)
    if code:
        raise typer.Exit(code)


@app.command()
def demo(
    out: Annotated[Path, typer.Option(help="reports folder; the demo report goes to <out>/demo/")] = Path(
        "reports"
    ),
    quick: Annotated[bool, typer.Option(help="a smaller, faster demo")] = False,
) -> None:
    """The main job on the built-in examples: Housner, curved-base and synthetic-rock scenarios across all engines."""
    from pbr_xval.cli.report_impl import demo_command

    code = demo_command(out, quick, console)
    if code:
        raise typer.Exit(code)
