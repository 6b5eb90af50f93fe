"""Stability at the extremes: a matrix of extreme scenarios × engines, each cell classified.

Every cell runs in a worker process (:mod:`pbr_xval.study.workers`), so a segfault or a hang
of an engine is a classified cell, and the study always completes. Classes, in order of
precedence:

* ``crash`` — the worker died; ``timeout`` — no answer within the time limit;
* ``not_applicable`` — the engine cannot represent the case (2-D engine, no sliding, no
  time step, shape unsupported, not installed);
* ``nan`` — a failed trajectory mentioning NaN/inf/explosion, or non-finite samples;
  ``failed`` — any other failed trajectory or exception;
* ``penetration`` — maximum penetration beyond 1 % of the rock's smallest dimension;
* ``drift`` — at-rest cases: the rock tilts (> 1e-3 rad) or its COM moves (> 1 mm);
* ``biased`` — the outcome differs from the reference (see below);
* ``ok``.

How each case is judged (chosen for cost: two simulations per cell, not a threshold search):

* *bracket* cases (slenderness, size, mass, dt = 1e-2, friction 10, 50 Hz, 1,000+ basal
  nodes, 10 km offset, ±0.01 % amplitude): the rock must stand at (1 − band)·a_ref and topple
  at (1 + band)·a_ref (band = 1 %, or 0.01 % for the amplitude case), i.e. the engine's
  threshold is within the band of the reference; otherwise ``biased``, and (``measure_biased``)
  the cell's threshold is searched to say how far off it is. a_ref is the housner
  engine's threshold (a search, once per case) or — where similarity fixes it — the
  analytical 5.638 m/s²: a block scaled by k with the pulse frequency scaled by k^-1/2 (ω/p
  fixed) has the same threshold in m/s². The mass cases are such scaled blocks of granite
  density (2400 kg/m³): 1 kg is a 5.2 × 5.2 × 15.5 cm block, 1e6 kg a 5.2 × 5.2 × 15.5 m one — a real rock,
  not an impossible density, so the engines are tested and not the input check.
* *slide* (μ = 0.05 < tan α): physics says the block slides and cannot rock: ``biased`` if it
  tilts by more than 0.1 α or topples, or if its COM does not move by at least 1 mm.
* *rest* (600 s of noise below the uplift acceleration): nothing topples (``biased``) and
  nothing drifts (``drift``).
* *peak* (dt = 1e-5, short run of 1.5 s at 0.9·5.638 m/s²): peak |θ| within 1 % of the
  housner engine's.
"""

from __future__ import annotations

import math
import shutil
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from pbr_xval.scenario import Scenario
from pbr_xval.study.base import Figure, StudyResult, clamped_progress

__all__ = ["ALL_CASES", "CLASSES", "ExtremesConfig", "build_cases", "run"]

CLASSES = ("ok", "biased", "drift", "penetration", "nan", "failed", "crash", "timeout", "not_applicable")
CLASS_COLOURS = {
    "ok": "#4caf50",
    "biased": "#ffb300",
    "drift": "#ff7043",
    "penetration": "#ab47bc",
    "nan": "#e53935",
    "failed": "#8d6e63",
    "crash": "#212121",
    "timeout": "#546e7a",
    "not_applicable": "#e0e0e0",
}
ALL_CASES = (
    "slender_2deg",
    "slender_10deg",
    "slender_45deg",
    "size_5cm",
    "size_50m",
    "mass_1kg",
    "mass_1e6kg",
    "dt_1e-2",
    "dt_1e-5",
    "friction_0.05",
    "friction_10",
    "freq_50Hz",
    "amplitude_0.01pct",
    "basal_1000_nodes",
    "offset_10km",
    "record_600s",
)
HOUSNER = 5.638  # m/s², conformance.HOUSNER_THRESHOLD
GRANITE = 2400.0  # kg/m³, the Housner block's density: the mass cases keep it


