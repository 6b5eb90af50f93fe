"""Run a campaign's tests through the catalog machinery (chunks, local executor, Parquet store).

Every test becomes one catalog motion (its baseline-corrected table record, written once as a
one-column text table in m/s² under ``<out>/motions/``) and the specimen's scenario becomes a
``shape = "scenario"`` catalog rock: the chunk worker replaces only the scenario's excitation
(keeping its azimuth), name, duration (motion + tail) and seed. Chunks are written atomically
to ``<out>/store/`` and a rerun skips every chunk already there (resumable).
"""

from __future__ import annotations

import hashlib
import json
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pbr_xval.atomic import write_text_atomic
from pbr_xval.validation.campaign import Baseline, Campaign, baseline_correct, record_pgv

__all__ = ["MotionFile", "prepare_motions", "run_campaign", "scenario_rock"]


@dataclass(frozen=True)
class MotionFile:
    """One test's corrected record on disk. ``path``: text table (m/s²); ``dt`` s; PGA m/s²; PGV m/s."""

    test: str
    path: Path
    sha256: str
    dt: float
    duration: float
    pga: float
    pgv: float


def _safe(s: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.\-]", "_", s)


def prepare_motions(campaign: Campaign, baseline: Baseline, folder: Path) -> dict[str, MotionFile]:
    """Correct every test's record and write it (atomically, once: an identical file is kept).

    The file's header comments record the source and the correction.
    """
    folder.mkdir(parents=True, exist_ok=True)
    out: dict[str, MotionFile] = {}
    for t in campaign.tests:
        raw, dt = t.raw_acceleration()
        acc, dt = baseline_correct(raw, dt, baseline)
        header = (
            f"# pbr-xval validate: table acceleration of test {t.test} ({t.motion}), m/s², dt = {dt!r} s\n"
            f"# source: {t.source} (units {t.units}); correction: {baseline.describe()}\n"
        )
        body = "\n".join(f"{x:.8e}" for x in acc)
        text = header + body + "\n"
        data = text.encode()
        sha = hashlib.sha256(data).hexdigest()
        path = folder / f"test{_safe(t.test)}.txt"
        if not (path.is_file() and hashlib.sha256(path.read_bytes()).hexdigest() == sha):
            write_text_atomic(path, text, hidden=True)
        out[t.test] = MotionFile(
            test=t.test, path=path.resolve(), sha256=sha, dt=float(dt), duration=(acc.size - 1) * dt,
            pga=float(np.max(np.abs(acc))), pgv=record_pgv(acc, dt),
        )  # fmt: skip
    return out


def scenario_rock(scn: Any, rock_id: str | None = None) -> dict[str, Any]:
    """The catalog rock entry that carries a whole scenario (file paths made absolute)."""
    d = scn.model_dump(mode="json", exclude_unset=True)
    d.pop("uncertainty", None)  # the deterministic runs use the written values (chunk hashes unchanged)
    rock = d.get("rock", {})
    if "path" in rock:
        rock["path"] = str(scn.resolve_path(rock["path"]).resolve())
    ped = d.get("pedestal", {})
    if isinstance(ped, dict) and "path" in ped:
        ped["path"] = str(scn.resolve_path(ped["path"]).resolve())
    d.get("excitation", {}).pop("vertical", None)
    # a run stops once the rock is at rest after the table motion (its outcome is decided; the
    # rest of the 3 s tail cannot change it): docs/toppling.md, ``stop_at_rest``
    d.setdefault("toppling", {}).setdefault("stop_at_rest", True)
    mu = float(scn.contact.friction_static)
    return {
        "id": _safe(rock_id or scn.name),
        "shape": "scenario",
        "scenario": d,
        "friction_min": mu,
        "friction_max": mu,
    }


def build_validation_chunks(
    campaign: Campaign,
    motions: dict[str, MotionFile],
    scn: Any,
    engines: list[str],
    *,
    settings: dict[str, dict[str, Any]] | None = None,
    tail: float = 3.0,
    output_dt: float = 0.01,
    chunk_size: int = 1,
    profile: str | None = None,
) -> list[Any]:
    """One chunk per engine × block of ``chunk_size`` tests."""
    from pbr_xval.catalog.tasks import ChunkSpec

    rock = scenario_rock(scn)
    mlist = []
    for t in campaign.tests:
        m = motions[t.test]
        mlist.append(
            {
                "id": f"test{_safe(t.test)}",
                "kind": "record",
                "excitation": {"type": "record", "format": "table", "units": "m/s2", "dt": m.dt},
                "params": {"test": t.test, "motion": t.motion},
                "path": str(m.path),
                "sha256": m.sha256,
                "duration": m.duration,
            }
        )
    chunks = []
    for eng in engines:
        for i in range(0, len(mlist), chunk_size):
            chunks.append(
                ChunkSpec(
                    catalog=f"validate_{rock['id']}", rock=rock, motions=mlist[i : i + chunk_size],
                    engine=eng, profile=profile, settings=dict((settings or {}).get(eng, {})),
                    duration="auto", tail=float(tail), settle_time=float(scn.settle_time),
                    output_dt=float(output_dt), catalog_seed=int(scn.seed), tag="validate",
                )
            )  # fmt: skip
    return chunks


def run_campaign(
    campaign: Campaign,
    scn: Any,
    engines: list[str],
    out: Path,
    *,
    baseline: Baseline,
    settings: dict[str, dict[str, Any]] | None = None,
    tail: float = 3.0,
    output_dt: float = 0.01,
    chunk_size: int = 1,
    workers: int | None = None,
    executor: str = "local",
    progress: bool = True,
    console: Any = None,
) -> tuple[pd.DataFrame, dict[str, MotionFile], Any]:
    """Run every test on every engine (resuming); (rows of these chunks, motions, sweep summary)."""
    from pbr_xval.catalog.store import load_results
    from pbr_xval.catalog.sweep import run_chunks

    motions = prepare_motions(campaign, baseline, out / "motions")
    chunks = build_validation_chunks(
        campaign, motions, scn, engines, settings=settings, tail=tail, output_dt=output_dt,
        chunk_size=chunk_size,
    )  # fmt: skip
    store = out / "store"
    summary = run_chunks(
        chunks, store, executor=executor, workers=workers, progress=progress, console=console,
        description="validate",
    )  # fmt: skip
    hashes = {c.content_hash() for c in chunks}
    rows = load_results(store)
    rows = rows[rows["chunk_hash"].isin(hashes)].copy()
    rows["test"] = rows["motion_params"].map(lambda s: str(json.loads(s)["test"]))
    return rows.reset_index(drop=True), motions, summary
