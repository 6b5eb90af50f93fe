"""Ensemble throughput on MuJoCo (issue 23): a campaign's P(topple) per test against its goals.

Runs ``pbr-xval validate`` as a user would, each into a fresh temporary folder, on the same tests:

1. the deterministic MuJoCo campaign (``--engine mujoco``);
2. the 16-member ensemble (``--ensemble --engine mujoco --members 16``, non-adaptive), in the
   folder of run 1 (its deterministic chunks are in the store and skipped, so the command's extra
   cost is the ensemble's);
3. the adaptive ensemble (``--half-width 0.1``, batches of 4, up to 16 members) in a copy of
   run 1's folder.

and prints for each: wall time, CPU time (the command and its worker processes), simulation runs,
wall and CPU seconds per run; then, next to their goals,

* the projected wall time of all 196 tests × 16 members on 2 workers (runs scaled from the
  measured ensemble wall per run): goal < 15 min;
* the adaptive ensemble's wall time over the deterministic campaign's (both whole commands, same
  tests, same machine): goal ≤ 6.

Usage::

    python benchmarks/ensemble.py [--tests-every K | --limit N] [--members 16] [--workers 2]

All 196 tests by default: the three runs cost about 160 CPU-s per 13 tests (measured 2026-11-26,
``--tests-every 16``, AMD EPYC 2 cores), so about 20 min on a quiet 2-core machine for all 196
(``--no-adaptive``: about 14 min); the last line projects the full run from the subset's own time.
The machine's load average is printed at the start and the end: on a shared machine the wall times
include other processes' load, and the CPU figures (and the projection from them) are the ones to
compare.
"""

from __future__ import annotations

import argparse
import functools
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from pbr_xval.machine import describe_machine

print = functools.partial(print, flush=True)

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
GOAL_WALL_MIN = 15.0  # min, 196 tests × 16 members on 2 cores
GOAL_ADAPTIVE_RATIO = 6.0  # adaptive ensemble wall / deterministic wall
FULL_TESTS, FULL_MEMBERS = 196, 16


def _children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def _run(label: str, args: list[str]) -> dict[str, float]:
    """Run ``pbr-xval <args>``; wall and CPU seconds (the command and every worker it waited for)."""
    cmd = [
        sys.executable,
        "-c",
        "import sys; from pbr_xval.cli import main; sys.argv[0] = 'pbr-xval'; main()",
        *args,
    ]
    print(f"-- {label}: pbr-xval {' '.join(args)}")
    c0, t0 = _children_cpu(), time.perf_counter()
    proc = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
    wall, cpu = time.perf_counter() - t0, _children_cpu() - c0
    out = Path(args[args.index("--out") + 1])
    if proc.returncode not in (0, 1) or not (out / "validation.json").is_file():  # 1: some runs failed
        print(proc.stdout[-3000:])
        print(proc.stderr[-3000:])
        raise SystemExit(f"{label}: pbr-xval exited with {proc.returncode}")
    for line in proc.stdout.splitlines():
        if line.startswith(("F1 mujoco", "F1 ensemble", "Brier ensemble")):
            print(f"   {line}")
    if proc.returncode == 1:
        print(f"   (exit 1: some runs failed) {proc.stderr.strip().splitlines()[-1]}")
    return {"wall": wall, "cpu": cpu}


def _meta(out: Path) -> dict[str, object]:
    return dict(json.loads((out / "validation.json").read_text()))


def _members(out: Path) -> int:
    import pandas as pd

    return len(pd.read_csv(out / "ensemble_members.csv"))


