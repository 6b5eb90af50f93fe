"""Re-measure the one-off figures of docs/toppling.md and docs/scenarios.md (not run in CI).

``one-cosine``: the band edges of the Housner block under a one-cosine pulse at 2 Hz (docs/toppling.md,
"The example that shows the difference"): per engine, the first-crossing edge (criterion
``critical_tilt``, searched in 17–40 m/s²) and the physical rule's return to toppling (mode 2,
searched in 40–70 m/s²), ``find_threshold`` with rel_tol 1e-3.

``alpha-noise``: how SP1's smallest critical tilt moves when every scan vertex gets Gaussian noise
of σ = 1 and 3 mm (5 draws each, seed 0; docs/scenarios.md, "critical tilt α(φ)"): the rock model is
rebuilt (mass 353.8 kg, pose settle) and α_min refined (``StabilityTable.minimum``).

Usage::

    nice -n 10 python tools/doc_one_offs.py one-cosine [--engine housner --engine dart --engine mujoco]
    nice -n 10 python tools/doc_one_offs.py alpha-noise [--scan ../shared/data/scans/SP1_mesh.obj]

Each line printed is one measurement; the machine and its load (``os.getloadavg``) come first.
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING, cast

import numpy as np

if TYPE_CHECKING:
    from pbr_xval.scenario import Scenario

ROOT = Path(__file__).resolve().parents[1]


def one_cosine(engines: list[str]) -> None:
    from pbr_xval.conformance import housner_scenario
    from pbr_xval.study.threshold_search import find_threshold

    def scn(criterion: str | None = None) -> Scenario:
        kw = {"toppling": {"criterion": criterion}} if criterion else {}
        return housner_scenario(
            duration=3.0, excitation={"type": "one_cosine", "amplitude": 12.0, "frequency": 2.0}, **kw
        )

    for engine in engines:
        first = find_threshold(scn("critical_tilt"), engine, lo=17.0, hi=40.0, rel_tol=1e-3)
        phys = find_threshold(scn(), engine, lo=40.0, hi=70.0, rel_tol=1e-3)
        print(
            f"{engine}: first crossing topples from {first.minimum:.4g} m/s²; "
            f"physical rule topples again from {phys.minimum:.4g} m/s² "
            f"({first.n_simulations} + {phys.n_simulations} simulations)",
            flush=True,
        )


def alpha_noise(scan: Path, sigmas: tuple[float, ...] = (0.001, 0.003), draws: int = 5) -> None:
    import trimesh

    from pbr_xval.geometry.rockmodel import build_rock_model

    src = cast(trimesh.Trimesh, trimesh.load(scan, force="mesh", process=False))
    v = np.asarray(src.vertices)
    rng = np.random.default_rng(0)
    with tempfile.TemporaryDirectory() as tmp:
        for sigma in sigmas:
            for k in range(draws):
                path = Path(tmp) / f"noisy_{k}.obj"
                trimesh.Trimesh(v + rng.normal(0.0, sigma, v.shape), src.faces, process=False).export(path)
                m = build_rock_model(path, mass=353.8, density=None, pose="settle", n_directions=72)
                a, phi = m.stability.minimum(step_deg=0.25)
                i = int(np.nanargmin(m.stability.alpha))
                print(
                    f"sigma {sigma * 1e3:g} mm, draw {k}: α_min {math.degrees(a):.2f}° at {math.degrees(phi):.1f}° "
                    f"(5° table: {math.degrees(m.stability.alpha[i]):.2f}° at {math.degrees(m.stability.phi[i]):.0f}°); "
                    f"α toward +x {math.degrees(m.stability.alpha[0]):.1f}°",
                    flush=True,
                )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="what", required=True)
    oc = sub.add_parser("one-cosine")
    oc.add_argument("--engine", action="append", default=None)
    an = sub.add_parser("alpha-noise")
    an.add_argument("--scan", type=Path, default=ROOT.parent / "shared" / "data" / "scans" / "SP1_mesh.obj")
    args = ap.parse_args()
    print(f"# {platform.processor() or platform.machine()}, {os.cpu_count()} CPUs, load {os.getloadavg()}")
    if args.what == "one-cosine":
        one_cosine(args.engine or ["housner", "dart", "mujoco"])
    else:
        alpha_noise(args.scan)


if __name__ == "__main__":
    main()
