"""A 40 × 40 fragility map on 2 workers: wall time against the goal (< 60 s, issue 15).

The Housner block (0.4 × 0.4 × 1.2 m, the conformance block) under a half-sine pulse (Housner's
uplift phase) over amplitude (m/s²) × frequency (Hz): one simulation per cell with the fastest
faithful engine (MuJoCo, faithful profile, dt = 1 ms), 0.5 s settling + ``--duration`` s. Cells
are split by frequency rows over a process pool; each worker compiles the engine model once
(``engines._common.cached_model``: the model depends on the geometry and the settings, not on
the excitation) and reuses it for all its cells; the script reports the compiles per worker.

Prints the wall time, simulations per second, the toppled fraction, and the ratio to the goal.
Usage: ``python benchmarks/fragility_map.py [--n 40] [--workers 2] [--engine mujoco]``
"""

from __future__ import annotations

import argparse
import os
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np

GOAL_S = 60.0


def _row(args: tuple[str, float, list[float], float]) -> tuple[list[bool], int, int, float]:
    """Toppled flags of one frequency row, the model compiles of this worker, its pid, CPU s of the row."""
    engine, freq, amps, duration = args
    from pbr_xval.conformance import housner_scenario
    from pbr_xval.engine import get_engine
    from pbr_xval.engines import _common
    from pbr_xval.runner import run_scene
    from pbr_xval.scene import compile_scene

    c0 = time.process_time()
    settings = get_engine(engine).profiles()["faithful"]
    out = []
    for a in amps:
        exc = {"type": "half_sine", "amplitude": a, "frequency": freq, "phase": "housner_uplift"}
        scene = compile_scene(housner_scenario(duration=duration, excitation=exc))
        traj = run_scene(scene, engine, settings)
        if traj.status != "ok":
            raise RuntimeError(f"{engine} failed at a = {a} m/s², f = {freq} Hz: {traj.message}")
        out.append(bool(traj.toppled))
    return out, _common.MODEL_BUILDS.get(engine, 0), os.getpid(), time.process_time() - c0


def fragility_map(n: int = 40, workers: int = 2, engine: str = "mujoco", duration: float = 2.5) -> dict:
    """Run the n × n map; returns wall time (s), grid, toppled map (n_freq, n_amp), compiles per worker."""
    amps = np.linspace(3.0, 15.0, n).tolist()  # m/s²; g·tan α = 3.27 m/s² is the uplift bound
    freqs = np.linspace(0.5, 4.0, n).tolist()  # Hz
    t0 = time.perf_counter()
    with ProcessPoolExecutor(max_workers=workers) as pool:
        rows = list(pool.map(_row, [(engine, f, amps, duration) for f in freqs]))
    wall = time.perf_counter() - t0
    builds: dict[int, int] = {}
    for _, b, pid, _ in rows:
        builds[pid] = max(builds.get(pid, 0), b)
    return {
        "wall_s": wall,
        "n": n,
        "workers": workers,
        "engine": engine,
        "toppled": np.array([r[0] for r in rows]),
        # CPU seconds of the simulations (worker start-up excluded): wall on idle cores ≈ cpu_s / workers
        "cpu_s": float(sum(r[3] for r in rows)),
        "compiles_per_worker": sorted(builds.values()),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, default=40)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--engine", default="mujoco")
    ap.add_argument("--duration", type=float, default=2.5, help="s after the pulse starts")
    args = ap.parse_args()
    r = fragility_map(args.n, args.workers, args.engine, args.duration)
    sims = args.n * args.n
    print(
        f"fragility map {args.n} × {args.n} ({args.engine}, faithful, {args.workers} workers): "
        f"{r['wall_s']:.1f} s, {sims / r['wall_s']:.1f} simulations/s, toppled {r['toppled'].mean():.1%}, "
        f"model compiles per worker {r['compiles_per_worker']}"
    )
    print(
        f"  goal < {GOAL_S:.0f} s: ratio {r['wall_s'] / GOAL_S:.2f} ({'met' if r['wall_s'] < GOAL_S else 'NOT met'})"
    )
    idle = r["cpu_s"] / args.workers
    print(
        f"  CPU {r['cpu_s']:.1f} core-s in the simulations: {idle:.1f} s on {args.workers} idle cores "
        f"(ratio {idle / GOAL_S:.2f}); load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs"
    )


if __name__ == "__main__":
    main()
