"""``pbr-xval fragility | constrain``: rock fragility ready for hazard, and the hazard the rocks constrain."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from pbr_xval.cli._app import app, console


@app.command()
def fragility(
    results: Annotated[Path, typer.Argument(help="sweep results store (pbr-xval sweep OUT)")],
    catalog: Annotated[
        Path | None, typer.Option(help="the sweep's catalog (TOML): needed for SA(T), recomputed from it")
    ] = None,
    period: Annotated[
        list[float] | None, typer.Option("--period", "-T", help="SA(T) period in s (repeatable)")
    ] = None,
    engine: Annotated[str | None, typer.Option(help="only this engine's runs")] = None,
    ci: Annotated[float, typer.Option(help="confidence level of the profile-likelihood intervals")] = 0.95,
    out: Annotated[Path, typer.Option(help="folder for fits.csv, fragility.csv and NRML files")] = Path(
        "reports/fragility"
    ),
    ensemble: Annotated[
        bool,
        typer.Option(
            "--ensemble",
            help="RESULTS holds ensemble members (a `validate --ensemble` folder, its ensemble_members.csv or "
            "store): θ, β on PGA and PGV with a two-stage bootstrap band (records, then members)",
        ),
    ] = False,
    bootstrap: Annotated[int, typer.Option(help="--ensemble: bootstrap refits of the band")] = 200,
) -> None:
    """Lognormal fragility per rock on PGA, PGV, SA(T) (binomial MLE, profile-likelihood CIs), the
    vector fragility on (PGA, PGV/PGA), the IMs ranked by dispersion; NRML and CSV export."""
    if ensemble:
        from pbr_xval.cli.fragility_ensemble_impl import ensemble_fragility_command

        code = ensemble_fragility_command(
            results, engine=engine, ci=ci, n_boot=bootstrap, out=out, console=console
        )
        if code:
            raise typer.Exit(code)
        return
    from pbr_xval.cli.hazard_impl import fragility_command

    code = fragility_command(results, catalog, period or [], engine, ci, out, console)
    if code:
        raise typer.Exit(code)


@app.command()
def constrain(
    config: Annotated[
        Path | None,
        typer.Argument(help="constrain file (TOML): hazard branches, rocks, ages (docs/hazard.md)"),
    ] = None,
    out: Annotated[Path, typer.Option(help="report folder (index.html, curves.csv, branches.csv)")] = Path(
        "reports/constrain"
    ),
    example: Annotated[
        bool, typer.Option(help="write the synthetic example's inputs into OUT/inputs and run it")
    ] = False,
    joint: Annotated[
        str | None, typer.Option(help="independent | shared-events (overrides the file)")
    ] = None,
    rate: Annotated[
        float | None, typer.Option(help="annual rate of interest, 1/yr (overrides the file)")
    ] = None,
) -> None:
    """Survival probability of each rock under each hazard branch, the joint survival, and the
    hazard reweighted by it: mean and fractile curves before and after, as an HTML report."""
    from pbr_xval.cli.hazard_impl import constrain_command

    code = constrain_command(config, out, example, joint, rate, console)
    if code:
        raise typer.Exit(code)
