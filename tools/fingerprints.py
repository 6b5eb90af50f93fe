"""Fingerprints of a fixed set of short runs, to check that a refactoring is bit-identical.

Each run simulates one scenario on one engine and records ``Trajectory.fingerprint()`` (a
SHA-256 of the sampled arrays and the events) together with a digest of the standard
diagnostics. The set covers the Housner block, the notched block and the curved-base block under
pulses, the synthetic scanned rock (``examples/rocks/synthetic_pbr.obj``) and, when its scan is
present, the SP1 scan; on the analytical engines (``housner``, ``curved_base``), the reference
solver and the MuJoCo, PyBullet and DART adapters. Durations are short: the whole set takes
about a minute on one core.

Usage::

    python tools/fingerprints.py --out /tmp/fp_before.json          # compute and save
    python tools/fingerprints.py --compare /tmp/fp_before.json      # compute and compare
    python tools/fingerprints.py --compare A.json --against B.json  # compare two saved files
    python tools/fingerprints.py --only reference --out ref.json     # one engine only

``--compare`` exits with status 1 when a run's fingerprint differs (or a run is missing).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
SP1 = ROOT.parent / "shared" / "data" / "scans" / "SP1_mesh.obj"

_FRICTION = {"friction_static": 2.0, "friction_dynamic": 2.0, "restitution": 0.0}


def _housner(amplitude: float, *, criterion: str = "physical", duration: float = 2.0) -> dict[str, Any]:
    return {
        "name": "fp_housner",
        "gravity": 9.81,
        "duration": duration,
        "settle_time": 0.2,
        "output_dt": 0.005,
        "rock": {"shape": "box", "half_extents": [0.2, 0.2, 0.6], "density": 2400.0},
        "pedestal": {"kind": "plane"},
        "contact": dict(_FRICTION),
        "excitation": {
            "type": "half_sine",
            "amplitude": amplitude,
            "frequency": 1.0,
            "phase": "housner_uplift",
            "azimuth_deg": 0.0,
        },
        "toppling": {"criterion": criterion},
    }


def _notched(amplitude: float) -> dict[str, Any]:
    d = _housner(amplitude)
    d["name"] = "fp_notched"
    d["rock"] = {
        "shape": "notched_block",
        "half_extents": [0.2, 0.2, 0.6],
        "notch_width": 0.2,
        "notch_height": 0.3,
        "density": 2400.0,
    }
    return d


def _curved(amplitude: float, pulse: str = "one_sine") -> dict[str, Any]:
    return {
        "name": "fp_curved",
        "gravity": 9.81,
        "duration": 2.0,
        "settle_time": 0.2,
        "output_dt": 0.005,
        "rock": {"shape": "curved_base", "H": 1.0, "r": 0.1, "h": 0.3, "depth": 0.4, "density": 2400.0},
        "pedestal": {"kind": "plane"},
        "contact": dict(_FRICTION),
        "excitation": {"type": pulse, "amplitude": amplitude, "frequency": 1.5, "azimuth_deg": 0.0},
        "toppling": {"criterion": "physical"},
    }


def _mesh(
    path: Path, amplitude: float, *, mass: float | None = None, duration: float = 1.5
) -> dict[str, Any]:
    rock: dict[str, Any] = {"shape": "mesh", "path": str(path), "units": "m", "pose": "settle"}
    if mass is None:
        rock["density"] = 2600.0
    else:
        rock["mass"] = mass
    return {
        "name": f"fp_{path.stem}",
        "gravity": 9.81,
        "duration": duration,
        "output_dt": 0.005,
        "rock": rock,
        "pedestal": {"kind": "plane"},
        "excitation": {"type": "one_sine", "amplitude": amplitude, "frequency": 1.0, "azimuth_deg": 30.0},
    }


def cases() -> list[tuple[str, str, dict[str, Any]]]:
    """(case id, engine, scenario dict) for every run of the fixed set."""
    out: list[tuple[str, str, dict[str, Any]]] = []
    sim = ("reference", "mujoco", "pybullet", "dart")
    for a in (4.0, 5.7, 7.0):
        for eng in ("housner", *sim):
            out.append((f"housner_a{a}", eng, _housner(a)))
    for eng in ("housner", "mujoco", "pybullet"):
        out.append(("housner_a6.0_critical_tilt", eng, _housner(6.0, criterion="critical_tilt")))
    for eng in ("housner", "mujoco", "dart"):
        out.append(("notched_a5.5", eng, _notched(5.5)))
    for a in (2.0, 4.0):
        for eng in ("curved_base", *sim):
            out.append((f"curved_one_sine_a{a}", eng, _curved(a)))
    out.append(("curved_half_sine_a3.0", "curved_base", _curved(3.0, "half_sine")))
    for eng in sim:
        out.append(("synthetic_pbr_a5.2", eng, _mesh(EXAMPLES / "rocks" / "synthetic_pbr.obj", 5.2)))
    if SP1.is_file():
        for eng in ("mujoco", "pybullet"):
            out.append(("sp1_scan_a5.2", eng, _mesh(SP1, 5.2, mass=353.8, duration=1.0)))
    return out


def _diag_digest(diagnostics: dict[str, Any]) -> str:
    from pbr_xval.jsonio import jsonable

    # timings (wall_s, cpu_s, lcp_time_s, ...) differ from run to run
    keep = {k: v for k, v in diagnostics.items() if not any(w in k for w in ("time", "wall", "cpu"))}
    return hashlib.sha256(json.dumps(jsonable(keep), sort_keys=True, default=str).encode()).hexdigest()


def compute(only: set[str] | None = None) -> dict[str, dict[str, Any]]:
    """Run the set; ``{"<case>/<engine>": {fingerprint, diagnostics, status, toppled, wall}}``."""
    import pbr_xval
    from pbr_xval.runner import run_scenario
    from pbr_xval.scenario import scenario_from_dict

    print(f"pbr_xval from {Path(pbr_xval.__file__).parent}", file=sys.stderr)
    out: dict[str, dict[str, Any]] = {}
    for case, eng, data in cases():
        if only and eng not in only:
            continue
        key = f"{case}/{eng}"
        t0 = time.perf_counter()
        traj = run_scenario(scenario_from_dict(json.loads(json.dumps(data))), eng)
        wall = time.perf_counter() - t0
        out[key] = {
            "fingerprint": traj.fingerprint(),
            "diagnostics": _diag_digest(traj.diagnostics),
            "status": str(traj.status),
            "toppled": traj.toppled,
            "samples": int(traj.t.size),
            "wall_s": round(wall, 3),
        }
        print(f"{key:44s} {traj.fingerprint()[:16]} {traj.status!s:6s} {wall:6.2f} s", file=sys.stderr)
    return out


def compare(before: dict[str, dict[str, Any]], after: dict[str, dict[str, Any]]) -> int:
    """Print the differences; the number of runs that differ or are missing."""
    bad = 0
    for key in sorted(set(before) | set(after)):
        b, a = before.get(key), after.get(key)
        if b is None or a is None:
            print(f"MISSING  {key} ({'before' if b is None else 'after'})")
            bad += 1
            continue
        diffs = [f for f in ("fingerprint", "diagnostics", "status", "toppled", "samples") if b[f] != a[f]]
        if diffs:
            print(f"DIFFERS  {key}: {', '.join(diffs)}")
            bad += 1
    n = len(set(before) | set(after))
    print(f"{n - bad}/{n} runs identical")
    return bad


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--out", type=Path, help="write the fingerprints as JSON here")
    p.add_argument("--compare", type=Path, help="compare with this saved JSON (exit 1 on a difference)")
    p.add_argument("--against", type=Path, help="with --compare: compare two files, run nothing")
    p.add_argument("--only", action="append", help="run only this engine (repeatable)")
    args = p.parse_args(argv)
    if args.against is not None:
        if args.compare is None:
            p.error("--against needs --compare")
        before = json.loads(args.compare.read_text())
        return 1 if compare(before, json.loads(args.against.read_text())) else 0
    result = compute(set(args.only) if args.only else None)
    if args.out is not None:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps(result, indent=1, sort_keys=True) + "\n")
    if args.compare is not None:
        before = json.loads(args.compare.read_text())
        if args.only:
            before = {k: v for k, v in before.items() if k.split("/")[-1] in set(args.only)}
        return 1 if compare(before, result) else 0
    if args.out is None:
        print(json.dumps(result, indent=1, sort_keys=True))
    return 0


if __name__ == "__main__":
    sys.exit(main())