class ExtremesConfig(BaseModel):
    """Stability at the extremes."""

    model_config = ConfigDict(extra="forbid")

    type: Literal["extremes"] = "extremes"
    cases: list[str] | Literal["all"] = "all"
    timeout: float = Field(120.0, description="per cell (s); the 600 s record gets 5×")
    band: float = Field(0.01, description="relative bracket around the reference threshold")
    penetration_fraction: float = Field(0.01, description="of the rock's smallest dimension")
    reference_engine: str = "housner"
    settings: dict[str, dict[str, Any]] = Field(default_factory=dict, description="per-engine overrides")
    max_workers: int = Field(1, ge=1)
    measure_biased: bool = Field(
        True, description="search the threshold of every cell outside the band: how far it is"
    )


@dataclass
class Case:
    name: str
    group: str
    kind: Literal["bracket", "slide", "rest", "peak"]
    scenario: Scenario
    description: str
    a_ref: float | None = None
    search: dict[str, float] | None = None  # lo, hi, n_grid, rel_tol for the reference search
    band: float = 0.01
    settings: dict[str, Any] = field(default_factory=dict)  # applied when the engine has the key
    needs_timestep: bool = False
    needs_sliding: bool = False
    timeout_factor: float = 1.0


# ------------------------------------------------------------------- scenarios
def _block(**kw: Any) -> Scenario:
    from pbr_xval.conformance import housner_scenario

    return housner_scenario(**kw)


def _excitation(amplitude: float, frequency: float = 1.0) -> dict[str, Any]:
    return {"type": "half_sine", "amplitude": amplitude, "frequency": frequency, "phase": "housner_uplift"}


def fine_base_box_mesh(
    half: tuple[float, float, float] = (0.2, 0.2, 0.6),
    n: int = 33,
    offset: tuple[float, float, float] = (0.0, 0.0, 0.0),
) -> Any:
    """A closed box mesh whose base is an n×n vertex grid (the sides are fans to the top edge)."""
    import trimesh

    bx, by, bz = half
    xs = np.linspace(-bx, bx, n)
    ys = np.linspace(-by, by, n)
    gx, gy = np.meshgrid(xs, ys, indexing="ij")
    verts = [np.column_stack([gx.ravel(), gy.ravel(), np.zeros(n * n)])]
    idx = lambda i, j: i * n + j  # noqa: E731
    faces = []
    for i in range(n - 1):
        for j in range(n - 1):
            faces.append([idx(i, j), idx(i, j + 1), idx(i + 1, j)])
            faces.append([idx(i + 1, j), idx(i, j + 1), idx(i + 1, j + 1)])
    top0 = n * n
    verts.append(np.array([[-bx, -by, 2 * bz], [bx, -by, 2 * bz], [bx, by, 2 * bz], [-bx, by, 2 * bz]]))
    faces += [[top0, top0 + 1, top0 + 2], [top0, top0 + 2, top0 + 3]]
    # base boundary walks: (boundary vertex indices along the edge, its two top corners)
    sides = [
        ([idx(i, 0) for i in range(n)], top0, top0 + 1),  # y = -by, x from -bx to bx
        ([idx(n - 1, j) for j in range(n)], top0 + 1, top0 + 2),  # x = +bx, y up
        ([idx(i, n - 1) for i in range(n - 1, -1, -1)], top0 + 2, top0 + 3),  # y = +by, x down
        ([idx(0, j) for j in range(n - 1, -1, -1)], top0 + 3, top0),  # x = -bx, y down
    ]
    for edge, ta, tb in sides:
        for k in range(n - 1):
            faces.append([ta, edge[k + 1], edge[k]])
        faces.append([ta, tb, edge[-1]])
    v = np.vstack(verts)
    f = np.asarray(faces)
    # orient every face outward (the box is convex: the normal points away from its centre)
    tri = v[f]
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    inward = np.einsum("ij,ij->i", normal, tri.mean(axis=1) - [0.0, 0.0, bz]) < 0
    f[inward] = f[inward][:, ::-1]
    return trimesh.Trimesh(v + np.asarray(offset), f, process=True)


def _box_mesh_offset(offset: tuple[float, float, float]) -> Any:
    import trimesh

    m = trimesh.creation.box(extents=(0.4, 0.4, 1.2))
    m.apply_translation(np.asarray(offset, dtype=float) + np.array([0.0, 0.0, 0.6]))
    return m


