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
