"""Provenance: the reference solver names the compiler of its kernel (numba, llvmlite) in its
versions, hence in ``pbr-xval engines`` and in every result it produces."""

from __future__ import annotations

import llvmlite
import numba
import numpy as np

from pbr_xval import conformance as conf
from pbr_xval.engine import get_engine
from pbr_xval.runner import run_scene
from pbr_xval.scene import compile_scene
from pbr_xval.version import __version__

EXPECTED = {
    "pbr_xval": __version__,
    "numpy": np.__version__,
    "numba": numba.__version__,
    "llvmlite": llvmlite.__version__,
}


def test_reference_versions_name_the_kernel_compiler() -> None:
    assert get_engine("reference").versions() == EXPECTED


def test_every_reference_result_carries_numba_and_llvmlite() -> None:
    scene = compile_scene(conf.housner_scenario(duration=0.05, settle_time=0.0))
    traj = run_scene(scene, "reference")
    assert traj.settings["compiled"] is True  # the kernel these versions compiled
    assert {k: traj.versions[k] for k in EXPECTED} == EXPECTED
