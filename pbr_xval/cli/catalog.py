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
) -> None:
    """Run a rock catalog × motion set × engines, chunk by chunk, resumable (reruns skip finished chunks)."""
    from pbr_xval.cli.catalog_impl import sweep_command

    code = sweep_command(
        catalog, out, engine, profile, executor, workers, scheduler, shard, chunk_size, console
    )
    if code:
        raise typer.Exit(code)


@app.command()
def choose(
    catalog: Annotated[Path, typer.Argument(help="catalog file (TOML) with a [choose] table")],
    budget: Annotated[
        str, typer.Option(help="accuracy budget, e.g. 5% (fragility median vs the reference)")
    ] = "5%",
    out: Annotated[Path, typer.Option(help="where choose.md / choose.json are written")] = Path(
        "reports/choose"
    ),
) -> None:
    """Recommend the cheapest engine and settings within an accuracy budget; project the catalog's cost."""
    from pbr_xval.cli.catalog_impl import choose_command

    try:
        fraction = _fraction(budget)
    except typer.BadParameter as exc:
        raise _fail(f"--budget: {exc}") from None
    code = choose_command(catalog, fraction, out, console)
    if code:
        raise typer.Exit(code)
