"""Shared by the reference solver's tests: a shake-table test of SP1 as ``validate`` builds its scene,
and the comparison of two runs that must be the same bit for bit."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from pbr_xval.reference.adapter import TIMING_DIAGNOSTICS

REPO = Path(__file__).resolve().parents[2]
#: ../shared/data beside the checkout, or PBR_XVAL_SHARED_DATA (tests/conftest.py: with CI=true a
#: test skipped for want of it fails)
SHAKE_TABLE = Path(os.environ.get("PBR_XVAL_SHARED_DATA") or REPO.parent / "shared" / "data") / "shake_table"


def sp1_test_scene(test: str) -> Any:
    """The compiled scene of SP1's shake-table test ``test`` (its corrected table record,
    ``examples/validation/sp1.toml``), as ``pbr-xval validate`` builds it; skips without the
    shared data."""
    from pbr_xval.catalog.tasks import scenario_dict
    from pbr_xval.scenario import load_scenario, scenario_from_dict
    from pbr_xval.scene import compile_scene
    from pbr_xval.validation.campaign import Baseline, load_campaign
    from pbr_xval.validation.execution import build_validation_chunks, prepare_motions

    if not (SHAKE_TABLE / "experiments.csv").is_file():
        pytest.skip("the shared shake-table data is not beside the checkout")
    camp = load_campaign(SHAKE_TABLE, 1).select([test])
    scn = load_scenario(REPO / "examples" / "validation" / "sp1.toml")
    with tempfile.TemporaryDirectory() as tmp:
        motions = prepare_motions(camp, Baseline(), Path(tmp))
        (chunk,) = build_validation_chunks(camp, motions, scn, ["reference"])
        m = chunk.motions[0]
        return compile_scene(scenario_from_dict(scenario_dict(chunk, m, chunk.rock["friction_min"], 1)))


def assert_same_run(a: Any, b: Any) -> None:
    """Two trajectories are the same run bit for bit: status, outcome, samples, events (kind and
    time) and every diagnostic but the timings."""
    assert a.status == b.status and a.toppled == b.toppled
    for name in ("t", "com", "quat", "omega"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    assert [(e.kind, e.t) for e in a.events] == [(e.kind, e.t) for e in b.events]
    da = {k: v for k, v in a.diagnostics.items() if k not in TIMING_DIAGNOSTICS}
    db = {k: v for k, v in b.diagnostics.items() if k not in TIMING_DIAGNOSTICS}
    assert da == db
