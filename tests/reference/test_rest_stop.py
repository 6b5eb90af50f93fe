"""``toppling.stop_at_rest`` in the reference's step-by-step loop (issue 23, fifth pass): the
loop records its rows with ``Recorder.record``, which does not apply the rest rule, so a run
without the compiled blocks (``adapter.BLOCK_STEPS = 0``) went on past the time at which the
rule stops the same run made by blocks (SP1 test 459: 21.73 s against 20.95 s, the same
trajectory until then). Each step's row now feeds the rest hold, whichever path made it."""

from __future__ import annotations

import numpy as np
import pytest

from pbr_xval import conformance as conf
from pbr_xval.reference import adapter
from pbr_xval.runner import run_scene
from pbr_xval.scene import compile_scene

_TIMING = ("wall", "cpu", "time")


def _scene():
    scn = conf.housner_scenario(
        duration=6.0,
        excitation={"type": "half_sine", "amplitude": 5.0, "frequency": 1.0, "phase": "housner_uplift"},
    )
    return compile_scene(scn.with_value("toppling.stop_at_rest", True))


def test_step_by_step_loop_stops_at_rest_as_the_blocks(monkeypatch: pytest.MonkeyPatch) -> None:
    scene = _scene()
    blocks = run_scene(scene, "reference")
    monkeypatch.setattr(adapter, "BLOCK_STEPS", 0)
    steps = run_scene(scene, "reference")
    d_b, d_s = blocks.diagnostics, steps.diagnostics
    # the rule stopped the run after the pulse (1 s), well before the end (6 s)
    assert d_b["stopped_at_rest"] and 1.0 < d_b["stopped_at_rest_s"] < 5.0
    assert d_s["stopped_at_rest"] and d_s["stopped_at_rest_s"] == d_b["stopped_at_rest_s"]
    for name in ("t", "com", "quat", "omega"):
        np.testing.assert_array_equal(getattr(steps, name), getattr(blocks, name))
    assert steps.toppled is blocks.toppled is False
    same = {k for k in d_b if not any(x in k for x in _TIMING)}
    assert {k: d_s[k] for k in same} == {k: d_b[k] for k in same}