def build_cases(names: Sequence[str], tmp: Path) -> list[Case]:
    """The requested cases (files they need are written under ``tmp``).

    Long on purpose: one short branch of data per case family (slenderness, size, friction,
    restitution, mesh, motion, ...), so the function reads as the catalogue of cases; split into
    one function per family it would scatter that catalogue without removing any logic.
    """
    out: list[Case] = []
    r_block = math.hypot(0.2, 0.6)
    for name in names:
        if name.startswith("slender_"):
            deg = float(name.split("_")[1].removesuffix("deg"))
            a = math.radians(deg)
            b, h = r_block * math.sin(a), r_block * math.cos(a)
            u = 9.81 * math.tan(a)
            scn = _block(
                name=f"extreme_{name}",
                rock={"shape": "box", "half_extents": [b, 0.2, h], "density": 2400.0},
                excitation=_excitation(1.5 * u),
            )
            out.append(
                Case(
                    name,
                    "slenderness",
                    "bracket",
                    scn,
                    f"α = {deg:g}° at R = {r_block:.3f} m",
                    search={"lo": 1.01 * u, "hi": 8.0 * u, "n_grid": 8, "rel_tol": 2e-4},
                )
            )
        elif name.startswith("size_"):
            s = {"size_5cm": 0.05, "size_50m": 50.0}[name]
            k = s / 1.2
            sk = math.sqrt(k)
            scn = _block(
                name=f"extreme_{name}",
                duration=5.0 * sk,
                settle_time=0.5 * sk,
                output_dt=min(1e-2, 1e-3 * sk),
                rock={"shape": "box", "half_extents": [0.2 * k, 0.2 * k, 0.6 * k], "density": 2400.0},
                excitation=_excitation(HOUSNER, 1.0 / sk),
            )
            out.append(
                Case(
                    name,
                    "size",
                    "bracket",
                    scn,
                    f"height {s:g} m, pulse frequency {1 / sk:.3g} Hz (ω/p fixed: a_ref = 5.638 by similarity)",
                    a_ref=HOUSNER,
                )
            )
        elif name.startswith("mass_"):
            # a real rock of that mass: granite density, the block scaled (k) to hold it, the pulse
            # frequency scaled by k^-1/2 so ω/p and hence the threshold in m/s² stay 5.638
            m = {"mass_1kg": 1.0, "mass_1e6kg": 1e6}[name]
            k = (m / GRANITE / (0.4 * 0.4 * 1.2)) ** (1.0 / 3.0)
            sk = math.sqrt(k)
            scn = _block(
                name=f"extreme_{name}",
                duration=5.0 * sk,
                settle_time=0.5 * sk,
                output_dt=min(1e-2, 1e-3 * sk),
                rock={"shape": "box", "half_extents": [0.2 * k, 0.2 * k, 0.6 * k], "mass": m},
                excitation=_excitation(HOUSNER, 1.0 / sk),
            )
            out.append(
                Case(
                    name,
                    "mass",
                    "bracket",
                    scn,
                    f"mass {m:g} kg: a granite block ({GRANITE:g} kg/m³) {0.4 * k:.3g} × {0.4 * k:.3g} × "
                    f"{1.2 * k:.3g} m, pulse {1 / sk:.3g} Hz (ω/p fixed: a_ref = 5.638 by similarity)",
                    a_ref=HOUSNER,
                )
            )
        elif name == "dt_1e-2":
            out.append(
                Case(
                    name,
                    "timestep",
                    "bracket",
                    _block(name="extreme_dt_coarse"),
                    "timestep 1e-2 s",
                    a_ref=HOUSNER,
                    settings={"timestep": 1e-2},
                    needs_timestep=True,
                )
            )
        elif name == "dt_1e-5":
            scn = _block(name="extreme_dt_fine", duration=1.5, excitation=_excitation(0.9 * HOUSNER))
            out.append(
                Case(
                    name,
                    "timestep",
                    "peak",
                    scn,
                    "timestep 1e-5 s, 1.5 s at 0.9·5.638: peak |θ| vs housner",
                    settings={"timestep": 1e-5},
                    needs_timestep=True,
                    timeout_factor=3.0,
                )
            )
        elif name.startswith("friction_"):
            mu = float(name.split("_")[1])
            if mu < 1 / 3:
                scn = _block(
                    name=f"extreme_{name}",
                    contact={"friction_static": mu, "restitution": 0.0},
                    excitation=_excitation(1.01 * HOUSNER),
                )
                out.append(
                    Case(
                        name,
                        "friction",
                        "slide",
                        scn,
                        f"μ = {mu:g} < tan α = 1/3: must slide, not rock",
                        needs_sliding=True,
                    )
                )
            else:
                scn = _block(name=f"extreme_{name}", contact={"friction_static": mu, "restitution": 0.0})
                out.append(Case(name, "friction", "bracket", scn, f"μ = {mu:g}", a_ref=HOUSNER))
        elif name == "freq_50Hz":
            u = 9.81 / 3
            scn = _block(name="extreme_freq50", excitation=_excitation(50 * u, 50.0))
            out.append(
                Case(
                    name,
                    "frequency",
                    "bracket",
                    scn,
                    "half-sine at 50 Hz (ω/p ≈ 92)",
                    search={"lo": 1.05 * u, "hi": 600.0 * u, "n_grid": 12, "rel_tol": 2e-4},
                )
            )
        elif name == "amplitude_0.01pct":
            out.append(
                Case(
                    name,
                    "amplitude",
                    "bracket",
                    _block(name="extreme_amp"),
                    "±0.01 % around the housner threshold (outcome must flip)",
                    search={"lo": 5.60, "hi": 5.68, "n_grid": 2, "rel_tol": 2e-6},
                    band=1e-4,
                )
            )
        elif name == "basal_1000_nodes":
            path = tmp / "fine_base_box.obj"
            mesh = fine_base_box_mesh()
            mesh.export(path)
            n_base = int(np.sum(np.abs(mesh.vertices[:, 2]) < 1e-12))
            scn = _block(
                name="extreme_fine_base", rock={"shape": "mesh", "path": str(path), "density": 2400.0}
            )
            out.append(
                Case(
                    name,
                    "contact nodes",
                    "bracket",
                    scn,
                    f"box mesh with {n_base} basal vertices",
                    a_ref=HOUSNER,
                )
            )
        elif name == "offset_10km":
            path = tmp / "box_10km.obj"
            _box_mesh_offset((1e4, 0.0, 0.0)).export(path, digits=10)
            scn = _block(name="extreme_offset", rock={"shape": "mesh", "path": str(path), "density": 2400.0})
            out.append(
                Case(
                    name,
                    "position",
                    "bracket",
                    scn,
                    "box mesh with vertices 10 km from the origin",
                    a_ref=HOUSNER,
                )
            )
        elif name == "record_600s":
            path = tmp / "noise_600s.txt"
            rng = np.random.default_rng(0)
            dt, n = 0.01, 60001
            x = np.convolve(rng.standard_normal(n), np.ones(5) / 5, mode="same")
            x *= 0.3 * 9.81 / 3 / np.max(np.abs(x))  # peak 30 % of the uplift acceleration
            np.savetxt(path, x)
            scn = _block(
                name="extreme_record600",
                duration=600.0,
                output_dt=0.01,
                excitation={"type": "record", "path": str(path), "dt": dt, "units": "m/s2"},
            )
            out.append(
                Case(
                    name,
                    "duration",
                    "rest",
                    scn,
                    "600 s of noise at 30 % of the uplift acceleration",
                    timeout_factor=5.0,
                )
            )
        else:
            raise ValueError(f"unknown extremes case {name!r}; expected one of {list(ALL_CASES)}")
    return out


