"""``pbr-xval predict``: P(topple) of a scenario from its ``[uncertainty]`` ensemble."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from pbr_xval.cli._app import ProfileOpt, app, console


@app.command()
def predict(
    scenario: Annotated[
        Path, typer.Argument(help="scenario with an [uncertainty] table (docs/scenarios.md)")
    ],
    members: Annotated[
        int | None,
        typer.Option(help="members to run (the most, with --half-width); default [uncertainty].members"),
    ] = None,
    engine: Annotated[
        list[str] | None,
        typer.Option(
            "--engine", "-e", help="engines (repeatable): restrict the [uncertainty].engines mixture"
        ),
    ] = None,
    out: Annotated[
        Path | None,
        typer.Option(
            help="folder for members.csv, predict.json and the store (default reports/predict_<name>)"
        ),
    ] = None,
    workers: Annotated[int, typer.Option(help="worker processes")] = 2,
    half_width: Annotated[
        float | None,
        typer.Option(
            help="adaptive: add members a batch at a time until the Jeffreys interval's half-width ≤ H "
            "or the interval lies entirely above or below 0.5 (up to --members)"
        ),
    ] = None,
    batch: Annotated[int, typer.Option(help="members per batch (and per chunk of the store)")] = 4,
    engine_set: Annotated[
        list[str] | None,
        typer.Option("--engine-set", help="engine setting KEY=VALUE for every engine (repeatable)"),
    ] = None,
    profile: ProfileOpt = None,
    member: Annotated[
        int | None,
        typer.Option(
            help="re-run only this member (0-based) in this process, bit for bit, and write its trajectory "
            "(--out: a Parquet file; default <out>/member_<i>.<engine>.parquet)"
        ),
    ] = None,
) -> None:
    """Run the scenario's ensemble (parallel, resumable, crash-contained): P(topple) with its Jeffreys
    95 % interval and the share per engine; members.csv and predict.json."""
    from pbr_xval.cli.predict_impl import predict_command

    code = predict_command(
        scenario, members=members, engines=engine or [], out=out, workers=workers, half_width=half_width,
        batch=batch, engine_set=engine_set, profile=profile, console=console, member=member,
    )  # fmt: skip
    if code:
        raise typer.Exit(code)
