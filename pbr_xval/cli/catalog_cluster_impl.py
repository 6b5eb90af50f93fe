"""``pbr-xval sweep --executor dask --cluster slurm|pbs|local --cluster-config FILE.toml``.

Builds the dask-jobqueue cluster (:mod:`pbr_xval.catalog.cluster`), submits its ``[scale] jobs``
and runs the ordinary sweep through its scheduler (``sweep_command`` with ``scheduler=`` the
cluster's address); ``--job-script`` prints the job script and submits nothing.
Exit codes as ``sweep_command``'s (2: bad input).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

__all__ = ["cluster_sweep_command"]


def cluster_sweep_command(
    catalog: Path,
    out: Path,
    *,
    cluster: str,
    cluster_config: Path | None,
    job_script: bool = False,
    executor: str = "dask",
    scheduler: str | None = None,
    workers: int | None = None,
    console: Any = None,
    **sweep: Any,
) -> int:
    """Check the cluster options, build the cluster, run ``sweep_command`` through it, close it."""
    from pbr_xval.catalog import CatalogError, load_catalog
    from pbr_xval.catalog.cluster import ClusterConfigError, load_cluster_config, make_cluster
    from pbr_xval.cli.catalog_impl import _error, sweep_command
    from pbr_xval.console import make_console

    con = make_console(console)
    problems = []
    if executor != "dask":
        problems.append(f"--cluster {cluster}: needs --executor dask")
    if scheduler:
        problems.append("--cluster and --scheduler: give one (the cluster starts its own scheduler)")
    if cluster_config is None:
        problems.append(f"--cluster {cluster}: needs --cluster-config FILE.toml")
    if workers is not None and workers < 1:
        problems.append(f"--workers {workers}: expected at least 1 job")
    cfg = None
    if cluster_config is not None:
        try:
            cfg = load_cluster_config(cluster_config, cluster)
        except ClusterConfigError as exc:
            problems.append(str(exc))
    if problems or cfg is None:
        for p in problems:
            _error(con, p)
        return 2
    if not job_script:
        try:  # a bad catalog is reported by sweep_command before any job is submitted
            load_catalog(catalog)
        except CatalogError:
            return sweep_command(catalog, out, executor="dask", workers=workers, console=con, **sweep)
    try:
        jq = make_cluster(cluster, cfg)
    except ClusterConfigError as exc:
        _error(con, str(exc))
        return 2
    try:
        if job_script:
            print(jq.job_script(), flush=True)
            return 0
        jobs = cfg["scale"]["jobs"] or workers or 1
        jq.scale(jobs=jobs)
        con.print(
            f"{cluster} cluster: {jobs} job(s) submitted; scheduler {jq.scheduler_address}", highlight=False
        )
        return sweep_command(
            catalog,
            out,
            executor="dask",
            scheduler=jq.scheduler_address,
            workers=workers,
            console=con,
            **sweep,
        )
    finally:
        jq.close()