# -------------------------------------------------------------- classification
def _runs_for(case: Case) -> list[tuple[str, Scenario]]:
    if case.kind == "bracket":
        assert case.a_ref is not None
        lo, hi = (1 - case.band) * case.a_ref, (1 + case.band) * case.a_ref
        return [
            ("below", case.scenario.with_value("excitation.amplitude", lo)),
            ("above", case.scenario.with_value("excitation.amplitude", hi)),
        ]
    return [("run", case.scenario)]


_NAN_WORDS = ("nan", "inf", "explo", "diverg", "blow")


def classify(case: Case, res: Any, ref_peak: float | None, pen_fraction: float) -> tuple[str, str]:
    """(class, detail) of one cell from its :class:`~pbr_xval.study.workers.IsolatedResult`."""
    st = res.status
    if st in ("crash", "timeout"):
        return st, res.message.splitlines()[0][:200] if res.message else st
    if st in ("not_applicable", "unavailable"):
        return "not_applicable", (res.message or st)[:200]
    runs = res.runs
    if st == "failed":
        msg = res.message or ""
        cls = "nan" if any(w in msg.lower() for w in _NAN_WORDS) else "failed"
        return cls, msg.splitlines()[0][:200] if msg else "failed"
    if any(r.get("nan_or_explosion") for r in runs):
        return "nan", "non-finite samples or explosion flagged"
    for r in runs:
        pen, dim = r.get("max_penetration_m"), r.get("min_dimension_m")
        if pen is not None and dim and pen > pen_fraction * dim:
            return "penetration", f"max penetration {pen:.3g} m > {pen_fraction:.0%} of {dim:.3g} m"
    if case.kind == "bracket":
        lo, hi = runs[0]["toppled"], runs[1]["toppled"]
        if not lo and hi:
            return "ok", f"stands at −{case.band:.2%}, topples at +{case.band:.2%} of {case.a_ref:.6g}"
        if lo:
            return "biased", f"topples already at −{case.band:.2%} of {case.a_ref:.6g} (threshold too low)"
        return "biased", f"stands at +{case.band:.2%} of {case.a_ref:.6g} (threshold too high)"
    r = runs[0]
    if case.kind == "slide":
        alpha = r.get("alpha_rad") or math.atan(1 / 3)
        if r["toppled"] or (r.get("peak_tilt_rad") or 0) > 0.1 * alpha:
            return "biased", f"rocked (peak tilt {r.get('peak_tilt_rad', 0):.3g} rad) although μ < tan α"
        if (r.get("max_com_disp_m") or 0) < 1e-3:
            return "biased", f"did not slide (COM moved {r.get('max_com_disp_m', 0):.3g} m)"
        return "ok", f"slid {r['max_com_disp_m']:.3g} m, peak tilt {r.get('peak_tilt_rad', 0):.2g} rad"
    if case.kind == "rest":
        if r["toppled"]:
            return "biased", "toppled under sub-uplift noise"
        tilt, disp = r.get("peak_tilt_rad") or 0.0, r.get("final_com_disp_m") or 0.0
        if tilt > 1e-3 or disp > 1e-3:
            return "drift", f"peak tilt {tilt:.3g} rad, COM moved {disp:.3g} m"
        return "ok", f"peak tilt {tilt:.2g} rad, COM moved {disp:.2g} m"
    # peak
    pk = r.get("peak_abs_theta_rad")
    if ref_peak is None or pk is None:
        return "failed", "no reference peak"
    rel = pk / ref_peak - 1
    if abs(rel) > case.band:
        return "biased", f"peak |θ| {pk:.5g} rad vs reference {ref_peak:.5g} ({rel:+.2%})"
    return "ok", f"peak |θ| {pk:.5g} rad ({rel:+.2%} vs reference)"


