"""Chunks: one rock × a block of motions × one engine and settings, as a pure function.

A :class:`ChunkSpec` is JSON-serialisable and carries everything a worker needs (no catalog
file is read in the worker). :func:`execute_chunk` runs it in the current process — one
engine instance per process, cached — and writes one Parquet file through the store.

Random numbers (the friction coefficient drawn from [μ_min, μ_max] and the scenario seed) come
from ``numpy.random.SeedSequence(catalog_seed, spawn_key=...)`` with a spawn key derived from
the SHA-256 of (rock id, motion id): every engine sees the same μ for the same rock × motion,
and the numbers do not depend on chunking or sharding. The chunk's own seed (recorded in the
file metadata) derives the same way from its content hash.
"""

from __future__ import annotations

import dataclasses
import hashlib
import importlib
import json
import math
import os
import re
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, cast

from pbr_xval.atomic import write_bytes_atomic
from pbr_xval.jsonio import jsonable
from pbr_xval.status import RunStatus

__all__ = ["ROW_COLUMNS", "ChunkSpec", "build_chunks", "execute_chunk", "run_chunk", "shard_chunks"]

#: columns of one simulation row (the store's schema)
ROW_COLUMNS = [
    "rock_id", "motion_id", "motion_kind", "motion_params", "pga", "pgv", "pgv_pga", "mu", "engine",
    "profile", "settings", "toppled", "toppled_at", "peak_tilt", "peak_com_disp", "wall_s", "status",
    "message", "sim_seed", "chunk_hash",
]  # fmt: skip


def _canon(obj: Any) -> str:
    return json.dumps(obj, sort_keys=True, separators=(",", ":"), default=str)


def _strip_paths(obj: Any) -> Any:
    """Drop absolute file paths (kept as sha256 beside them) so hashes survive moving the catalog."""
    if isinstance(obj, dict):
        return {k: _strip_paths(v) for k, v in obj.items() if not (k == "path" and "sha256" in obj)}
    if isinstance(obj, list):
        return [_strip_paths(v) for v in obj]
    return obj


@dataclass(frozen=True)
class ChunkSpec:
    """One unit of work. ``engine`` is a registered name or an importable ``"module:Class"``."""

    catalog: str
    rock: dict[str, Any]
    motions: list[dict[str, Any]]
    engine: str
    profile: str | None
    settings: dict[str, Any]
    duration: float | str
    tail: float
    settle_time: float
    output_dt: float
    catalog_seed: int
    tag: str = field(default="sweep")

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> ChunkSpec:
        return cls(**d)

    def to_json(self) -> str:
        return _canon(self.to_dict())

    def content_hash(self) -> str:
        d = _strip_paths(self.to_dict())
        d.pop("catalog", None)  # the catalog's name is a label, not content
        d.pop("tag", None)
        return hashlib.sha256(_canon(d).encode()).hexdigest()

    @property
    def engine_label(self) -> str:
        """Directory-safe engine name (``module:Class`` → ``Class``)."""
        return re.sub(r"[^A-Za-z0-9_.\-]", "_", self.engine.rsplit(":", 1)[-1])

    def seed_sequence(self) -> Any:
        import numpy as np

        h = self.content_hash()
        return np.random.SeedSequence(
            self.catalog_seed, spawn_key=tuple(int(h[i : i + 8], 16) for i in range(0, 32, 8))
        )


def sim_seed_sequence(catalog_seed: int, rock_id: str, motion_id: str) -> Any:
    import numpy as np

    h = hashlib.sha256(f"{rock_id}\x00{motion_id}".encode()).hexdigest()
    return np.random.SeedSequence(
        catalog_seed, spawn_key=tuple(int(h[i : i + 8], 16) for i in range(0, 32, 8))
    )


