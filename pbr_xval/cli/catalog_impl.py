"""Plain functions behind ``pbr-xval sweep`` and ``pbr-xval choose`` (wired into the typer app by cli.py).

Both return a process exit code: 0 success, 1 some chunks failed / no recommendation, 2 invalid input.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from pbr_xval.console import make_console

__all__ = ["choose_command", "sweep_command"]


def escape(text: str) -> str:
    from rich.markup import escape as _escape

    return _escape(text)


def _error(con: Any, msg: str) -> None:
    """``error: <msg>``, one line per line of ``msg`` (never wrapped at the terminal width)."""
    for line in msg.splitlines():
        con.print("[red]error:[/red] " + escape(line), highlight=False, soft_wrap=True)


def sweep_command(
    catalog: Path,
    out: Path,
    engines: list[str] | None = None,
    profile: str | None = None,
    executor: str = "local",
    workers: int | None = None,
    scheduler: str | None = None,
    shard: str | None = None,
    chunk_size: int = 0,
    console: Any = None,
) -> int:
    """Validate ``catalog``, run (the ``shard`` of) its chunks into ``out``, print the summary.

    ``chunk_size`` 0 uses the catalog's ``chunk_size``; ``executor`` is ``local`` (process
    pool, ``workers`` processes), ``dask`` (LocalCluster of ``workers``, or ``scheduler``
    address) or ``inline``. Rerunning resumes: finished chunks are skipped.
    """
    from pbr_xval.atomic import check_output_dir, clean_stale_temporaries
    from pbr_xval.catalog import CatalogError, format_summary, load_catalog, run_sweep
    from pbr_xval.catalog.tasks import parse_shard
    from pbr_xval.engine import registered_names
    from pbr_xval.errors import OutputPathError

    con = make_console(console)
    try:
        cat = load_catalog(catalog)
        parse_shard(shard)
    except (CatalogError, ValueError) as exc:
        _error(con, str(exc))
        return 2
    problems = []
    if executor not in ("local", "dask", "inline"):
        problems.append(f"--executor {executor!r}: expected 'local', 'dask' or 'inline'")
    known = registered_names()
    problems += [
        f"--engine {e!r}: unknown engine; expected one of {', '.join(known)}"
        for e in engines or []
        if e not in known
    ]
    if workers is not None and workers < 1:
        problems.append(f"--workers {workers}: expected at least 1 worker process")
    if chunk_size < 0:
        problems.append(f"--chunk-size {chunk_size}: expected motions per chunk ≥ 1 (0: the catalog's)")
    try:
        check_output_dir(out, "results store")
    except OutputPathError as exc:
        problems.append(str(exc))
    if problems:
        for p in problems:
            _error(con, p)
        return 2
    if out.is_dir():
        clean_stale_temporaries(out, recursive=True)  # chunk files of killed sweeps
    n_sims = len(cat.rocks) * len(cat.motions) * len(engines or cat.engines)
    con.print(
        f"catalog {cat.name!r}: {len(cat.rocks)} rocks × {len(cat.motions)} motions × "
        f"{len(engines or cat.engines)} engines = {n_sims} simulations"
        + (f" (shard {shard})" if shard else ""),
        highlight=False,
    )
    summary = run_sweep(
        cat, out, engines=engines, profile=profile, executor=executor, workers=workers, scheduler=scheduler,
        shard=shard, chunk_size=chunk_size or None, console=con,
    )  # fmt: skip
    con.print(escape(format_summary(summary)), highlight=False)
    con.print(f"results: {out}  (pbr_xval.catalog.load_results)", highlight=False)
    return 1 if summary.failed else 0


def choose_command(catalog: Path, budget: float, out: Path, console: Any = None) -> int:
    """Calibrate on the catalog's ``[choose]`` subset, recommend the cheapest engine/settings
    within ``budget`` (relative, e.g. 0.05), project the full catalog's cost; writes
    ``choose.md`` and ``choose.json`` into ``out``."""
    from pbr_xval.catalog import CatalogError, load_catalog
    from pbr_xval.catalog.choose import choose, format_choice, write_choice

    con = make_console(console)
    try:
        cat = load_catalog(catalog)
    except CatalogError as exc:
        _error(con, str(exc))
        return 2
    if not budget > 0 or not math.isfinite(budget):
        _error(con, f"--budget {budget!r}: expected a positive fraction, e.g. 0.05 or 5%")
        return 2
    from pbr_xval.atomic import check_output_dir
    from pbr_xval.errors import OutputPathError

    try:
        check_output_dir(out, "--out")
    except OutputPathError as exc:
        _error(con, f"{exc} (for choose.md and choose.json)")
        return 2
    result = choose(cat, budget, out, console=con)
    md, js = write_choice(result, out)
    con.print(escape(format_choice(result)), highlight=False)
    con.print(f"written: {md} and {js}", highlight=False)
    return 0 if result.get("recommendation") else 1