# ------------------------------------------------------------------------ run
def run(
    config: ExtremesConfig,
    scenario: Scenario | None,
    engines: Sequence[str],
    *,
    progress: Callable[[str, float], None] | None = None,
) -> StudyResult:
    """Run the matrix. ``scenario`` is not used to build cases (they derive from the Housner
    block) and may be None; it is recorded in the provenance when given."""
    import pandas as pd

    from pbr_xval.engine import EngineNotAvailable
    from pbr_xval.study.workers import (
        SimTask,
        engine_label,
        resolve_engine,
        run_many,
        scenario_payload,
    )

    t_start = time.perf_counter()
    cfg = config
    names = list(ALL_CASES) if cfg.cases == "all" else list(cfg.cases)
    result = StudyResult(kind="extremes", title="Stability at the extremes")
    result.provenance = {"cases": names, "engines": {}, "scenario_hashes": {}}
    if scenario is not None:
        result.provenance["scenario_hash"] = scenario.content_hash()

    say = clamped_progress(progress)

    engs: dict[str, Any] = {}
    labels: dict[str, str] = {}
    for e in engines:
        try:
            engs[e] = resolve_engine(e)
            labels[e] = engine_label(e)
            result.provenance["engines"][labels[e]] = {
                "versions": engs[e].versions(),
                "settings": {"every case": {**engs[e].default_settings(), **cfg.settings.get(labels[e], {})}},
            }
        except EngineNotAvailable as exc:
            result.notes.append(f"{e}: not available ({exc}); skipped")

    tmp = Path(tempfile.mkdtemp(prefix="pbr_xval_extremes_"))
    rows: list[dict[str, Any]] = []
    try:
        cases = build_cases(names, tmp)
        for c in cases:
            result.provenance["scenario_hashes"][c.name] = c.scenario.content_hash()
            result.provenance.setdefault("case_descriptions", {})[c.name] = c.description
        # ---- references (threshold searches and reference peaks), in workers
        ref_tasks = _reference_tasks(cases, cfg)
        ref_peak: dict[str, float] = {}
        ref_fail: dict[str, str] = {}
        by_name = {c.name: c for c in cases}
        n_cells = len(cases) * max(1, len(engs)) + len(ref_tasks)
        done = 0
        for r in run_many(ref_tasks, cfg.max_workers):
            kind, cname = r.tag
            done += 1
            if kind == "search":
                if r.ok and r.value.get("minimum") is not None and not r.value.get("toppled_at_lo"):
                    by_name[cname].a_ref = float(r.value["minimum"])
                    result.provenance.setdefault("reference_thresholds", {})[cname] = {
                        "value_m_s2": r.value["minimum"],
                        "tolerance_m_s2": r.value["tolerance"],
                        "engine": cfg.reference_engine,
                    }
                else:
                    ref_fail[cname] = f"reference search failed: {r.message or r.value}"
            elif r.ok:
                ref_peak[cname] = float(r.summary["peak_abs_theta_rad"])
            else:
                ref_fail[cname] = f"reference run failed: {r.status} {r.message}"
            say(f"reference for {cname}", done / n_cells)

        # ---- cells
        tasks: list[SimTask] = []
        cell_settings: dict[tuple[str, str], dict[str, Any]] = {}
        for c in cases:
            for e, eng in engs.items():
                label = labels[e]
                reason = _not_applicable(c, eng)
                if c.name in ref_fail:
                    reason = ref_fail[c.name]
                if reason:
                    rows.append(
                        {
                            "case": c.name,
                            "group": c.group,
                            "engine": label,
                            "class": "not_applicable",
                            "detail": reason,
                            "wall_s": 0.0,
                            "reference_m_s2": c.a_ref,
                        }
                    )
                    done += 1
                    continue
                settings = dict(cfg.settings.get(label, {}))
                default = eng.default_settings()
                settings.update({k: v for k, v in c.settings.items() if k in default})
                cell_settings[(c.name, label)] = settings
                runs: list[dict[str, Any]] = []
                for _, scn in _runs_for(c):
                    d, s = scenario_payload(scn)
                    runs.append({"scenario": d, "source": s, "settings": settings})
                tasks.append(SimTask(e, runs, tag=(c.name, label), timeout=cfg.timeout * c.timeout_factor))
        for r in run_many(tasks, cfg.max_workers):
            cname, label = r.tag
            c = by_name[cname]
            cls, detail = classify(c, r, ref_peak.get(cname), cfg.penetration_fraction)
            row = _cell_row(r, c, cname, label, cls, detail, result)
            if r.signal:
                row["detail"] = f"{detail} (signal {r.signal})"
            rows.append(row)
            done += 1
            say(f"{cname} × {label}: {cls}", done / n_cells)
        if cfg.measure_biased:
            _measure_biased(rows, by_name, engs, labels, cell_settings, cfg, say)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)

    df = pd.DataFrame(rows)
    if not df.empty:
        order = {n: i for i, n in enumerate(names)}
        eorder = {labels[e]: i for i, e in enumerate(engs)}
        df = df.sort_values(
            by=["case", "engine"], key=lambda s: s.map(order) if s.name == "case" else s.map(eorder)
        )
        df = df.reset_index(drop=True)
    result.tables["extremes_matrix"] = df
    _summarise(result, df, names, engs)
    try:
        if not df.empty:
            result.figures.append(_figure(df, names, [labels[e] for e in engs]))
    except Exception as exc:  # pragma: no cover
        result.notes.append(f"figure failed: {exc}")
    result.wall_time = time.perf_counter() - t_start
    return result