def build_chunks(
    catalog: Any,
    engines: list[str] | None = None,
    profile: str | None = None,
    chunk_size: int | None = None,
    rocks: list[str] | None = None,
    motions: list[dict[str, Any]] | None = None,
    settings: dict[str, dict[str, Any]] | None = None,
    tag: str = "sweep",
) -> list[ChunkSpec]:
    """The deterministic chunk list: engines × rocks × motion blocks, in catalog order."""
    engines = list(engines or catalog.engines)
    size = int(chunk_size or catalog.chunk_size)
    mlist = list(motions if motions is not None else catalog.motions)
    rlist = [r for r in catalog.rocks if rocks is None or r["id"] in rocks]
    out = []
    for eng in engines:
        s = dict(catalog.settings.get(eng, {}))
        s.update((settings or {}).get(eng, {}))
        for r in rlist:
            for i in range(0, len(mlist), size):
                out.append(
                    ChunkSpec(
                        catalog=catalog.name,
                        rock=r,
                        motions=mlist[i : i + size],
                        engine=eng,
                        profile=profile if profile is not None else catalog.profile,
                        settings=s,
                        duration=catalog.duration,
                        tail=catalog.tail,
                        settle_time=catalog.settle_time,
                        output_dt=catalog.output_dt,
                        catalog_seed=catalog.seed,
                        tag=tag,
                    )
                )
    return out


def parse_shard(shard: str | None) -> tuple[int, int] | None:
    if shard is None:
        return None
    m = re.fullmatch(r"\s*(\d+)\s*/\s*(\d+)\s*", shard)
    if not m or not (1 <= int(m.group(1)) <= int(m.group(2))):
        raise ValueError(f"shard {shard!r}: expected 'i/N' with 1 <= i <= N (e.g. '3/10')")
    return int(m.group(1)), int(m.group(2))


def shard_chunks(chunks: list[ChunkSpec], shard: str | None) -> list[ChunkSpec]:
    """Shard ``i/N`` (1-based): chunks whose index in the deterministic list is ≡ i−1 mod N."""
    p = parse_shard(shard)
    if p is None:
        return list(chunks)
    i, n = p
    return [c for k, c in enumerate(chunks) if k % n == i - 1]


# ------------------------------------------------------------------ worker side
_ENGINES: dict[str, Any] = {}


def worker_engine(name: str) -> Any:
    """One engine instance per process (cached)."""
    eng = _ENGINES.get(name)
    if eng is None:
        if ":" in name:
            mod, _, attr = name.partition(":")
            eng = getattr(importlib.import_module(mod), attr)()
        else:
            from pbr_xval.engine import get_engine

            eng = get_engine(name)
        _ENGINES[name] = eng
    return eng


_MESH_CACHE: dict[str, str] = {}


def synthetic_mesh_file(rock: dict[str, Any]) -> str:
    """Write (once per process / machine) the synthetic rock's mesh; deterministic bytes."""
    from pbr_xval.geometry.synthetic import SYNTHETIC_ROCK_KEYS, synthetic_rock

    params = {k: rock[k] for k in SYNTHETIC_ROCK_KEYS}
    key = hashlib.sha256(_canon(params).encode()).hexdigest()[:24]
    if key in _MESH_CACHE and Path(_MESH_CACHE[key]).is_file():
        return _MESH_CACHE[key]
    d = Path(tempfile.gettempdir()) / "pbr_xval_synthetic"
    d.mkdir(parents=True, exist_ok=True)
    path = d / f"synthetic_{key}.ply"
    if not path.is_file():
        mesh, _ = synthetic_rock(
            seed=params["seed"],
            radii=tuple(params["radii"]),
            roughness=params["roughness"],
            base_fraction=params["base_fraction"],
            unevenness=params["unevenness"],
            subdivisions=params["subdivisions"],
            target_alpha_deg=params["target_alpha_deg"],
        )
        write_bytes_atomic(path, cast(bytes, mesh.export(file_type="ply")), hidden=True)  # binary PLY
    _MESH_CACHE[key] = str(path)
    return str(path)


