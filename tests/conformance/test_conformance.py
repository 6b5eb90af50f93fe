"""Every registered engine through the shared analytical cases (pbr_xval.conformance).

Known gaps are declared on the engine class as ``expected_failures = {check: reason}`` and
run as strict xfail (:func:`pbr_xval.testing.run_case`), so a gap that closes is noticed. Engines whose package is missing skip.
Every case runs in CI (none is gated behind PBR_XVAL_SLOW).
"""

from __future__ import annotations

import os

import pytest

from pbr_xval.testing import conformance_cases, run_case


# ids "<engine>-<check>", e.g. -k "mujoco and notched"; the public runner of the same suite is
# pbr_xval.testing.check_engine (docs/adding_an_engine.md)
@pytest.mark.parametrize(("engine", "check"), conformance_cases())
def test_conformance(engine: str, check: str) -> None:
    out = run_case(engine, check)
    if os.environ.get("PBR_XVAL_VERBOSE"):
        print(engine, check, out)
