"""Every registered engine through the shared analytical cases (pbr_xval.conformance).

Known gaps are declared on the engine class as ``expected_failures = {check: reason}`` and
run as strict xfail, so a gap that closes is noticed. Engines whose package is missing skip.
Every case runs in CI (none is gated behind PBR_XVAL_SLOW).
"""

from __future__ import annotations

import os

import pytest

from pbr_xval import conformance
from pbr_xval.engine import EngineNotAvailable, get_engine, registered_names


def _cases():
    for engine in registered_names():
        for name in conformance.CHECKS:
            yield pytest.param(engine, name, id=f"{engine}-{name}")


@pytest.mark.parametrize(("engine", "check"), list(_cases()))
def test_conformance(engine: str, check: str, request: pytest.FixtureRequest) -> None:
    try:
        eng = get_engine(engine)
    except EngineNotAvailable as exc:
        pytest.skip(str(exc))
    c = conformance.CHECKS[check]
    why = conformance.applicable(engine, c)
    if why:
        pytest.skip(why)
    gaps = getattr(eng, "expected_failures", {}) or {}
    if check in gaps:
        request.applymarker(pytest.mark.xfail(reason=gaps[check], strict=True, raises=AssertionError))
    out = c.func(engine)
    if os.environ.get("PBR_XVAL_VERBOSE"):
        print(engine, check, out)