def scenario_dict(spec: ChunkSpec, motion: dict[str, Any], mu: float, seed: int) -> dict[str, Any]:
    r = spec.rock
    shape = r["shape"]
    if shape == "scenario":  # a whole scenario (pbr-xval validate): only motion, name, duration, seed change
        d = json.loads(json.dumps(r["scenario"]))
        if "member" in motion:  # an ensemble member (pbr_xval.uncertainty): its values, its seed
            return _member_scenario_dict(spec, d, motion)
        exc = {**motion["excitation"], "path": motion["path"]}
        exc.setdefault("azimuth_deg", d.get("excitation", {}).get("azimuth_deg", 0.0))
        dur = (
            float(motion.get("duration", 0.0)) + spec.tail
            if spec.duration == "auto"
            else float(spec.duration)
        )
        name = re.sub(r"[^A-Za-z0-9_.\-]", "_", f"{r['id']}__{motion['id']}")
        d.update(name=name, duration=dur, seed=int(seed), excitation=exc)
        return d
    mass = {"density": r["density"]} if r.get("density") is not None else {"mass": r["mass"]}
    if shape == "synthetic":
        rock = {"shape": "mesh", "path": synthetic_mesh_file(r), **mass}
    else:
        keys = {"box": ["half_extents"], "notched_block": ["half_extents", "notch_width", "notch_height"],
                "curved_base": ["H", "r", "h", "depth", "arc_segments"], "mesh": ["path", "units", "pose", "orientation"]}[shape]  # fmt: skip
        rock = {"shape": shape, **{k: r[k] for k in keys if r.get(k) is not None}, **mass}
    if r.get("yaw_deg"):
        rock["yaw_deg"] = r["yaw_deg"]
    exc = dict(motion["excitation"])
    if motion["kind"] == "record":
        exc["path"] = motion["path"]
    exc["azimuth_deg"] = r.get("azimuth_deg", 0.0)
    ped = {k: v for k, v in r.get("pedestal", {"kind": "plane"}).items() if k != "sha256"}
    dur = float(motion.get("duration", 0.0)) + spec.tail if spec.duration == "auto" else float(spec.duration)
    name = re.sub(r"[^A-Za-z0-9_.\-]", "_", f"{r['id']}__{motion['id']}")
    return {
        "name": name,
        "duration": dur,
        "settle_time": spec.settle_time,
        "output_dt": spec.output_dt,
        "seed": int(seed),
        "rock": rock,
        "pedestal": ped,
        "contact": {"friction_static": float(mu), "restitution": r.get("restitution", 0.0)},
        "excitation": exc,
    }


def _member_scenario_dict(spec: ChunkSpec, d: dict[str, Any], motion: dict[str, Any]) -> dict[str, Any]:
    """An ensemble member's scenario: the rock's full scenario tables with the member's values.

    ``motion["kind"] == "scenario"`` (``pbr-xval predict``) keeps the scenario's own excitation,
    duration, name (``<name>__m<member>``) and seed, so the member's scenario is exactly
    :func:`pbr_xval.uncertainty.member_scenario`; a ``record`` motion (``validate --ensemble``)
    replaces the excitation (keeping its azimuth) and the duration as for a deterministic test.
    """
    from pbr_xval.uncertainty import apply_values, member_name

    apply_values(d, motion["values"], spec.engine)
    if motion["kind"] == "scenario":
        d["name"] = member_name(d["name"], int(motion["member"]))
        return d
    exc = {**motion["excitation"], "path": motion["path"]}
    exc.setdefault("azimuth_deg", d.get("excitation", {}).get("azimuth_deg", 0.0))
    dur = float(motion.get("duration", 0.0)) + spec.tail if spec.duration == "auto" else float(spec.duration)
    d.update(
        name=re.sub(r"[^A-Za-z0-9_.\-]", "_", f"{spec.rock['id']}__{motion['id']}"),
        duration=dur,
        excitation=exc,
    )
    return d


def _limit_threads() -> None:
    for k in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ[k] = "1"


