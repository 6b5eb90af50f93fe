"""One local process pool across several ``run_chunks`` calls (the adaptive ensemble's batches)."""

from __future__ import annotations

from pathlib import Path

from pbr_xval.catalog import catalog_from_dict
from pbr_xval.catalog.sweep import LocalPool, run_chunks
from pbr_xval.catalog.tasks import build_chunks


def _chunks() -> list:
    cat = catalog_from_dict(
        {
            "name": "pool", "seed": 1, "duration": 1.0, "engines": ["housner"], "chunk_size": 1,
            "settings": {"housner": {"rtol": 1e-6, "atol": 1e-8}},
            "rock": [{"id": "box", "shape": "box", "half_extents": [0.2, 0.2, 0.6], "density": 2500.0, "friction": 2.0}],
            "motions": {"pulse": [{"type": "half_sine", "amplitude": [3.0, 4.0, 5.0, 6.0], "frequency": [1.0]}]},
        }
    )  # fmt: skip
    return build_chunks(cat)


def test_batches_share_the_workers_and_results_match(tmp_path: Path) -> None:
    chunks = _chunks()
    assert len(chunks) == 4
    with LocalPool(2) as pool:
        a = run_chunks(chunks[:2], tmp_path / "shared", progress=False, pool=pool)
        b = run_chunks(chunks[2:], tmp_path / "shared", progress=False, pool=pool)
    assert a.done == b.done == 2 and not a.failed and not b.failed
    assert set(a.peak_rss_mb) & set(b.peak_rss_mb)  # the second batch ran in the first batch's workers
    assert pool._pool is None  # shut down on exit
    fresh = run_chunks(chunks, tmp_path / "fresh", workers=2, progress=False)
    assert fresh.done == 4

    from pbr_xval.catalog.store import load_results

    cols = ["motion_id", "toppled", "peak_tilt"]
    shared = load_results(tmp_path / "shared").sort_values("motion_id")[cols].reset_index(drop=True)
    alone = load_results(tmp_path / "fresh").sort_values("motion_id")[cols].reset_index(drop=True)
    assert shared.equals(alone)  # bit-identical outcomes with or without the shared pool


def test_a_crash_renews_the_shared_pool_and_the_next_batch_runs(tmp_path: Path, monkeypatch) -> None:
    import os
    import sys

    here = Path(__file__).resolve().parent
    sys.path.insert(0, str(here))
    from conftest import write_catalog

    from pbr_xval.catalog import load_catalog

    crash_rock = (
        '\n[[rock]]\nid = "crash_me"\nshape = "box"\nhalf_extents = [0.2, 0.2, 0.6]\ndensity = 2400.0\n'
    )
    monkeypatch.setenv("PYTHONPATH", str(here) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    cat = load_catalog(write_catalog(tmp_path, extra_rocks=crash_rock))
    chunks = build_chunks(cat, engines=["crash_engine:CrashEngine"])
    bad = [c for c in chunks if c.rock["id"] == "crash_me"]
    good = [c for c in chunks if c.rock["id"] != "crash_me"]
    with LocalPool(2) as pool:
        first = run_chunks(bad + good[:1], tmp_path / "out", progress=False, pool=pool)
        second = run_chunks(good[1:], tmp_path / "out", progress=False, pool=pool)
    assert first.failed == len(bad) and first.done == 1
    assert second.failed == 0 and second.done == len(good) - 1
