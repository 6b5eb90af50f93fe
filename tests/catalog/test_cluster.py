"""dask-jobqueue clusters for ``pbr-xval sweep --executor dask --cluster``: SLURM / PBS job
scripts checked without submitting anything; a real sweep through a jobqueue cluster whose jobs
are separate worker processes on this machine (dask_jobqueue's local job runner)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

pytest.importorskip("dask_jobqueue")

from pbr_xval.catalog import load_catalog, load_results, run_sweep
from pbr_xval.catalog.cluster import ClusterConfigError, load_cluster_config, make_cluster

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from conftest import write_catalog  # noqa: E402

CONFIG = """
[cluster]
cores = 2
processes = 2
memory = "4GB"
walltime = "04:00:00"
queue = "normal"
account = "myproj"
job_extra_directives = ["--constraint=intel"]
job_script_prologue = ["module load gcc"]

[scale]
jobs = 50
"""


def _cfg(tmp_path: Path, text: str = CONFIG) -> Path:
    p = tmp_path / "cluster.toml"
    p.write_text(text)
    return p


def test_slurm_job_script(tmp_path):
    cfg = load_cluster_config(_cfg(tmp_path), "slurm")
    assert cfg["scale"]["jobs"] == 50
    cluster = make_cluster("slurm", cfg)
    try:
        script = cluster.job_script()
        assert not cluster.workers and not cluster.worker_spec  # nothing submitted
    finally:
        cluster.close()
    lines = script.splitlines()
    assert lines[0].startswith("#!")
    for want in (
        "#SBATCH -p normal", "#SBATCH -A myproj", "#SBATCH -n 1", "#SBATCH --cpus-per-task=2",
        "#SBATCH --mem=4G", "#SBATCH -t 04:00:00", "#SBATCH --constraint=intel",
        "export OMP_NUM_THREADS=1", "export OPENBLAS_NUM_THREADS=1", "module load gcc",
    ):  # fmt: skip
        assert want in lines, (want, script)
    worker = next(ln for ln in lines if "distributed.cli.dask_worker" in ln)
    # this environment's python; 2 processes × 1 thread, memory split between them
    assert worker.startswith(f"{sys.executable} -m distributed.cli.dask_worker tcp://")
    assert (
        "--nworkers 2" in worker and "--nthreads 1" in worker and "--memory-limit 1.86GiB" in worker
    )  # 4 GB / 2 processes
    # the prologue runs before the worker
    assert lines.index("export OMP_NUM_THREADS=1") < lines.index(worker)


def test_pbs_job_script(tmp_path):
    cfg = load_cluster_config(
        _cfg(tmp_path, CONFIG.replace('job_extra_directives = ["--constraint=intel"]\n', "")), "pbs"
    )
    cluster = make_cluster("pbs", cfg)
    try:
        script = cluster.job_script()
    finally:
        cluster.close()
    lines = script.splitlines()
    for want in (
        "#PBS -q normal",
        "#PBS -A myproj",
        "#PBS -l select=1:ncpus=2:mem=3815MB",
        "#PBS -l walltime=04:00:00",
    ):
        assert want in lines, (want, script)
    assert any(ln.startswith(f"{sys.executable} -m distributed.cli.dask_worker") for ln in lines)


def test_sweep_cli_prints_the_job_script_without_submitting(tiny_catalog, tmp_path, capsys):
    from pbr_xval.cli.catalog_cluster_impl import cluster_sweep_command

    code = cluster_sweep_command(
        tiny_catalog, tmp_path / "out", executor="dask", cluster="slurm", cluster_config=_cfg(tmp_path),
        job_script=True,
    )  # fmt: skip
    assert code == 0
    out = capsys.readouterr().out
    assert "#SBATCH -t 04:00:00" in out and "distributed.cli.dask_worker" in out
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").rglob("*.parquet"))


@pytest.mark.parametrize(
    ("text", "kind", "fragment"),
    [
        ("[cluster]\ncpus = 4\n", "slurm", "cpus not accepted for slurm"),
        ("[cluster]\nresource_spec = 'x'\n", "slurm", "resource_spec not accepted"),
        ("[cluster]\ncores = 0\n", "pbs", "cores = 0: expected an integer"),
        ("[cluster]\n[scale]\njobs = -1\n", "slurm", "jobs = -1"),
        ("[clutser]\n", "slurm", "unknown table(s) clutser"),
        ("[cluster]\ncores = 1\n", "sge", "--cluster 'sge'"),
        ("cores = [", "slurm", "not valid TOML"),
    ],
)
def test_bad_cluster_config(tmp_path, text, kind, fragment):
    with pytest.raises(ClusterConfigError, match=None) as ei:
        load_cluster_config(_cfg(tmp_path, text), kind)
    assert fragment in str(ei.value) and "\n" not in str(ei.value)


def test_sweep_cli_cluster_needs_dask_and_a_config(tiny_catalog, tmp_path):
    from pbr_xval.cli.catalog_cluster_impl import cluster_sweep_command

    cfg = _cfg(tmp_path)
    assert (
        cluster_sweep_command(
            tiny_catalog, tmp_path / "o", executor="local", cluster="slurm", cluster_config=cfg
        )
        == 2
    )
    assert cluster_sweep_command(tiny_catalog, tmp_path / "o", cluster="slurm", cluster_config=None) == 2
    assert (
        cluster_sweep_command(
            tiny_catalog, tmp_path / "o", cluster="slurm", cluster_config=cfg, scheduler="tcp://x:1"
        )
        == 2
    )
    assert not (tmp_path / "o").exists()


def test_real_sweep_through_a_jobqueue_cluster(tmp_path):
    """``pbr-xval sweep --executor dask --cluster local``: the jobqueue machinery (job script,
    scale, scheduler) with each job a separate ``dask_worker`` process on this machine; the
    results equal an inline run's."""
    p = write_catalog(tmp_path)
    cfg = _cfg(tmp_path, '[cluster]\ncores = 1\nprocesses = 1\nmemory = "1GB"\n\n[scale]\njobs = 2\n')
    cmd = [
        sys.executable, "-c", "from pbr_xval.cli import app; app()", "sweep", str(p), str(tmp_path / "jq"), "--executor", "dask",
        "--cluster", "local", "--cluster-config", str(cfg),
    ]  # fmt: skip
    proc = subprocess.Popen(
        cmd, start_new_session=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    try:
        stdout, stderr = proc.communicate(timeout=240)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.communicate()
        pytest.fail("the sweep through a jobqueue cluster did not finish within 240 s")
    assert proc.returncode == 0, stdout[-2000:] + stderr[-3000:]
    assert "local cluster: 2 job(s) submitted" in stdout and "4 done" in stdout
    key = ["engine", "rock_id", "motion_id"]
    jq = load_results(tmp_path / "jq").drop(columns=["wall_s"]).sort_values(key).reset_index(drop=True)
    run_sweep(load_catalog(p), tmp_path / "inline", executor="inline", progress=False)
    ref = load_results(tmp_path / "inline").drop(columns=["wall_s"]).sort_values(key).reset_index(drop=True)
    pd.testing.assert_frame_equal(ref, jq)