def run_chunk(spec: ChunkSpec) -> tuple[list[dict[str, Any]], dict[str, Any]]:
    """Simulate every motion of the chunk; (rows, provenance). Never raises for one bad run."""
    import numpy as np

    from pbr_xval.diagnostics import ensure_standard_diagnostics
    from pbr_xval.engine import NotApplicable
    from pbr_xval.machine import machine_info
    from pbr_xval.motion import intensity_measures
    from pbr_xval.runner import effective_settings
    from pbr_xval.scenario import scenario_from_dict
    from pbr_xval.scene import compile_scene
    from pbr_xval.version import __version__

    _limit_threads()
    h = spec.content_hash()
    eng = worker_engine(spec.engine)
    overrides = dict(spec.settings)
    if spec.profile is not None:
        overrides["profile"] = spec.profile
    rows = []
    used_settings: dict[str, Any] | None = None
    lo, hi = spec.rock["friction_min"], spec.rock["friction_max"]
    for m in spec.motions:
        ss = sim_seed_sequence(spec.catalog_seed, spec.rock["id"], m["id"])
        rng = np.random.default_rng(ss)
        mu = float(lo if hi == lo else rng.uniform(lo, hi))
        seed = int(ss.generate_state(1, dtype=np.uint32)[0])
        row: dict[str, Any] = {
            "rock_id": spec.rock["id"], "motion_id": m["id"], "motion_kind": m["kind"],
            "motion_params": _canon(m["params"]), "pga": math.nan, "pgv": math.nan, "pgv_pga": math.nan,
            "mu": mu, "engine": spec.engine_label, "profile": spec.profile or "", "settings": _canon(spec.settings),
            "toppled": False, "toppled_at": math.nan, "peak_tilt": math.nan, "peak_com_disp": math.nan,
            "wall_s": 0.0, "status": RunStatus.OK, "message": "", "sim_seed": seed, "chunk_hash": h,
        }  # fmt: skip
        t0 = time.perf_counter()
        try:
            scn = scenario_from_dict(scenario_dict(spec, m, mu, seed))
            if "member" in m:  # an ensemble member's own friction
                row["mu"] = float(scn.contact.friction_static)
            scene = compile_scene(scn)
            im = intensity_measures(scene.excitation.horizontal, periods=())
            row["pga"], row["pgv"] = float(im["PGA"]), float(im["PGV"])
            row["pgv_pga"] = float(im["PGV/PGA"])
            full = effective_settings(eng, scene, overrides)
            used_settings = used_settings or full
            t1 = time.perf_counter()
            traj = eng.simulate(scene, full)
            row["wall_s"] = time.perf_counter() - t1
            row["status"] = traj.status
            row["message"] = traj.message
            row["toppled"] = bool(traj.toppled)
            if traj.ok:
                row["regime"] = ensure_standard_diagnostics(traj, scene).regime
            ta = traj.toppled_at
            row["toppled_at"] = math.nan if ta is None else float(ta)
            if traj.t.size:
                row["peak_tilt"] = float(np.max(traj.tilt()))
                d = traj.com[:, :2] - traj.com[0, :2]
                row["peak_com_disp"] = float(np.max(np.hypot(d[:, 0], d[:, 1])))
        except NotApplicable as exc:
            row.update(status=RunStatus.NOT_APPLICABLE, message=str(exc), wall_s=time.perf_counter() - t0)
        except Exception as exc:  # a run's error is a row, not a crash of the chunk
            row.update(
                status=RunStatus.ERROR,
                message=f"{type(exc).__name__}: {exc}",
                wall_s=time.perf_counter() - t0,
            )
        rows.append(row)
    versions = eng.versions() if hasattr(eng, "versions") else {}
    prov = {
        "engine": spec.engine,
        "engine_versions": versions,
        "settings": jsonable(used_settings or {}, default=str),
        "pbr_xval_version": __version__,
        "machine": machine_info(),
        "chunk_seed_entropy": str(spec.seed_sequence().entropy),
        "chunk_seed_spawn_key": list(spec.seed_sequence().spawn_key),
    }
    return rows, prov


def _peak_rss_mb() -> float:
    try:
        import resource

        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # Linux: kB
    except Exception:  # pragma: no cover
        return math.nan


def execute_chunk(spec_json: str, out: str, skip_existing: bool = True) -> dict[str, Any]:
    """Worker entry point: run the chunk and write its file; returns a small summary dict."""
    from pbr_xval.catalog import store

    spec = ChunkSpec.from_dict(json.loads(spec_json))
    h = spec.content_hash()
    if skip_existing and store.chunk_done(out, spec):
        return {
            "hash": h,
            "skipped": True,
            "n": 0,
            "compute_s": 0.0,
            "write_s": 0.0,
            "pid": os.getpid(),
            "rss_mb": _peak_rss_mb(),
        }
    t0 = time.perf_counter()
    rows, prov = run_chunk(spec)
    t1 = time.perf_counter()
    store.write_chunk(out, spec, rows, prov)
    t2 = time.perf_counter()
    return {
        "hash": h,
        "skipped": False,
        "n": len(rows),
        "compute_s": t1 - t0,
        "write_s": t2 - t1,
        "sim_s": float(sum(r["wall_s"] for r in rows)),
        "not_ok": sum(1 for r in rows if r["status"] != "ok"),
        "pid": os.getpid(),
        "rss_mb": _peak_rss_mb(),
    }
