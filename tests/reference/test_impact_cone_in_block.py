"""Impacts whose cone needs the iterative solver, resolved inside the compiled blocks (issue 23,
fifteenth pass of ``reference/PERFORMANCE.md``).

On a scanned rock most eq. 3.5 impacts are sliding ones whose active-set guess fails
(``kernel.IMPACT_CONE``); they used to end the compiled block and go through Python
(``cone.solve_friction_cone``), ~0.5 ms each. The blocks now run the cone solver's first sweeps
(``cone.cone_first_sweeps``: up to its first contact-mode polish) and eq. 3.5 on the normal
impulses (``kernel.impact_cone_normals``) themselves, and hand back only what does not converge
there.

Reference: the step-by-step loop (``BLOCK_STEPS = 0``, which resolves every impact in Python):
the same run bit for bit on a shake-table test of SP1 with dozens of such impacts. The compiled
pieces against the general solver and LAPACK: ``tests/reference/test_impact_kernel.py``.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np
import pytest

from pbr_xval.reference import kernel
from pbr_xval.runner import run_scene
from pbr_xval.scene import compile_scene

ROOT = Path(__file__).resolve().parents[2]
SHAKE_TABLE = ROOT.parent / "shared" / "data" / "shake_table"


def _sp1_test_scene(test: str):
    from pbr_xval.catalog.tasks import scenario_dict
    from pbr_xval.scenario import load_scenario, scenario_from_dict
    from pbr_xval.validation.campaign import Baseline, load_campaign
    from pbr_xval.validation.execution import build_validation_chunks, prepare_motions

    camp = load_campaign(SHAKE_TABLE, 1).select([test])
    scn = load_scenario(ROOT / "examples" / "validation" / "sp1.toml")
    with tempfile.TemporaryDirectory() as tmp:
        motions = prepare_motions(camp, Baseline(), Path(tmp))
        (chunk,) = build_validation_chunks(camp, motions, scn, ["reference"])
        m = chunk.motions[0]
        return compile_scene(scenario_from_dict(scenario_dict(chunk, m, chunk.rock["friction_min"], 1)))


def test_block_cone_impacts_equal_the_step_by_step_loop(monkeypatch) -> None:
    """SP1 test 632 (the rock rocks for ~16 s and stands, ~50 impacts; a robust outcome in the
    reference's guard file): the blocks resolve many cone impacts themselves — 25 with OpenBLAS's
    Haswell and SkylakeX kernels, 19 with the AVX-only Sandybridge ones (measured on a Zen 5) —
    and the run is the step-by-step loop's bit for bit: samples, events and every diagnostic but
    the timings."""
    if not (SHAKE_TABLE / "experiments.csv").is_file():
        pytest.skip("the shared shake-table data is not beside the checkout")
    from pbr_xval.reference import adapter as ref_engine
    from pbr_xval.reference import dynamics
    from pbr_xval.reference.adapter import TIMING_DIAGNOSTICS

    sweeps: list[float] = []
    info = dynamics.RigidBodySolver._block_impact_info
    monkeypatch.setattr(
        dynamics.RigidBodySolver,
        "_block_impact_info",
        lambda self, row: sweeps.append(float(row[kernel.J_SWEEPS])) or info(self, row),
    )
    scene = _sp1_test_scene("632")
    blocked = run_scene(scene, "reference")
    in_block = sum(s > 0 for s in sweeps)
    assert in_block >= 10, f"{in_block} cone impacts resolved in the blocks"
    monkeypatch.setattr(ref_engine, "BLOCK_STEPS", 0)
    single = run_scene(scene, "reference")
    assert blocked.status == single.status and blocked.toppled == single.toppled
    for name in ("t", "com", "quat", "omega"):
        np.testing.assert_array_equal(getattr(blocked, name), getattr(single, name))
    # the events too: the step-by-step loop records the step of the first uplift
    # (Recorder.uplift_due), as the blocks do; before, it dated the uplift at the output sample
    # after it (here 0.810 s against 0.807 s)
    assert [(e.kind, e.t) for e in blocked.events] == [(e.kind, e.t) for e in single.events]
    db = {k: v for k, v in blocked.diagnostics.items() if k not in TIMING_DIAGNOSTICS}
    ds = {k: v for k, v in single.diagnostics.items() if k not in TIMING_DIAGNOSTICS}
    assert db == ds
    assert db["pgs_sweeps"] >= sum(sweeps) > 0  # the blocks' sweeps are counted
