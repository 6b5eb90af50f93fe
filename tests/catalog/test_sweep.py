"""Executors, shards, resume after SIGKILL and crash containment — all with real processes."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest

from pbr_xval.catalog import build_chunks, load_catalog, load_results, run_sweep
from pbr_xval.catalog.store import chunk_files, read_chunk_meta

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from conftest import write_catalog  # noqa: E402

KEY = ["engine", "rock_id", "motion_id"]


def _table(out: Path) -> pd.DataFrame:
    df = load_results(out)
    return df.drop(columns=["wall_s"]).sort_values(KEY).reset_index(drop=True)


def test_local_dask_and_shards_identical(tiny_catalog, tmp_path):
    pytest.importorskip("distributed")
    cat = load_catalog(tiny_catalog)
    s_local = run_sweep(cat, tmp_path / "local", workers=2, progress=False)
    assert s_local.done == 4 and s_local.failed == 0 and s_local.simulations == 8
    local = _table(tmp_path / "local")
    assert len(local) == 8 and not local.duplicated(KEY).any()
    assert (local["status"] == "ok").all() and local["toppled"].any() and (~local["toppled"]).any()
    # file metadata: spec, hash, provenance
    f = chunk_files(tmp_path / "local")[0]
    meta = read_chunk_meta(f)
    assert meta["content_hash"] == f.stem and meta["spec"]["engine"] == "housner"
    assert {"engine_versions", "settings", "pbr_xval_version", "machine"} <= set(meta["provenance"])
    assert f.parent.name.startswith("rock=") and f.parent.parent.name == "engine=housner"

    s_dask = run_sweep(cat, tmp_path / "dask", executor="dask", workers=2, progress=False)
    assert s_dask.done == 4 and s_dask.dashboard
    pd.testing.assert_frame_equal(local, _table(tmp_path / "dask"))

    for i in (1, 2, 3):  # shards of a job array, into one folder
        run_sweep(cat, tmp_path / "shards", shard=f"{i}/3", workers=1, progress=False, executor="inline")
    pd.testing.assert_frame_equal(local, _table(tmp_path / "shards"))

    again = run_sweep(cat, tmp_path / "local", workers=2, progress=False)  # resume: nothing to do
    assert again.skipped == 4 and again.done == 0


def test_crash_contained_local(tmp_path, monkeypatch):
    crash_rock = (
        '\n[[rock]]\nid = "crash_me"\nshape = "box"\nhalf_extents = [0.2, 0.2, 0.6]\ndensity = 2400.0\n'
    )
    p = write_catalog(tmp_path, extra_rocks=crash_rock)
    monkeypatch.setenv("PYTHONPATH", str(HERE) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    cat = load_catalog(p)
    s = run_sweep(cat, tmp_path / "out", engines=["crash_engine:CrashEngine"], workers=2, progress=False)
    assert s.failed == 2  # both chunks of the crashing rock, after one retry each
    assert s.done == 4
    assert all(f["rock"] == "crash_me" and "died" in f["reason"] for f in s.failures)
    df = load_results(tmp_path / "out")
    assert sorted(df["rock_id"].unique()) == ["blk", "squat"] and len(df) == 8
    assert list((tmp_path / "out" / "_failed").glob("*.json"))


_DASK_CRASH_SWEEP = """
import dataclasses, json, sys
from pbr_xval.catalog import load_catalog, run_sweep
s = run_sweep(load_catalog(sys.argv[1]), sys.argv[2], engines=["crash_engine:CrashEngine"],
              executor="dask", workers=2, progress=False)
print("SUMMARY " + json.dumps(dataclasses.asdict(s), default=str))
"""


def test_crash_contained_dask(tmp_path):
    pytest.importorskip("distributed")
    crash_rock = (
        '\n[[rock]]\nid = "crash_me"\nshape = "box"\nhalf_extents = [0.2, 0.2, 0.6]\ndensity = 2400.0\n'
    )
    p = write_catalog(tmp_path, extra_rocks=crash_rock)
    env = dict(os.environ, PYTHONPATH=str(HERE) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    # in a process of its own with a time limit: a sweep that hangs (all workers dead and none
    # restarted) is a failure to report, not a CI job that never ends (measured: 6-50 s)
    proc = subprocess.Popen(
        [sys.executable, "-c", _DASK_CRASH_SWEEP, str(p), str(tmp_path / "out")],
        env=env,
        start_new_session=True,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        stdout, stderr = proc.communicate(timeout=240)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.communicate()
        pytest.fail("the dask sweep with a crashing engine did not finish within 240 s")
    assert proc.returncode == 0, stderr[-3000:]
    s = json.loads(next(ln for ln in stdout.splitlines() if ln.startswith("SUMMARY "))[len("SUMMARY ") :])
    # only the crashing rock's 2 chunks fail; a healthy chunk whose worker died after writing
    # its file is found on the retry and counted as skipped, so done + skipped = 4
    assert s["failed"] == 2, s["failures"]
    assert s["done"] + s["skipped"] == 4
    assert all(f["rock"] == "crash_me" and "KilledWorker" in f["reason"] for f in s["failures"])
    df = load_results(tmp_path / "out")
    assert sorted(df["rock_id"].unique()) == ["blk", "squat"] and len(df) == 8


def test_sigkill_and_resume(tmp_path):
    # more chunks (chunk_size 1) so the kill lands mid-sweep
    p = write_catalog(
        tmp_path,
        **{"chunk_size = 2": "chunk_size = 1", "amplitude = [3.0, 9.0]": "amplitude = [3.0, 5.0, 9.0]"},
    )
    out = tmp_path / "out"
    cat = load_catalog(p)
    n_chunks = len(build_chunks(cat))
    cmd = [sys.executable, "-m", "pbr_xval.catalog", "sweep", str(p), str(out), "--workers", "2"]
    proc = subprocess.Popen(cmd, start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 120
        while len(chunk_files(out)) < 2 and time.monotonic() < deadline and proc.poll() is None:
            time.sleep(0.05)
        os.killpg(proc.pid, signal.SIGKILL)  # the whole process group: driver and workers
    finally:
        proc.wait(timeout=30)
    written = len(chunk_files(out))
    assert 2 <= written < n_chunks, f"kill landed outside the sweep ({written}/{n_chunks} written)"
    s = run_sweep(cat, out, workers=2, progress=False)
    assert s.skipped == written and s.done == n_chunks - written
    df = load_results(out)
    assert len(df) == len(cat.rocks) * len(cat.motions)
    assert not df.duplicated(KEY).any()
    # leftover temp files (if the kill hit a write) are never read
    assert all(not f.name.startswith(".") for f in chunk_files(out))