def _reference_tasks(cases: list[Any], cfg: ExtremesConfig) -> list[Any]:
    """The reference engine's work: a threshold search per searched case, a run per peak case."""
    from pbr_xval.study.workers import CallTask, SimTask, scenario_payload

    ref_tasks: list[CallTask | SimTask] = []
    for c in cases:
        data, src = scenario_payload(c.scenario)
        if c.search is not None:
            ref_tasks.append(
                CallTask(
                    "pbr_xval.study.tradeoff:threshold_point",
                    {
                        "scenario": data,
                        "source": src,
                        "engine": cfg.reference_engine,
                        "settings": {},
                        "param": "excitation.amplitude",
                        **c.search,
                    },
                    tag=("search", c.name),
                    timeout=cfg.timeout * 5,
                )
            )
        if c.kind == "peak":
            ref_tasks.append(
                SimTask.single(
                    data,
                    cfg.reference_engine,
                    {},
                    source=src,
                    tag=("peak", c.name),
                    timeout=cfg.timeout * 2,
                )
            )
    return ref_tasks


def _cell_row(
    r: Any, c: Any, cname: str, label: str, cls: str, detail: str, result: StudyResult
) -> dict[str, Any]:
    """The matrix row of one cell (case × engine) from its runs; the case's settings go to the provenance."""
    runs = r.runs
    row = {
        "case": cname,
        "group": c.group,
        "engine": label,
        "class": cls,
        "detail": detail,
        "wall_s": r.wall_s,
        "reference_m_s2": c.a_ref,
    }
    if runs:
        row["max_penetration_m"] = max((x.get("max_penetration_m") or 0.0) for x in runs)
        row["peak_tilt_rad"] = max((x.get("peak_tilt_rad") or 0.0) for x in runs)
        row["sim_wall_s"] = sum((x.get("wall_time_s") or 0.0) for x in runs)
        if c.settings and runs[0].get("settings"):
            result.provenance["engines"].setdefault(label, {}).setdefault("settings", {})[cname] = runs[0][
                "settings"
            ]
    return row


