"""Results store: a partitioned Parquet dataset, one file per chunk, written atomically.

Layout::

    <out>/engine=<engine>/rock=<rock id>/<chunk content hash>.parquet

Each file's key-value metadata (key ``pbr_xval_chunk``) holds the chunk spec, its content
hash and provenance (engine versions and settings, pbr-xval version, machine). A file is
written to a hidden temporary file in the same directory, fsynced, then ``os.replace``d into
place (and the directory fsynced), so a reader — or a resumed sweep — sees a chunk either
complete or not at all. Resume skips every chunk whose file exists with a matching hash.
Temporary files start with ``.`` and are never read.
"""

from __future__ import annotations

import json
import os
import re
from pathlib import Path
from typing import TYPE_CHECKING, Any

from pbr_xval.atomic import write_parquet_atomic
from pbr_xval.atomic import write_text_atomic as _write_text_atomic

if TYPE_CHECKING:
    import pandas as pd

    from pbr_xval.catalog.tasks import ChunkSpec

__all__ = [
    "chunk_done",
    "chunk_files",
    "chunk_path",
    "load_results",
    "read_chunk_meta",
    "write_chunk",
    "write_text_atomic",
]

META_KEY = b"pbr_xval_chunk"


def _safe(s: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.\-]", "_", s)


def chunk_path(out: str | os.PathLike[str], spec: ChunkSpec) -> Path:
    return (
        Path(out)
        / f"engine={spec.engine_label}"
        / f"rock={_safe(spec.rock['id'])}"
        / f"{spec.content_hash()}.parquet"
    )


def _schema() -> Any:
    import pyarrow as pa

    return pa.schema([
        ("rock_id", pa.string()), ("motion_id", pa.string()), ("motion_kind", pa.string()),
        ("motion_params", pa.string()), ("pga", pa.float64()), ("pgv", pa.float64()), ("pgv_pga", pa.float64()),
        ("mu", pa.float64()), ("engine", pa.string()), ("profile", pa.string()), ("settings", pa.string()),
        ("toppled", pa.bool_()), ("toppled_at", pa.float64()), ("peak_tilt", pa.float64()),
        ("peak_com_disp", pa.float64()), ("wall_s", pa.float64()), ("status", pa.string()),
        ("message", pa.string()), ("sim_seed", pa.int64()), ("chunk_hash", pa.string()),
    ])  # fmt: skip


def _fsync_dir(d: Path) -> None:
    try:
        fd = os.open(d, os.O_RDONLY)
    except OSError:  # pragma: no cover - platforms without directory fds
        return
    try:
        os.fsync(fd)
    except OSError:  # pragma: no cover
        pass
    finally:
        os.close(fd)


def write_chunk(
    out: str | os.PathLike[str], spec: ChunkSpec, rows: list[dict[str, Any]], provenance: dict[str, Any]
) -> Path:
    """Write one chunk's rows atomically (temp file in the same dir, fsync, os.replace)."""
    import pyarrow as pa

    path = chunk_path(out, spec)
    path.parent.mkdir(parents=True, exist_ok=True)
    schema = _schema()
    table = pa.Table.from_pylist(rows, schema=schema)
    meta = {"content_hash": spec.content_hash(), "spec": spec.to_dict(), "provenance": provenance}
    table = table.replace_schema_metadata({META_KEY: json.dumps(meta, sort_keys=True, default=str).encode()})
    write_parquet_atomic(path, table, hidden=True)
    _fsync_dir(path.parent)
    return path


def read_chunk_meta(path: str | os.PathLike[str]) -> dict[str, Any] | None:
    """The chunk metadata of a file, or None if it is not a readable chunk file."""
    import pyarrow.parquet as pq

    try:
        md = pq.read_schema(path).metadata or {}
        return json.loads(md[META_KEY])
    except Exception:
        return None


def chunk_done(out: str | os.PathLike[str], spec: ChunkSpec) -> bool:
    """True if the chunk's file exists and its metadata hash matches."""
    p = chunk_path(out, spec)
    if not p.is_file():
        return False
    meta = read_chunk_meta(p)
    return meta is not None and meta.get("content_hash") == spec.content_hash()


def chunk_files(out: str | os.PathLike[str]) -> list[Path]:
    """Every complete chunk file (temporary files, hidden or ``_``-prefixed entries excluded)."""
    root = Path(out)
    return sorted(
        p for p in root.glob("engine=*/rock=*/*.parquet") if not p.name.startswith((".", "_")) and p.is_file()
    )


def load_results(out: str | os.PathLike[str], *, tag: str | None = None) -> pd.DataFrame:
    """All simulation rows of a results folder as one DataFrame (pyarrow.dataset underneath).

    ``tag`` restricts to chunks written by a given kind of run (``"sweep"`` or ``"choose"``).
    """
    import pandas as pd
    import pyarrow.dataset as ds

    files = chunk_files(out)
    if tag is not None:
        keep = []
        for f in files:
            meta = read_chunk_meta(f) or {}
            if meta.get("spec", {}).get("tag", "sweep") == tag:
                keep.append(f)
        files = keep
    if not files:
        return pd.DataFrame(
            {
                c: pd.Series(dtype=t.to_pandas_dtype())
                for c, t in zip(_schema().names, _schema().types, strict=True)
            }
        )
    dataset = ds.dataset([str(f) for f in files], format="parquet", schema=_schema())
    return dataset.to_table().to_pandas()


def write_text_atomic(path: str | os.PathLike[str], text: str) -> Path:
    """Atomic text write with a hidden temporary name (see :mod:`pbr_xval.atomic`)."""
    return _write_text_atomic(path, text, hidden=True)
