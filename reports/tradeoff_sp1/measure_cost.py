"""CPU cost per simulation of a mesh rock (SP1, MuJoCo faithful, hull) under shake-table records.

The inputs of the 1,000 rocks × 1,000 records × 16 members projection in docs/catalogs.md.
Runs every ``--stride``-th screening test of SP1 in this process, one at a time, through the
catalog chunk machinery's own scenario (the corrected record written by ``pbr-xval choose
--campaign`` / ``validate``), and measures per test: CPU seconds of the scene compilation and
of ``simulate`` (``time.process_time``: the machine is shared, wall time is not the cost),
the simulated time (record + 3 s tail, or up to the topple: runs stop once toppled) and the
engine wall time. Writes ``cost_per_simulation.json`` (MuJoCo, hull) or
``cost_per_simulation_<engine>_<settings>.json`` beside this file.

    python reports/tradeoff_sp1/measure_cost.py --store runs/tradeoff_sp1 [--stride 2]
    python reports/tradeoff_sp1/measure_cost.py --engine pybullet --stride 6
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[1]


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--store", type=Path, default=REPO / "runs" / "tradeoff_sp1")
    ap.add_argument("--stride", type=int, default=2, help="every N-th of the 66 screening tests")
    ap.add_argument("--engine", default="mujoco")
    ap.add_argument("--settings", default='{"collision": "hull"}', help="engine settings (JSON)")
    a = ap.parse_args()
    settings = json.loads(a.settings)
    for k in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ[k] = "1"

    from pbr_xval.catalog.tasks import scenario_dict, worker_engine
    from pbr_xval.runner import effective_settings
    from pbr_xval.scenario import load_scenario, scenario_from_dict
    from pbr_xval.scene import compile_scene
    from pbr_xval.validation.calibrate import screening_subset
    from pbr_xval.validation.campaign import Baseline, load_campaign
    from pbr_xval.validation.runner import build_validation_chunks, prepare_motions

    camp = load_campaign(REPO.parent / "shared" / "data" / "shake_table", 1)
    tests = screening_subset(camp, 3)[:: a.stride]
    camp = camp.select(tests)
    scn = load_scenario(REPO / "examples" / "validation" / "sp1.toml")
    motions = prepare_motions(camp, Baseline(), a.store / "motions")
    chunks = build_validation_chunks(
        camp, motions, scn, [a.engine], settings={a.engine: {"collision": "hull"}}
    )
    eng = worker_engine(a.engine)
    # warm-up (imports, the scan's cache): not counted
    c0 = chunks[0]
    s0 = compile_scene(scenario_from_dict(scenario_dict(c0, c0.motions[0], 0.6, 1)))
    eng.simulate(s0, effective_settings(eng, s0, settings))
    rows = []
    for c in chunks:
        m = c.motions[0]
        t0, w0 = time.process_time(), time.perf_counter()
        scene = compile_scene(scenario_from_dict(scenario_dict(c, m, 0.6, 1)))
        full = effective_settings(eng, scene, settings)
        t1, w1 = time.process_time(), time.perf_counter()
        traj = eng.simulate(scene, full)
        t2, w2 = time.process_time(), time.perf_counter()
        sim_t = float(traj.t[-1]) if traj.t.size else float("nan")
        rows.append({
            "test": m["params"]["test"], "record_s": m["duration"], "simulated_s": sim_t, "toppled": bool(traj.toppled),
            "compile_cpu_s": t1 - t0, "simulate_cpu_s": t2 - t1, "simulate_wall_s": w2 - w1, "compile_wall_s": w1 - w0,
        })  # fmt: skip
        print(json.dumps(rows[-1]), flush=True)
    sim = np.array([r["simulate_cpu_s"] for r in rows])
    comp = np.array([r["compile_cpu_s"] for r in rows])
    simt = np.array([r["simulated_s"] for r in rows])
    doc = {
        "what": f"SP1 ({a.engine} faithful, settings {settings}, output every 10 ms) under {len(rows)} corrected "
        f"shake-table records (every {a.stride}th screening test), one process, after a warm-up run",
        "engine": a.engine,
        "settings": settings,
        "n": len(rows),
        "cpu_s_per_simulation_mean": float((sim + comp).mean()),
        "simulate_cpu_s_mean": float(sim.mean()),
        "simulate_cpu_s_median": float(np.median(sim)),
        "compile_cpu_s_mean": float(comp.mean()),
        "simulated_s_mean": float(simt.mean()),
        "cpu_s_per_simulated_s": float(sim.sum() / simt.sum()),
        "toppled": int(sum(r["toppled"] for r in rows)),
        "load_average_at_end": os.getloadavg(),
        "cpus": os.cpu_count(),
        "runs": rows,
    }
    name = (
        "cost_per_simulation.json"
        if (a.engine, settings) == ("mujoco", {"collision": "hull"})
        else (
            f"cost_per_simulation_{a.engine}_" + "_".join(f"{k}-{v}" for k, v in settings.items()) + ".json"
        )
    )
    (HERE / name).write_text(json.dumps(doc, indent=2) + "\n")
    print(json.dumps({k: v for k, v in doc.items() if k != "runs"}, indent=2))


if __name__ == "__main__":
    main()
