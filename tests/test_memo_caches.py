"""Per-process memos that ensemble members share (issue 23): same values, own copies, keyed on content."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from pbr_xval.geometry.stability import hull_vertices


def test_hull_vertices_memo_gives_fresh_equal_arrays() -> None:
    rng = np.random.default_rng(0)
    pts = rng.normal(size=(500, 3))
    a = hull_vertices(pts)
    a[:] = 0.0  # a caller's copy: mutating it does not touch the memo
    b = hull_vertices(pts)
    c = hull_vertices(pts.copy())
    assert np.array_equal(b, c) and not np.all(b == 0.0)
    moved = pts + 1.0  # other content: another hull
    assert np.array_equal(hull_vertices(moved), b + 1.0)


def test_record_read_memo_follows_the_file_content(tmp_path: Path) -> None:
    from pbr_xval.motion.processing import _read_cached
    from pbr_xval.motion.records import read_record

    f = tmp_path / "acc.txt"
    f.write_text("0.0\n1.0\n-1.0\n0.0\n")
    kw = {"dt": 0.01, "units": "m/s2", "column": None, "time_column": "auto"}
    r1 = _read_cached(f, "table", kw, read_record)
    r1.acc[:] = 9.0  # the caller's copy
    r2 = _read_cached(f, "table", kw, read_record)
    assert r2.acc.tolist() == [0.0, 1.0, -1.0, 0.0]
    f.write_text("0.0\n2.0\n-2.0\n0.0\n")
    assert _read_cached(f, "table", kw, read_record).acc.tolist() == [0.0, 2.0, -2.0, 0.0]