def _summarise(result: StudyResult, df: Any, names: list[str], engs: dict[str, Any]) -> None:
    """Headline (class counts, class per cell) and summary lines (every cell not ok) of the matrix."""
    counts = df["class"].value_counts().to_dict() if not df.empty else {}
    result.headline = {
        "classes": {k: int(v) for k, v in counts.items()},
        "cells": {f"{r['case']}|{r['engine']}": r["class"] for _, r in df.iterrows()},
    }
    result.summary.append(
        f"{len(df)} cells ({len(names)} cases × {len(engs)} engines): "
        + ", ".join(f"{k} {v}" for k, v in sorted(counts.items()))
    )
    for _, r in df.iterrows():
        if r["class"] not in ("ok", "not_applicable"):
            thr = r.get("threshold_m_s2")
            extra = (
                f"; its threshold {thr:.5g} m/s² ({r['threshold_rel_error']:+.2%} from {r['reference_m_s2']:.5g})"
                if isinstance(thr, float) and math.isfinite(thr)
                else ""
            )
            result.summary.append(f"{r['engine']} · {r['case']}: **{r['class']}** — {r['detail']}{extra}")


def _measure_biased(
    rows: list[dict[str, Any]],
    by_name: dict[str, Case],
    engs: dict[str, Any],
    labels: dict[str, str],
    cell_settings: dict[tuple[str, str], dict[str, Any]],
    cfg: ExtremesConfig,
    say: Callable[[str, float], None],
) -> None:
    """Search the threshold of every *bracket* cell outside the band (in workers): how far off it is.

    The search runs on the side the two bracket runs point to: [0.25, 1 − band]·a_ref when the
    rock toppled below the band, [1 + band, 4]·a_ref when it stood above it; rel. tol 1e-3.
    Adds ``threshold_m_s2`` and ``threshold_rel_error`` to the row (NaN when no threshold lies in
    the range searched, with the reason in ``detail``).
    """
    from pbr_xval.study.workers import CallTask, run_many, scenario_payload

    label_to_engine = {v: k for k, v in labels.items()}
    tasks = []
    for idx, row in enumerate(rows):
        c = by_name.get(row["case"])
        if c is None or c.kind != "bracket" or row["class"] != "biased" or c.a_ref is None:
            continue
        low = "too low" in str(row["detail"])
        lo, hi = (0.25, 1 - c.band) if low else (1 + c.band, 4.0)
        data, src = scenario_payload(c.scenario)
        e = label_to_engine.get(row["engine"], row["engine"])
        tasks.append(
            CallTask(
                "pbr_xval.study.tradeoff:threshold_point",
                {
                    "scenario": data,
                    "source": src,
                    "engine": e,
                    "settings": cell_settings.get((c.name, row["engine"]), {}),
                    "param": "excitation.amplitude",
                    "lo": lo * c.a_ref,
                    "hi": hi * c.a_ref,
                    "n_grid": 6,
                    "rel_tol": 1e-3,
                },
                tag=idx,
                timeout=cfg.timeout * c.timeout_factor * 4,
            )
        )
    for i, r in enumerate(run_many(tasks, cfg.max_workers)):
        row = rows[r.tag]
        a_ref = by_name[row["case"]].a_ref or float("nan")
        if r.ok and r.value.get("minimum") is not None and not r.value.get("toppled_at_lo"):
            row["threshold_m_s2"] = float(r.value["minimum"])
            row["threshold_rel_error"] = float(r.value["minimum"]) / a_ref - 1
        else:
            why = (
                "toppled at the bottom of the range"
                if r.ok and r.value.get("toppled_at_lo")
                else "never toppled in the range"
                if r.ok
                else f"search {r.status}: {(r.message or '').splitlines()[0][:120] if r.message else ''}"
            )
            lo_hi = "[0.25, 0.99]" if "too low" in str(row["detail"]) else "[1.01, 4]"
            row["detail"] = f"{row['detail']}; threshold search over {lo_hi}·a_ref: {why}"
        say(f"threshold of {row['case']} × {row['engine']}", (i + 1) / max(len(tasks), 1))


