"""A batch-scheduler Dask cluster for ``pbr-xval sweep --executor dask --cluster slurm|pbs``.

The cluster is a ``dask_jobqueue.SLURMCluster`` / ``PBSCluster`` built from a TOML file::

    [cluster]                       # keywords of dask_jobqueue's cluster (checked, see KEYS)
    cores = 1                       # cores per job = worker threads per job
    processes = 1                   # worker processes per job
    memory = "2GB"                  # per job
    walltime = "04:00:00"
    queue = "normal"
    account = "myproj"
    job_extra_directives = ["--constraint=intel"]
    job_script_prologue = ["module load gcc"]
    log_directory = "dask-logs"

    [scale]
    jobs = 100                      # jobs submitted (default: --workers, else 1)

Added to every job: ``OMP_NUM_THREADS=1`` (and the OpenBLAS/MKL equivalents) and the current
``PYTHONPATH`` if set, exported before the worker starts; ``python`` defaults to this
interpreter (``sys.executable``, i.e. this environment's python: the workers must see the
same installation, and the results folder, on a shared file system). ``local`` builds
``dask_jobqueue``'s local job runner: the same job machinery, the jobs started as local
subprocesses (for testing a configuration on one machine; no prologue).

Building the cluster object starts its scheduler in this process but submits nothing;
:func:`job_script` returns the script a job would run, without submitting it.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path
from typing import Any

__all__ = ["KEYS", "ClusterConfigError", "load_cluster_config", "make_cluster"]

KINDS = ("slurm", "pbs", "local")

_COMMON = {
    "cores", "memory", "processes", "nanny", "interface", "death_timeout", "local_directory",
    "worker_extra_args", "job_extra_directives", "job_script_prologue", "job_directives_skip",
    "log_directory", "python", "job_name", "scheduler_options", "protocol",
}  # fmt: skip
#: the [cluster] keys each kind accepts (dask_jobqueue's keyword arguments)
KEYS: dict[str, set[str]] = {
    "slurm": _COMMON | {"queue", "account", "walltime", "job_cpu", "job_mem", "shebang"},
    "pbs": _COMMON | {"queue", "account", "walltime", "resource_spec", "shebang"},
    "local": _COMMON - {"job_script_prologue", "job_extra_directives", "job_directives_skip"},
}
_THREADS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


class ClusterConfigError(ValueError):
    """A cluster configuration file that cannot be used (one line naming the file and key)."""


def load_cluster_config(path: str | Path, kind: str) -> dict[str, Any]:
    """Read and check ``path``; returns ``{"cluster": {...}, "scale": {"jobs": n | None}}``."""
    from pbr_xval.tomlio import read_toml

    path = Path(path)
    if kind not in KINDS:
        raise ClusterConfigError(f"--cluster {kind!r}: expected one of {', '.join(KINDS)}")
    doc = read_toml(
        path, what="cluster configuration", expected="a [cluster] table", error=ClusterConfigError
    )
    extra = set(doc) - {"cluster", "scale"}
    if extra:
        raise ClusterConfigError(
            f"{path}: unknown table(s) {', '.join(sorted(extra))}; expected [cluster] and [scale]"
        )
    cl = dict(doc.get("cluster", {}))
    bad = sorted(set(cl) - KEYS[kind])
    if bad:
        raise ClusterConfigError(
            f"{path}: [cluster] key(s) {', '.join(bad)} not accepted for {kind}; expected some of {', '.join(sorted(KEYS[kind]))}"
        )
    for k in ("cores", "processes"):
        if k in cl and not (isinstance(cl[k], int) and cl[k] >= 1):
            raise ClusterConfigError(f"{path}: [cluster] {k} = {cl[k]!r}: expected an integer ≥ 1")
    for k in ("job_extra_directives", "job_script_prologue", "worker_extra_args", "job_directives_skip"):
        if k in cl and not (isinstance(cl[k], list) and all(isinstance(v, str) for v in cl[k])):
            raise ClusterConfigError(f"{path}: [cluster] {k}: expected a list of strings")
    sc = dict(doc.get("scale", {}))
    if set(sc) - {"jobs"}:
        raise ClusterConfigError(
            f"{path}: [scale] key(s) {', '.join(sorted(set(sc) - {'jobs'}))}; expected jobs"
        )
    jobs = sc.get("jobs")
    if jobs is not None and not (isinstance(jobs, int) and jobs >= 1):
        raise ClusterConfigError(f"{path}: [scale] jobs = {jobs!r}: expected an integer ≥ 1")
    return {"cluster": cl, "scale": {"jobs": jobs}}


def cluster_kwargs(kind: str, cfg: dict[str, Any]) -> dict[str, Any]:
    """The keyword arguments given to the dask_jobqueue cluster (the defaults filled in)."""
    kw: dict[str, Any] = {"cores": 1, "processes": 1, "memory": "2GB", **cfg["cluster"]}
    kw.setdefault("python", sys.executable)
    if kind != "local":
        kw.setdefault("walltime", "01:00:00")
    kw["scheduler_options"] = {"dashboard_address": ":0", **kw.get("scheduler_options", {})}
    if kind != "local":
        env = [f"export {k}=1" for k in _THREADS]
        if os.environ.get("PYTHONPATH"):
            env.append(f"export PYTHONPATH={os.environ['PYTHONPATH']}")
        kw["job_script_prologue"] = env + list(kw.get("job_script_prologue", []))
    return kw


def make_cluster(kind: str, cfg: dict[str, Any]) -> Any:
    """Build (never submit) the ``dask_jobqueue`` cluster of ``kind`` from a checked ``cfg``."""
    try:
        import dask_jobqueue
        from dask_jobqueue.local import LocalCluster
    except ImportError as exc:  # pragma: no cover
        raise RuntimeError(
            "the cluster executors need: pip install 'pbr-xval[dask]' (dask-jobqueue)"
        ) from exc
    cls = {"slurm": dask_jobqueue.SLURMCluster, "pbs": dask_jobqueue.PBSCluster, "local": LocalCluster}[kind]
    import dask

    kw = cluster_kwargs(kind, cfg)
    # as the sweep's own LocalCluster: a task whose worker dies is retried once, then failed
    conf = {"distributed.scheduler.allowed-failures": 1, "distributed.scheduler.worker-saturation": 1.0}
    try:
        with dask.config.set(conf):
            return cls(**kw)
    except (TypeError, ValueError) as exc:
        raise ClusterConfigError(f"{kind} cluster: {exc}") from None
