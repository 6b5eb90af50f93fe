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

from pbr_xval.reference import kernel
from pbr_xval.runner import run_scene

from .conftest import assert_same_run, sp1_test_scene


def test_block_cone_impacts_equal_the_step_by_step_loop(monkeypatch) -> None:
    """SP1 test 632 (the rock rocks for ~16 s and stands, ~50 impacts; a robust outcome in the
    reference's guard file): the blocks resolve many cone impacts themselves — 25 with OpenBLAS's
    Haswell and SkylakeX kernels, 19 with the AVX-only Sandybridge ones (measured on a Zen 5) —
    and the run is the step-by-step loop's bit for bit: samples, events and every diagnostic but
    the timings."""
    from pbr_xval.reference import adapter as ref_engine
    from pbr_xval.reference import dynamics

    sweeps: list[float] = []
    info = dynamics.RigidBodySolver._block_impact_info
    monkeypatch.setattr(
        dynamics.RigidBodySolver,
        "_block_impact_info",
        lambda self, row: sweeps.append(float(row[kernel.J_SWEEPS])) or info(self, row),
    )
    scene = sp1_test_scene("632")
    blocked = run_scene(scene, "reference")
    in_block = sum(s > 0 for s in sweeps)
    assert in_block >= 10, f"{in_block} cone impacts resolved in the blocks"
    monkeypatch.setattr(ref_engine, "BLOCK_STEPS", 0)
    single = run_scene(scene, "reference")
    # the events too: the step-by-step loop records the step of the first uplift
    # (Recorder.uplift_due), as the blocks do; before, it dated the uplift at the output sample
    # after it (here 0.810 s against 0.807 s)
    assert_same_run(blocked, single)
    assert blocked.diagnostics["pgs_sweeps"] >= sum(sweeps) > 0  # the blocks' sweeps are counted