def _not_applicable(c: Case, eng: Any) -> str:
    caps = eng.capabilities
    shape = c.scenario.rock.shape
    if shape not in caps.shapes:
        return f"engine does not take {shape!r} rocks"
    if c.needs_sliding and not caps.sliding:
        return "engine does not model sliding"
    if c.needs_timestep and "timestep" not in eng.default_settings():
        return "engine has no time step"
    return ""


def _figure(df: Any, cases: list[str], engines: list[str]) -> Figure:
    from matplotlib.colors import ListedColormap

    from pbr_xval.report.style import subplots

    cls_index = {c: i for i, c in enumerate(CLASSES)}
    grid = np.full((len(cases), len(engines)), np.nan)
    labels = [["" for _ in engines] for _ in cases]
    for _, r in df.iterrows():
        if r["case"] in cases and r["engine"] in engines:
            i, j = cases.index(r["case"]), engines.index(r["engine"])
            grid[i, j] = cls_index.get(r["class"], cls_index["failed"])
            labels[i][j] = str(r["class"]).replace("not_applicable", "n/a")
    cmap = ListedColormap([CLASS_COLOURS[c] for c in CLASSES])
    fig, ax = subplots(figsize=(1.6 + 1.4 * len(engines), 0.9 + 0.38 * len(cases)))
    ax.grid(False)
    ax.imshow(np.ma.masked_invalid(grid), cmap=cmap, vmin=-0.5, vmax=len(CLASSES) - 0.5, aspect="auto")
    for i in range(len(cases)):
        for j in range(len(engines)):
            txt = labels[i][j]
            dark = txt in ("crash", "nan", "timeout")
            ax.text(j, i, txt, ha="center", va="center", fontsize=8, color="white" if dark else "black")
    ax.set_xticks(range(len(engines)), engines)
    ax.set_yticks(range(len(cases)), cases)
    ax.set_xlabel("engine")
    ax.set_ylabel("extreme case (classes: no unit; thresholds in the table, m/s²)")
    ax.xaxis.tick_top()
    return Figure(
        "extremes_matrix",
        fig,
        "extremes_matrix",
        "Each cell: how an engine behaves in an extreme case (ok, biased > band from the reference, "
        "drift, penetration, nan, crash, timeout, n/a).",
    )
