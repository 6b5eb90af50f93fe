"""Convex decomposition of a rock mesh with CoACD, cached on disk.

The cache key is the SHA-256 of the mesh's vertex and face bytes, the parameters and the CoACD
version; parts are stored as one ``.npz`` per key in ``$PBR_XVAL_CACHE`` (default
``~/.cache/pbr_xval``), written atomically (temporary file, then ``os.replace``).
"""

from __future__ import annotations

import hashlib
import json
import os
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import Any

import numpy as np
import trimesh

from pbr_xval.atomic import atomic_file

__all__ = ["cache_dir_default", "convex_parts", "decomposition_report"]


def cache_dir_default() -> Path:
    """Cache folder of decompositions: ``$PBR_XVAL_CACHE``, else ``~/.cache/pbr_xval``."""
    env = os.environ.get("PBR_XVAL_CACHE")
    return Path(env) if env else Path.home() / ".cache" / "pbr_xval"


def _coacd_version() -> str:
    try:
        return version("coacd")
    except PackageNotFoundError:  # pragma: no cover
        return "unknown"


def _key(v: np.ndarray, f: np.ndarray, params: dict[str, Any]) -> str:
    h = hashlib.sha256()
    h.update(np.ascontiguousarray(v, dtype="<f8").tobytes())
    h.update(np.ascontiguousarray(f, dtype="<i8").tobytes())
    h.update(json.dumps({**params, "coacd": _coacd_version()}, sort_keys=True).encode())
    return h.hexdigest()


def convex_parts(
    mesh: trimesh.Trimesh,
    threshold: float = 0.05,
    max_convex_hull: int = -1,
    seed: int = 0,
    cache_dir: str | Path | None = None,
) -> list[trimesh.Trimesh]:
    """Approximate convex decomposition of ``mesh`` (CoACD), cached on disk.

    Parameters
    ----------
    threshold : CoACD concavity threshold (smaller → more, tighter parts).
    max_convex_hull : cap on the number of parts (-1: no cap).
    seed : CoACD's random seed (results are deterministic for a given seed).
    cache_dir : default :func:`cache_dir_default`.
    """
    v = np.asarray(mesh.vertices, dtype=np.float64)
    f = np.asarray(mesh.faces, dtype=np.int64)
    params = {"threshold": float(threshold), "max_convex_hull": int(max_convex_hull), "seed": int(seed)}
    key = _key(v, f, params)
    cdir = Path(cache_dir) if cache_dir is not None else cache_dir_default()
    path = cdir / f"coacd_{key}.npz"
    if path.is_file():
        try:
            with np.load(path) as z:
                n = int(z["n"])
                return [
                    trimesh.Trimesh(vertices=z[f"v{i}"], faces=z[f"f{i}"], process=False) for i in range(n)
                ]
        except Exception:  # corrupt cache entry: recompute
            pass
    try:
        import coacd
    except ImportError:  # pragma: no cover
        raise RuntimeError("convex decomposition needs coacd: pip install coacd") from None
    coacd.set_log_level("error")
    res = coacd.run_coacd(
        coacd.Mesh(v, f), threshold=float(threshold), max_convex_hull=int(max_convex_hull), seed=int(seed)
    )
    parts = []
    arrays: dict[str, np.ndarray] = {"n": np.array(len(res))}
    for i, (pv, pf) in enumerate(res):
        pv, pf = np.asarray(pv, np.float64), np.asarray(pf, np.int64)
        m = trimesh.Trimesh(vertices=pv, faces=pf, process=False)
        if m.volume < 0:
            m.invert()
        parts.append(m)
        arrays[f"v{i}"], arrays[f"f{i}"] = np.asarray(m.vertices), np.asarray(m.faces)
    try:
        with atomic_file(path, "wb", hidden=True) as fh:
            # numpy's stub lets **kwds fill the keyword allow_pickle: bool (a stub gap; keys are part names)
            np.savez(fh, **arrays)  # type: ignore[arg-type]
    except OSError:  # a read-only cache is not an error
        pass
    return parts


def decomposition_report(mesh: trimesh.Trimesh, parts: list[trimesh.Trimesh]) -> dict[str, Any]:
    """Number of parts and relative volume error (sum of part volumes vs the mesh)."""
    vol = float(mesh.volume)
    total = float(sum(p.volume for p in parts))
    return {
        "n_parts": len(parts),
        "volume_m3": vol,
        "parts_volume_m3": total,
        "rel_volume_error": (total - vol) / vol,
    }
