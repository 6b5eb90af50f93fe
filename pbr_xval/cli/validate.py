"""``pbr-xval validate``: predictions scored against shake-table experiments."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from pbr_xval.cli._app import SetOpt, app, console


@app.command()
def validate(
    campaign: Annotated[
        Path,
        typer.Argument(
            help="campaign: a directory with experiments.csv + table_motions.npz, or a CSV "
            "(test, motion_file, units, toppled[, dt, motion, specimen])"
        ),
    ],
    specimen: Annotated[int, typer.Option(help="specimen number (column toppled_specimen<N>)")] = 1,
    scenario: Annotated[
        Path | None,
        typer.Option(help="scenario of the specimen (its excitation is replaced by each test's motion)"),
    ] = None,
    engine: Annotated[list[str] | None, typer.Option("--engine", "-e", help="engines (repeatable)")] = None,
    out: Annotated[
        Path | None, typer.Option(help="report folder (default reports/validate_<scenario>/)")
    ] = None,
    tests: Annotated[
        str | None, typer.Option(help="comma-separated test identifiers to run (default: all)")
    ] = None,
    limit: Annotated[int | None, typer.Option(help="run only the first N tests (after --tests)")] = None,
    folds: Annotated[int, typer.Option(help="folds of the record-grouped cross-validation of the rules")] = 4,
    highpass: Annotated[
        float, typer.Option(help="baseline correction: high-pass corner, Hz (0: none)")
    ] = 0.3,
    lowpass: Annotated[float, typer.Option(help="baseline correction: low-pass corner, Hz (0: none)")] = 25.0,
    detrend: Annotated[str, typer.Option(help="baseline correction: linear | constant | none")] = "linear",
    resample: Annotated[
        float, typer.Option(help="resample corrected records to this rate, Hz (0: keep)")
    ] = 200.0,
    tail: Annotated[float, typer.Option(help="simulated time after each motion ends, s")] = 3.0,
    workers: Annotated[int, typer.Option(help="worker processes")] = 2,
    chunk_size: Annotated[
        int,
        typer.Option(help="tests per chunk (the unit of resumption; 1 lets any subset reuse stored runs)"),
    ] = 1,
    baseline_source: Annotated[
        str, typer.Option(help="intensity measures of the rules: auto | sheet | record")
    ] = "auto",
    transfer: Annotated[
        str | None,
        typer.Option(
            help="also the transferred logistic baseline, fitted on another specimen's tests in IMs normalised "
            "by each rock's geometry: CAMPAIGN:SPECIMEN:SCENARIO (e.g. ../shared/data/shake_table:2:sp2.toml)"
        ),
    ] = None,
    calibration: Annotated[
        Path | None,
        typer.Option(
            help="also the rules and logistic baselines fitted on every test of another campaign and applied "
            "unchanged to these tests (models '<name>@calibration'): CAMPAIGN[:SPECIMEN], e.g. the calibration "
            "half when scoring the held-out half (default specimen: --specimen)"
        ),
    ] = None,
    set_: SetOpt = None,
    ensemble: Annotated[
        bool,
        typer.Option(
            "--ensemble",
            help="also P(topple) per test from the scenario's [uncertainty] ensemble (model 'ensemble': "
            "Brier, log loss, AUC, F1 at P ≥ 0.5); --engine restricts its engine mixture",
        ),
    ] = False,
    members: Annotated[
        int | None, typer.Option(help="--ensemble: members per test (default [uncertainty].members)")
    ] = None,
    half_width: Annotated[
        float | None,
        typer.Option(
            help="--ensemble, adaptive: members in batches until each test's Jeffreys 95 % half-width is at "
            "most this, or its interval excludes 0.5 (decided), up to --members"
        ),
    ] = None,
    batch: Annotated[int, typer.Option(help="--half-width: members added per batch")] = 4,
) -> None:
    """Run every test of a shake-table campaign on each engine; F1 and the empirical baselines; CSV + HTML."""
    from pbr_xval.cli.validate_impl import validate_command

    code = validate_command(
        campaign, specimen=specimen, scenario=scenario, engines=engine or [], out=out, tests=tests,
        limit=limit, folds=folds, highpass=highpass, lowpass=lowpass, detrend=detrend, resample=resample, tail=tail,
        workers=workers, chunk_size=chunk_size, baseline_source=baseline_source, sets=set_, console=console,
        transfer=transfer, calibration=str(calibration) if calibration else None,
        ensemble=ensemble, members=members, half_width=half_width, batch=batch,
    )  # fmt: skip
    if code:
        raise typer.Exit(code)
