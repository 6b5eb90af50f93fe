"""Global sensitivity of the toppling response to the uncertain inputs (Morris elementary effects).

Which of the scenario's ``[uncertainty]`` inputs move a rock's response on the shake table, and
which could be fixed? SALib's Morris method (``SALib.sample.morris`` / ``SALib.analyze.morris``)
perturbs one input at a time along ``r`` random trajectories through the unit cube, mapped to each
input's distribution by its inverse CDF (the same map as the ensemble's members). Every sample is
run on every selected test through the ensemble machinery (``validate --ensemble``'s chunks and
store, so a rerun recomputes nothing), with one engine.

Responses, per test and sample: ``tilt`` = min(peak tilt / α_min, 1.5) (how close the rock came
to toppling; 1.5 for a toppled rock, rad/rad) and ``toppled`` (0/1). For each response the
elementary effects are analysed per test and summarised over tests by the mean of μ* (the mean
absolute elementary effect, in the response's unit per unit-cube step) and of σ (its spread:
non-linearity and interactions). Inputs with ``choice`` distributions are left out (Morris needs
an ordered input).

Usage (developer tool; minutes)::

    python -m pbr_xval.validation.sensitivity ../shared/data/shake_table --specimen 1 \\
        --scenario examples/validation/sp1_field.toml --engine mujoco --tests 15,61,... \\
        --trajectories 4 --out runs/sensitivity_sp1
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pbr_xval.atomic import write_text_atomic

__all__ = ["main", "morris_indices", "morris_members"]


def morris_members(
    spec: Any, engine: str, trajectories: int, levels: int, seed: int
) -> tuple[dict[str, Any], list[Any], np.ndarray]:
    """(SALib problem, members, unit-cube sample (n, k)) for the ordered inputs of ``spec``."""
    from SALib.sample import morris

    from pbr_xval.uncertainty import Member

    dists = [d for d in spec.dists if d.dist != "choice"]
    problem = {"num_vars": len(dists), "names": [d.key for d in dists], "bounds": [[0.0, 1.0]] * len(dists)}
    x = morris.sample(problem, N=trajectories, num_levels=levels, seed=seed)
    members = [
        Member(index=i, engine=engine, values={d.key: d.ppf(u) for d, u in zip(dists, row, strict=True)},
               seed=seed, sampling="morris", design_members=len(x))
        for i, row in enumerate(x)
    ]  # fmt: skip
    return problem, members, x


def morris_indices(problem: dict[str, Any], x: np.ndarray, y: np.ndarray, levels: int) -> pd.DataFrame:
    """μ*, μ and σ per input (SALib's Morris analysis) for one response vector ``y`` (n,)."""
    from SALib.analyze import morris

    r = morris.analyze(problem, x, y, num_levels=levels, print_to_console=False)
    return pd.DataFrame({"mu_star": r["mu_star"], "mu": r["mu"], "sigma": r["sigma"]}, index=problem["names"])


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(
        prog="python -m pbr_xval.validation.sensitivity", description=__doc__.split("\n")[0]
    )
    p.add_argument("campaign")
    p.add_argument("--specimen", type=int, default=1)
    p.add_argument("--scenario", type=Path, required=True)
    p.add_argument("--engine", required=True)
    p.add_argument("--tests", required=True)
    p.add_argument("--trajectories", type=int, default=4)
    p.add_argument("--levels", type=int, default=4)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--out", type=Path, required=True)
    a = p.parse_args(argv)
    if a.trajectories < 2 or a.levels < 2:
        p.error(f"--trajectories {a.trajectories} / --levels {a.levels}: expected at least 2 each")

    from pbr_xval.catalog.store import load_results
    from pbr_xval.catalog.sweep import run_chunks
    from pbr_xval.scenario import load_scenario
    from pbr_xval.scene import compile_scene
    from pbr_xval.uncertainty import ensemble_spec
    from pbr_xval.validation import load_campaign
    from pbr_xval.validation.campaign import Baseline
    from pbr_xval.validation.ensemble import build_ensemble_chunks
    from pbr_xval.validation.execution import prepare_motions

    scn = load_scenario(a.scenario)
    spec = ensemble_spec(scn)
    if spec is None:
        p.error(f"--scenario {a.scenario}: no [uncertainty] table")
    camp = load_campaign(a.campaign, specimen=a.specimen).select(tests=[t for t in a.tests.split(",") if t])
    motions = prepare_motions(camp, Baseline(), a.out / "motions")
    problem, members, x = morris_members(spec, a.engine, a.trajectories, a.levels, a.seed)
    alpha_min = min(compile_scene(scn).alpha)
    chunks = build_ensemble_chunks(camp, motions, scn, members)
    run_chunks(chunks, a.out / "store", workers=a.workers, description="sensitivity (Morris)")
    rows = load_results(a.out / "store")
    rows = rows[rows["chunk_hash"].isin({c.content_hash() for c in chunks})]
    rows = rows.assign(
        test=[json.loads(s)["test"] for s in rows["motion_params"]],
        member=[int(json.loads(s)["member"]) for s in rows["motion_params"]],
    ).drop_duplicates(["test", "member"])
    tables: dict[str, list[pd.DataFrame]] = {"tilt": [], "toppled": []}
    for test, g in rows.groupby("test"):
        g = g.set_index("member").reindex(range(len(members)))
        if g["toppled"].isna().any():
            print(f"sensitivity: test {test}: {int(g['toppled'].isna().sum())} samples did not run; skipped")
            continue
        tilt = np.where(
            g["toppled"].astype(bool), 1.5, np.minimum(g["peak_tilt"].to_numpy(float) / alpha_min, 1.5)
        )
        tables["tilt"].append(morris_indices(problem, x, tilt, a.levels).assign(test=test))
        top = g["toppled"].astype(float).to_numpy()
        tables["toppled"].append(morris_indices(problem, x, top, a.levels).assign(test=test))
    summary: dict[str, Any] = {
        "scenario": str(a.scenario), "engine": a.engine, "tests": sorted(rows["test"].unique().tolist()),
        "trajectories": a.trajectories, "levels": a.levels, "samples_per_test": len(members),
        "alpha_min_deg": float(np.degrees(alpha_min)),
    }  # fmt: skip
    a.out.mkdir(parents=True, exist_ok=True)
    for resp, ts in tables.items():
        if not ts:
            continue
        allt = pd.concat(ts)
        write_text_atomic(a.out / f"morris_{resp}_per_test.csv", allt.to_csv(index_label="input"))
        mean = allt.groupby(level=0)[["mu_star", "sigma"]].mean().sort_values("mu_star", ascending=False)
        summary[resp] = {
            k: {"mu_star": float(v.mu_star), "sigma": float(v.sigma)} for k, v in mean.iterrows()
        }
        print(f"Morris ({resp}, mean over {len(ts)} tests):")
        for k, v in mean.iterrows():
            print(f"  {k:28s} mu* {v.mu_star:.3f}  sigma {v.sigma:.3f}")
    write_text_atomic(a.out / "morris.json", json.dumps(summary, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
