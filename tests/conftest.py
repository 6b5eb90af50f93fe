"""Shared pytest configuration.

Every test runs by default, in CI too. Two markers:

* ``slow`` — a label for tests that take more than ~10 s; they still run. Deselect them for a
  quick local loop with ``pytest -m "not slow"``.
* ``optional_study`` — an optional long study that guards no claim made in the README or the
  docs; it runs only with ``PBR_XVAL_SLOW=1`` (docs/ci_regression.md lists them).

The tests that read ``../shared/data`` (the real scans and shake-table campaigns; they guard
the F1 and α figures of docs/validation.md) skip when it is absent — except with ``CI=true``,
where such a skip is a failure: a CI whose data path is broken must not pass with those claims
unguarded. ``PBR_XVAL_SHARED_DATA`` points the validation tests at another data folder.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import pytest

SHARED_DATA = Path(
    os.environ.get("PBR_XVAL_SHARED_DATA") or Path(__file__).resolve().parents[1].parent / "shared" / "data"
)
SCANS = SHARED_DATA / "scans"

#: skip reasons that mean "the shared data (or what is derived from it) is not there"
SHARED_DATA_SKIP = re.compile(
    r"shared[ -](shake-table |scan )?data|scans? not found|shake-table data|mesh not reconstructed|make_sp2_mesh",
    re.IGNORECASE,
)


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item: pytest.Item, call: pytest.CallInfo[None]):  # type: ignore[no-untyped-def]
    """With CI=true, a test skipped for want of ../shared/data fails instead."""
    outcome = yield
    rep = outcome.get_result()
    if not rep.skipped or hasattr(rep, "wasxfail") or os.environ.get("CI", "").lower() != "true":
        return
    reason = rep.longrepr[2] if isinstance(rep.longrepr, tuple) else str(rep.longrepr)
    reason = reason.removeprefix("Skipped: ")
    if SHARED_DATA_SKIP.search(reason):
        rep.outcome = "failed"
        rep.longrepr = (
            f"CI=true and this test would skip: {reason}. The tests that guard the documented figures "
            f"need the shared data ({SHARED_DATA}); CI must provide it."
        )


def pytest_sessionstart(session: pytest.Session) -> None:
    """Reconstruct SP2's mesh from its point cloud when the shared data is there and the mesh is not.

    ``examples/validation/sp2.rock.obj`` is derived from ``scans/SP2_points.ply`` and never committed
    (``examples/validation/make_sp2_mesh.py``, 2 s, deterministic); building it here lets the README's
    plain ``pytest`` on a fresh clone run the SP2 guards instead of skipping them.
    """
    import runpy

    if os.environ.get("PYTEST_XDIST_WORKER"):
        return  # the controller (pytest -n N) built it before starting its workers
    script = Path(__file__).resolve().parents[1] / "examples" / "validation" / "make_sp2_mesh.py"
    if (
        not script.is_file()
        or (script.parent / "sp2.rock.obj").is_file()
        or not (SCANS / "SP2_points.ply").is_file()
    ):
        return
    if runpy.run_path(str(script))["main"](SCANS / "SP2_points.ply") != 0:
        raise pytest.UsageError(f"could not reconstruct SP2's mesh from {SCANS / 'SP2_points.ply'}")


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    if os.environ.get("PBR_XVAL_SLOW") == "1" or "optional_study" in (config.getoption("-m") or ""):
        return
    skip = pytest.mark.skip(reason="optional long study (guards no claim): set PBR_XVAL_SLOW=1 to run")
    for item in items:
        if "optional_study" in item.keywords:
            item.add_marker(skip)


@pytest.fixture(autouse=True)
def _close_figures():
    """Close every matplotlib figure a test leaves open (studies return figures to their callers)."""
    yield
    import sys

    if "matplotlib.pyplot" in sys.modules:
        sys.modules["matplotlib.pyplot"].close("all")