def _line(label: str, r: dict[str, float], runs: int) -> None:
    print(
        f"   {label:<28s} wall {r['wall']:8.1f} s  CPU {r['cpu']:8.1f} s  runs {runs:5d}  "
        f"{r['wall'] / runs:6.3f} s wall/run  {r['cpu'] / runs:6.3f} s CPU/run"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--campaign", default=str(ROOT.parent / "shared" / "data" / "shake_table"))
    ap.add_argument("--specimen", type=int, default=1)
    ap.add_argument("--scenario", default=str(ROOT / "examples" / "validation" / "sp1.toml"))
    sel = ap.add_mutually_exclusive_group()
    sel.add_argument("--tests-every", type=int, default=None, help="every K-th test of the campaign")
    sel.add_argument("--limit", type=int, default=None, help="the first N tests")
    ap.add_argument("--members", type=int, default=FULL_MEMBERS)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--half-width", type=float, default=0.1)
    ap.add_argument("--no-adaptive", action="store_true", help="skip the adaptive run")
    a = ap.parse_args()

    from pbr_xval.validation.campaign import load_campaign

    camp = load_campaign(Path(a.campaign), a.specimen)
    all_tests = [t.test for t in camp.tests]
    if a.tests_every:
        tests = all_tests[:: a.tests_every]
    elif a.limit:
        tests = all_tests[: a.limit]
    else:
        tests = all_tests
    n_full = len(all_tests)
    print(
        f"machine: {describe_machine()}; {a.workers} workers; "
        f"load average at start {tuple(round(x, 2) for x in os.getloadavg())}"
    )
    print(
        f"campaign {a.campaign}, specimen {a.specimen}: {len(tests)} of {n_full} tests; "
        f"scenario {a.scenario}; MuJoCo ({a.members} members per test)"
    )
    base = ["validate", a.campaign, "--specimen", str(a.specimen), "--scenario", a.scenario]
    base += ["--engine", "mujoco", "--workers", str(a.workers), "--tests", ",".join(tests)]
    ens = ["--ensemble", "--members", str(a.members)]
    t_start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="pbr-xval-bench-ensemble-") as tmp:
        det_out, ada_out = Path(tmp) / "det", Path(tmp) / "adaptive"
        det = _run("deterministic", [*base, "--out", str(det_out)])
        n_det = len(tests)
        if not a.no_adaptive:
            shutil.copytree(det_out, ada_out)  # the deterministic chunks: skipped by the adaptive run
        full = _run("ensemble, non-adaptive", [*base, *ens, "--out", str(det_out)])
        n_full_runs = _members(det_out)
        meta_full = _meta(det_out)
        ada = None
        if not a.no_adaptive:
            ada = _run(
                f"ensemble, adaptive (half-width {a.half_width:g})",
                [*base, *ens, "--half-width", str(a.half_width), "--out", str(ada_out)],
            )
            n_ada = _members(ada_out)
    print(f"== figures ({len(tests)} tests; whole commands, workers' CPU included)")
    _line("deterministic", det, n_det)
    _line(f"ensemble ×{a.members}", full, n_full_runs)
    print(
        f"   (ensemble part alone, validate's own clock: {meta_full.get('ensemble_wall_s')} s for "
        f"{meta_full.get('ensemble_member_runs')} member runs)"
    )
    if ada is not None:
        _line("adaptive ensemble", ada, n_ada)
        print(f"   adaptive: {n_ada / len(tests):.2f} members per test on average (up to {a.members})")

    print("== against the goals (issue 23)")
    runs_goal = FULL_TESTS * FULL_MEMBERS
    proj = full["wall"] / n_full_runs * runs_goal / 60.0
    proj_cpu = full["cpu"] / n_full_runs * runs_goal / 2 / 60.0
    verdict = "met" if proj < GOAL_WALL_MIN else "NOT met"
    print(
        f"   {FULL_TESTS} tests × {FULL_MEMBERS} members on {a.workers} workers, projected wall "
        f"{proj:6.1f} min  goal < {GOAL_WALL_MIN:g} min  ratio {proj / GOAL_WALL_MIN:5.2f}  {verdict}"
    )
    print(
        f"   (from the CPU per run on 2 fully used cores: {proj_cpu:.1f} min; wall per run "
        f"{full['wall'] / n_full_runs:.3f} s scaled by {runs_goal} runs)"
    )
    if ada is not None:
        ratio = ada["wall"] / det["wall"]
        verdict = "met" if ratio <= GOAL_ADAPTIVE_RATIO else "NOT met"
        print(
            f"   adaptive P(topple) to ±{a.half_width:g} / deterministic, wall "
            f"{ratio:9.2f}      goal ≤ {GOAL_ADAPTIVE_RATIO:g}       ratio "
            f"{ratio / GOAL_ADAPTIVE_RATIO:5.2f}  {verdict}"
        )
        print(f"   (CPU ratio {ada['cpu'] / det['cpu']:.2f})")
    took = time.perf_counter() - t_start
    print(
        f"benchmark took {took / 60:.1f} min for {len(tests)} tests; all {n_full} tests would take about "
        f"{took / len(tests) * n_full / 60:.0f} min on this machine at this load"
    )
    print(f"load average at end {tuple(round(x, 2) for x in os.getloadavg())}")


if __name__ == "__main__":
    main()
