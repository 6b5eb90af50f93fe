"""Atomic file writes: a temporary file in the target's folder, fsync, then ``os.replace``.

A reader (or a resumed run) sees either the old file or the complete new one, never a
partial write. Used by trajectories, reports, the catalog store and the geometry cache.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import IO, Any

__all__ = ["atomic_file", "write_bytes_atomic", "write_parquet_atomic", "write_text_atomic"]


@contextlib.contextmanager
def atomic_file(path: str | os.PathLike[str], mode: str = "wb", *, hidden: bool = False) -> Iterator[IO[Any]]:
    """Open a temporary file beside ``path``; on success it replaces ``path``, on error it is removed.

    ``hidden`` starts the temporary name with a dot (readers that skip dot files, like the
    catalog store's Parquet dataset, never see it).
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(
        prefix=("." if hidden else "") + path.name + ".", suffix=".tmp", dir=path.parent
    )
    try:
        with os.fdopen(fd, mode) as fh:
            yield fh
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def write_bytes_atomic(path: str | os.PathLike[str], data: bytes, *, hidden: bool = False) -> Path:
    with atomic_file(path, "wb", hidden=hidden) as fh:
        fh.write(data)
    return Path(path)


def write_text_atomic(path: str | os.PathLike[str], text: str, *, hidden: bool = False) -> Path:
    return write_bytes_atomic(path, text.encode("utf-8"), hidden=hidden)


def write_parquet_atomic(path: str | os.PathLike[str], table: Any, *, hidden: bool = False) -> Path:
    """Write a pyarrow Table as Parquet, atomically."""
    import pyarrow.parquet as pq

    with atomic_file(path, "wb", hidden=hidden) as fh:
        pq.write_table(table, fh)
    return Path(path)
