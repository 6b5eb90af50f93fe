"""Cost of the ``reference`` engine (prints figures, asserts nothing).

1. Wall and CPU seconds per simulated second on the Housner block (a 2 s sub-threshold
   half-sine run at a = 5.0 m/s²; the 5 s run used before stalls from t ≈ 3.47 s, where the
   resting solve's fast path fails on every call and ``lcp.solve_friction_cone`` runs its
   5000 sweeps (~0.8 s per call) without converging — a solver issue, not the stepping), for the reference engine and — in the same run, if it
   imports — MuJoCo, and their ratio.
2. Cost per step against the number of basal contact nodes (4, 16, 64, 256, 1024: the box
   base sampled by an n-node grid, ``nodes = "grid"``), the rock resting on all of them
   (the worst case: every node is a contact), with the fitted log-log growth exponent,
   LCP (contact-solve) time separated from the rest.

Run:  /work/venv/bin/python benchmarks/reference.py [--quick]
"""

from __future__ import annotations

import argparse
import functools
import os
import time

# single-threaded BLAS: on a small shared machine OpenBLAS threads make a 192 × 192 solve
# ~40× slower (76 ms vs 1.8 ms measured); set before numpy is imported
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

from pbr_xval import conformance as conf  # noqa: E402
from pbr_xval.engine import EngineNotAvailable, get_engine  # noqa: E402
from pbr_xval.runner import run_scene  # noqa: E402
from pbr_xval.scene import compile_scene  # noqa: E402

print = functools.partial(print, flush=True)


def _timed(scene, engine, settings=None):
    c0 = time.process_time()
    w0 = time.perf_counter()
    traj = run_scene(scene, engine, settings)
    return traj, time.perf_counter() - w0, time.process_time() - c0


def housner_speed(duration: float) -> None:
    scene = compile_scene(
        conf.housner_scenario(
            duration=duration,
            excitation={"type": "half_sine", "amplitude": 5.0, "frequency": 1.0, "phase": "housner_uplift"},
        )
    )
    print(f"== Housner block, half-sine a = 5.0 m/s², {duration:g} s simulated, dt = 1e-3 s")
    _timed(compile_scene(conf.housner_scenario(duration=0.05)), "reference")  # warm-up (imports, caches)
    traj, wall, cpu = min((_timed(scene, "reference") for _ in range(2)), key=lambda r: r[2])  # best of 2
    d = traj.diagnostics
    t_sim = float(d["simulated_s"])
    held = d.get("held_at_rest_from_s")
    print(
        f"reference: status {traj.status}, toppled {traj.toppled}, steps {d['steps']}, impacts {d['impacts']}, "
        f"held at rest from {held}"
    )
    print(
        f"reference: wall {wall:.2f} s, CPU {cpu:.2f} s -> {wall / t_sim:.3f} wall-s and {cpu / t_sim:.3f} CPU-s "
        f"per simulated s; contact solves {d['lcp_time_s']:.2f} s ({100 * d['lcp_time_fraction']:.0f} %)"
    )
    # the same without the at-rest hold (every step integrated)
    traj2, wall2, cpu2 = _timed(scene, "reference", {"rest_velocity": 0.0})
    d2 = traj2.diagnostics
    print(
        f"reference (no rest hold): steps {d2['steps']}, wall {wall2:.2f} s, CPU {cpu2:.2f} s -> "
        f"{cpu2 / duration:.3f} CPU-s per simulated s, {1e3 * cpu2 / max(1, d2['steps']):.3f} ms CPU per step"
    )
    try:
        get_engine("mujoco")
    except (EngineNotAvailable, ImportError) as exc:
        print(f"mujoco: not available ({exc}); no ratio")
        return
    try:
        tm, wm, cm = min((_timed(scene, "mujoco") for _ in range(2)), key=lambda r: r[2])  # best of 2 (warm)
    except Exception as exc:  # the adapter is someone else's work in progress
        print(f"mujoco: failed ({type(exc).__name__}: {exc}); no ratio")
        return
    print(
        f"mujoco: status {tm.status}, toppled {tm.toppled}, wall {wm:.2f} s, CPU {cm:.2f} s -> "
        f"{wm / duration:.4f} wall-s and {cm / duration:.4f} CPU-s per simulated s"
    )
    print(
        f"ratio reference / mujoco (wall, with rest hold): {wall / max(wm, 1e-9):.1f}; "
        f"(CPU, with rest hold): {cpu / max(cm, 1e-9):.1f}; "
        f"(CPU, every step integrated): {cpu2 / max(cm, 1e-9):.1f}"
    )


def node_scaling(counts: list[int]) -> None:
    print("== cost against the number of basal contact nodes (box resting on an n-node grid)")
    rows = []
    for n in counts:
        steps = 100 if n <= 16 else (30 if n <= 64 else (8 if n <= 256 else 2))
        scene = compile_scene(
            conf.housner_scenario(
                name="bench_nodes",
                duration=steps * 1e-3,
                output_dt=1e-3,
                excitation={"type": "half_sine", "amplitude": 3.0, "frequency": 1.0, "phase": 0.0},
            )
        )
        settings = {"nodes": "grid", "max_nodes": n, "rest_velocity": 0.0}
        traj, _, _ = _timed(scene, "reference", settings)
        d = traj.diagnostics  # wall_s / lcp_time_s are measured inside the stepping loop
        nst = max(1, d["steps"])
        per = d["wall_s"] / nst
        lcp_per = d["lcp_time_s"] / nst
        rows.append((n, d["n_nodes"], per, lcp_per))
        print(
            f"n = {n:5d} (nodes {d['n_nodes']:5d}, contacts max {d.get('contacts_max', '?')}): {1e3 * per:9.2f} ms/step, "
            f"contact solve {1e3 * lcp_per:9.2f} ms, rest {1e3 * (per - lcp_per):7.2f} ms; "
            f"steps {nst}, solves {d['lcp_solves']}, fast path {d['lcp_fast_path']}, status {traj.status}"
        )
    n = np.array([r[0] for r in rows], dtype=float)
    for label, col in (("total", 2), ("contact solve", 3)):
        y = np.array([r[col] for r in rows])
        sel = n >= 16
        if sel.sum() >= 2 and np.all(y[sel] > 0):
            slope = np.polyfit(np.log(n[sel]), np.log(y[sel]), 1)[0]
            print(f"log-log growth exponent of the {label} cost per step (n >= 16): {slope:.2f}")
    print("(per-step cost ~ n^p; dense contact-space LCP: building A is O(n²), solving O(n³))")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="nodes up to 256 only")
    args = ap.parse_args()
    housner_speed(2.0)
    node_scaling([4, 16, 64, 256] if args.quick else [4, 16, 64, 256, 1024])
    print(f"(machine: {__import__('os').cpu_count()} CPUs; load average {__import__('os').getloadavg()})")


if __name__ == "__main__":
    main()
