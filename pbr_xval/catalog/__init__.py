"""Rock-catalog sweeps: catalogs × motion sets, chunked over processes, Dask or job arrays,
stored as a partitioned Parquet dataset, with fragility fits and solver choice."""

from __future__ import annotations

from pbr_xval.catalog.spec import Catalog, CatalogError, catalog_from_dict, load_catalog
from pbr_xval.catalog.store import load_results
from pbr_xval.catalog.sweep import SweepSummary, format_summary, run_chunks, run_sweep
from pbr_xval.catalog.tasks import ChunkSpec, build_chunks, shard_chunks

__all__ = [
    "Catalog",
    "CatalogError",
    "ChunkSpec",
    "SweepSummary",
    "build_chunks",
    "catalog_from_dict",
    "format_summary",
    "load_catalog",
    "load_results",
    "run_chunks",
    "run_sweep",
    "shard_chunks",
]
