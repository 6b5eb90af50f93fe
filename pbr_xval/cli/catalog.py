"""``pbr-xval sweep | choose``: rock catalogs at scale."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from pbr_xval.cli._app import ProfileOpt, _fail, _fraction, app, console


@app.command()
def sweep(
    catalog: Annotated[Path, typer.Argument(help="catalog file (TOML)")],
    out: Annotated[Path, typer.Argument(help="results store (partitioned Parquet dataset)")],
    engine: Annotated[
        list[str] | None, typer.Option("--engine", "-e", help="engines (default: the catalog's)")
    ] = None,
    profile: ProfileOpt = None,
    executor: Annotated[str, typer.Option(help="local | dask | inline")] = "local",
    workers: Annotated[int | None, typer.Option(help="worker processes (default: CPU count)")] = None,
    scheduler: Annotated[str | None, typer.Option(help="Dask scheduler address tcp://host:port")] = None,
    shard: Annotated[str | None, typer.Option(help="run only shard i/N of the chunks (job arrays)")] = None,
    chunk_size: Annotated[int, typer.Option(help="motions per chunk (0: the catalog's)")] = 0,
    cluster: Annotated[
        str | None, typer.Option(help="with --executor dask: a dask-jobqueue cluster, slurm | pbs | local")
    ] = None,
    cluster_config: Annotated[
        Path | None, typer.Option(help="TOML with [cluster] (dask-jobqueue keywords) and [scale] jobs")
    ] = None,
    job_script: Annotated[
        bool, typer.Option("--job-script", help="print the cluster's job script and exit (submits nothing)")
    ] = False,
) -> None:
    """Run a rock catalog × motion set × engines, chunk by chunk, resumable (reruns skip finished chunks)."""
    from pbr_xval.cli.catalog_impl import sweep_command

    if cluster is not None:
        from pbr_xval.cli.catalog_cluster_impl import cluster_sweep_command

        code = cluster_sweep_command(
            catalog, out, cluster=cluster, cluster_config=cluster_config, job_script=job_script,
            executor=executor, scheduler=scheduler, workers=workers, console=console,
            engines=engine, profile=profile, shard=shard, chunk_size=chunk_size,
        )  # fmt: skip
    else:
        code = sweep_command(
            catalog, out, engine, profile, executor, workers, scheduler, shard, chunk_size, console
        )
    if code:
        raise typer.Exit(code)


@app.command()
def choose(
    catalog: Annotated[
        Path | None, typer.Argument(help="catalog file (TOML) with a [choose] table (not with --campaign)")
    ] = None,
    budget: Annotated[
        str, typer.Option(help="accuracy budget, e.g. 5% (fragility median vs the reference)")
    ] = "5%",
    out: Annotated[
        Path | None,
        typer.Option(
            help="report folder (default reports/choose; with --campaign reports/tradeoff_<scenario>)"
        ),
    ] = None,
    campaign: Annotated[
        Path | None, typer.Option(help="shake-table campaign: score settings against observed outcomes")
    ] = None,
    specimen: Annotated[int, typer.Option(help="specimen number (with --campaign)")] = 1,
    scenario: Annotated[Path | None, typer.Option(help="the specimen's scenario (with --campaign)")] = None,
    engine: Annotated[
        list[str] | None,
        typer.Option("--engine", "-e", help="engines (with --campaign; default mujoco, pybullet)"),
    ] = None,
    profiles: Annotated[str | None, typer.Option("--profile", help="profiles, comma-separated")] = None,
    timestep: Annotated[
        str | None, typer.Option(help="time steps, s, comma-separated (default: the profile's)")
    ] = None,
    collision: Annotated[
        str | None,
        typer.Option(
            help="collision geometries, comma-separated: hull,coacd,decimated (engine:kind for one engine)"
        ),
    ] = None,
    tests: Annotated[str | None, typer.Option(help="campaign tests, comma-separated")] = None,
    limit: Annotated[int | None, typer.Option(help="the first N (selected) tests")] = None,
    margin_se: Annotated[
        float, typer.Option(help="recommend within this many standard errors of the best Brier (paired)")
    ] = 1.0,
    store: Annotated[
        Path | None, typer.Option(help="folder for the runs' store and motions (default: --out)")
    ] = None,
    workers: Annotated[int, typer.Option(help="worker processes (with --campaign)")] = 2,
) -> None:
    """Recommend the cheapest engine and settings: within an accuracy budget of a reference on a
    catalog (projecting its cost), or, with --campaign, within a margin of the best Brier score
    against shake-table outcomes (Pareto front of cost vs Brier)."""
    if campaign is not None:
        from pbr_xval.cli.catalog_choose_impl import choose_campaign_command

        if catalog is not None:
            raise _fail("give either a CATALOG or --campaign, not both")
        code = choose_campaign_command(
            campaign, specimen=specimen, scenario=scenario, engines=engine, profiles=profiles,
            timesteps=timestep, collisions=collision, tests=tests, limit=limit, margin_se=margin_se,
            out=out, work=store, workers=workers, console=console,
        )  # fmt: skip
        if code:
            raise typer.Exit(code)
        return
    from pbr_xval.cli.catalog_impl import choose_command

    if catalog is None:
        raise _fail("give a CATALOG file, or --campaign with --specimen and --scenario")
    try:
        fraction = _fraction(budget)
    except typer.BadParameter as exc:
        raise _fail(f"--budget: {exc}") from None
    code = choose_command(catalog, fraction, out or Path("reports/choose"), console)
    if code:
        raise typer.Exit(code)
