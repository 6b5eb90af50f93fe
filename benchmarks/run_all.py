"""Every performance figure of issue 15 in one run, each next to its goal as a ratio.

=====================================================  =========  ==============================
figure                                                 goal       computed by
=====================================================  =========  ==============================
harness / bare loop, per engine (wall, 1 kHz output)  ≤ 1.3×     ``benchmarks/engines.py``
reference / MuJoCo CPU per simulated second            ≤ 10×      ``benchmarks/reference.py``
node-growth exponent of the reference solver           ≤ 1.2      ``benchmarks/reference.py``
simulations per threshold (Housner, rel_tol 1e-3)      ≤ 15       ``find_threshold`` per engine
40 × 40 fragility map on 2 workers (MuJoCo faithful)   < 60 s     ``benchmarks/fragility_map.py``
catalog scaling efficiency 1 → 2 workers               ≥ 85 %     ``benchmarks/catalog.py``
catalog store overhead                                 < 5 %      ``benchmarks/catalog.py``
=====================================================  =========  ==============================

A ratio is value / goal for upper bounds (≤ 1 meets the goal) and goal / value for the
scaling efficiency. The machine's load average is printed at the start and the end: on a
shared machine the wall-time figures include other processes' load.

Usage: ``python benchmarks/run_all.py [--quick]`` (``--quick``: a 20 × 20 map, whose wall
time is scaled by 4 to the 40 × 40 figure, and fewer node counts; says so in the output).
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

ROWS: list[tuple[str, float, str, float, bool]] = []  # label, value, unit, goal, upper bound


def row(label: str, value: float, unit: str, goal: float, upper: bool = True) -> None:
    ROWS.append((label, value, unit, goal, upper))
    ratio = value / goal if upper else goal / value
    rel = "≤" if upper else "≥"
    ok = "met" if ratio <= 1.0 else "NOT met"
    print(f"  {label:58s} {value:10.3g} {unit:4s} goal {rel} {goal:g}: ratio {ratio:5.2f} ({ok})", flush=True)


def engines_part() -> None:
    import engines as eb
    from pbr_xval.engine import EngineNotAvailable, get_engine

    print(
        "== harness / bare loop (benchmarks/engines.py, Housner a = 5.0, 0.5 s + 5 s, output 1 ms;"
        " dt 1 ms: every step is a sample; dt 0.1 ms: native steps between samples)",
        flush=True,
    )
    for name in ("mujoco", "pybullet", "dart"):
        try:
            get_engine(name)
        except EngineNotAvailable as exc:
            print(f"  {name}: not available ({exc})")
            continue
        for dt in (1e-3, 1e-4):
            r = eb.overhead(name, dt, 3)
            row(f"harness / bare, {name}, dt {dt * 1e3:g} ms", r["ratio"], "×", eb.GOAL)


def reference_part(quick: bool) -> None:
    import reference as rb

    print("== reference solver (benchmarks/reference.py)", flush=True)
    h = rb.housner_speed()
    if "mujoco_2" in h:
        row(
            "reference / MuJoCo CPU per simulated s (2 s Housner)",
            h["ref_2"] / h["mujoco_2"],
            "×",
            rb.GOAL_RATIO,
        )
    counts = [16, 64, 256, 1024]
    expo = rb.node_scaling(counts, steps=60 if quick else 200)
    row("node-growth exponent, 16–1,024 nodes", expo, "", rb.GOAL_EXPONENT)


def threshold_part() -> None:
    from pbr_xval.engine import EngineNotAvailable, get_engine
    from pbr_xval.scenario import load_scenario
    from pbr_xval.study.threshold_search import find_threshold

    print("== simulations per threshold (find_threshold, examples/housner_halfsine.toml, rel_tol 1e-3)")
    scn = load_scenario(HERE.parent / "examples" / "housner_halfsine.toml")
    for name in ("housner", "mujoco", "pybullet", "dart"):
        try:
            get_engine(name)
        except EngineNotAvailable:
            continue
        t0 = time.perf_counter()
        res = find_threshold(scn, name, rel_tol=1e-3)
        first = f"{res.transitions[0].value:.5g} m/s²" if res.transitions else "none"
        print(
            f"  {name}: status {res.status}, first transition {first}, {time.perf_counter() - t0:.1f} s wall"
        )
        row(f"simulations per threshold, {name}", res.n_simulations, "", 15.0)


def fragility_part(quick: bool) -> None:
    import fragility_map as fm

    n = 20 if quick else 40
    print(f"== fragility map {n} × {n} (benchmarks/fragility_map.py, MuJoCo faithful, 2 workers)", flush=True)
    r = fm.fragility_map(n, 2, "mujoco")
    wall = r["wall_s"] * (40 / n) ** 2
    note = "" if n == 40 else f" (scaled from {n} × {n}: {r['wall_s']:.1f} s)"
    print(f"  compiles per worker {r['compiles_per_worker']}, toppled {r['toppled'].mean():.1%}{note}")
    row("40 × 40 fragility map, wall on 2 workers", wall, "s", fm.GOAL_S)
    row(
        "40 × 40 fragility map, CPU / 2 (wall on 2 idle cores)",
        r["cpu_s"] * (40 / n) ** 2 / 2,
        "s",
        fm.GOAL_S,
    )


def catalog_part() -> None:
    print("== catalog sweep (benchmarks/catalog.py)", flush=True)
    out = subprocess.run(
        [sys.executable, str(HERE / "catalog.py")], capture_output=True, text=True, check=True
    ).stdout
    for line in out.splitlines():
        print("  " + line)
    eff = float(re.search(r"scaling efficiency 1→2 workers: ([\d.]+)%", out).group(1))
    ovh = float(re.search(r"= ([\d.]+)% of compute", out).group(1))
    row("catalog scaling efficiency 1 → 2 workers", eff, "%", 85.0, upper=False)
    row("catalog store overhead (share of compute)", ovh, "%", 5.0)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument(
        "--skip", default="", help="comma-separated parts to skip: engines,reference,threshold,map,catalog"
    )
    args = ap.parse_args()
    skip = set(args.skip.split(",")) - {""}
    from pbr_xval.machine import describe_machine

    print(f"(machine: {describe_machine()}, load average at start {os.getloadavg()})", flush=True)
    parts = {
        "engines": engines_part,
        "reference": lambda: reference_part(args.quick),
        "threshold": threshold_part,
        "map": lambda: fragility_part(args.quick),
        "catalog": catalog_part,
    }
    for name, fn in parts.items():
        if name not in skip:
            fn()
    print(f"== summary (load average at end {os.getloadavg()})")
    for label, value, unit, goal, upper in ROWS:
        ratio = value / goal if upper else goal / value
        print(
            f"  {label:58s} {value:10.3g} {unit:4s} ratio {ratio:5.2f} {'met' if ratio <= 1 else 'NOT met'}"
        )


if __name__ == "__main__":
    main()
