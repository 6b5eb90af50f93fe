"""docs/adding_an_engine.md, followed: the example adapter (fake_engine.py) is registered through an
entry point, exactly as a plugin's ``pyproject.toml`` would register it, and passes the suite
with one :func:`pbr_xval.testing.check_engine` call. The same file tests check_engine's own
bookkeeping (expected failures, xpassed gaps, fast_only, skips, unknown names)."""

from __future__ import annotations

import dataclasses
import importlib.metadata
from pathlib import Path
from typing import ClassVar

import pytest

from pbr_xval import conformance, testing
from pbr_xval.engine import get_engine, refresh_engines, registered_names

HERE = Path(__file__).resolve().parent
TARGET = "fake_engine:PlanarRockingEngine"


@pytest.fixture
def plugin(monkeypatch: pytest.MonkeyPatch) -> str:
    """Register ``planar_rocking`` as an installed plugin would: an entry point in the
    ``pbr_xval.engines`` group, its module importable from sys.path."""
    monkeypatch.syspath_prepend(str(HERE))
    real = importlib.metadata.entry_points
    ep = importlib.metadata.EntryPoint("planar_rocking", TARGET, "pbr_xval.engines")

    def entry_points(**params):  # type: ignore[no-untyped-def]
        eps = real(**params)
        if params.get("group") == "pbr_xval.engines":
            return importlib.metadata.EntryPoints([*eps, ep])
        return eps

    monkeypatch.setattr(importlib.metadata, "entry_points", entry_points)
    refresh_engines()
    yield "planar_rocking"
    monkeypatch.undo()
    refresh_engines()


def test_plugin_is_registered(plugin: str) -> None:
    assert plugin in registered_names()
    eng = get_engine(plugin)
    assert type(eng).__name__ == "PlanarRockingEngine" and eng.name == plugin


def test_example_adapter_passes_the_suite(plugin: str) -> None:
    """The document's one call. Every check that applies to a 2-D box/notched-block engine runs
    (all but ground_modes: one ground-motion mode) and passes against the independent references
    of pbr_xval.conformance (Housner 5.638 m/s², notched block 5.12410 m/s², rebound 0.850 and
    0.86645, the closed-form impact count)."""
    results = testing.check_engine(plugin)
    ran = {n for n, r in results.items() if r.outcome == "passed"}
    assert ran == set(conformance.CHECKS) - {"ground_modes"}
    assert results["ground_modes"].outcome == "skipped"
    assert "one ground-motion mode" in results["ground_modes"].message
    thr = results["housner_threshold"].figures
    assert abs(thr["rel_error"]) <= thr["allowed"]


def test_unregistered_class_can_be_checked(monkeypatch: pytest.MonkeyPatch) -> None:
    """Before writing the entry point, an adapter class is checked directly (fast checks)."""
    monkeypatch.syspath_prepend(str(HERE))
    from fake_engine import PlanarRockingEngine

    res = testing.check_engine(PlanarRockingEngine, fast_only=True)
    assert {n for n, r in res.items() if r.outcome == "passed"} == {"rest", "deterministic", "impacts"}
    assert all(res[n].outcome == "skipped" for n in testing.check_names() if conformance.CHECKS[n].slow)


def _weak_gravity_engine(monkeypatch: pytest.MonkeyPatch) -> type:
    """The example adapter with a typical adapter bug: gravity 10 % too weak (the block uplifts
    and topples under smaller pulses, so the Housner threshold check must fail)."""
    monkeypatch.syspath_prepend(str(HERE))
    from fake_engine import PlanarRockingEngine

    class WeakGravity(PlanarRockingEngine):
        def simulate(self, scene, settings=None):  # type: ignore[no-untyped-def]
            return super().simulate(dataclasses.replace(scene, gravity=0.9 * scene.gravity), settings)

    return WeakGravity


def test_a_wrong_engine_fails(monkeypatch: pytest.MonkeyPatch) -> None:
    eng = _weak_gravity_engine(monkeypatch)
    with pytest.raises(testing.ConformanceError, match=r"housner_threshold: .*toppled at") as info:
        testing.check_engine(eng, checks=["housner_threshold"])
    assert info.value.results["housner_threshold"].outcome == "failed"
    res = testing.check_engine(eng, checks=["housner_threshold"], raise_on_failure=False)
    assert res["housner_threshold"].outcome == "failed" and not res["housner_threshold"].ok


def test_expected_failure_is_xfailed(monkeypatch: pytest.MonkeyPatch) -> None:
    eng = _weak_gravity_engine(monkeypatch)
    res = testing.check_engine(
        eng, {"housner_threshold": "gravity is 10 % weak"}, checks=["housner_threshold"]
    )
    assert res["housner_threshold"].outcome == "xfailed"
    assert res["housner_threshold"].message == "gravity is 10 % weak"


def test_declared_gap_that_passes_is_reported(monkeypatch: pytest.MonkeyPatch) -> None:
    """A gap declared on the engine class that no longer fails is an error (strict xfail)."""
    monkeypatch.syspath_prepend(str(HERE))
    from fake_engine import PlanarRockingEngine

    class Declared(PlanarRockingEngine):
        expected_failures: ClassVar[dict[str, str]] = {"rest": "claimed to drift"}

    with pytest.raises(testing.ConformanceError, match="rest: passed, but is declared"):
        testing.check_engine(Declared, checks=["rest"])


def test_unknown_check_names(plugin: str) -> None:
    with pytest.raises(KeyError, match="restt"):
        testing.check_engine(plugin, checks=["restt"])
    with pytest.raises(KeyError, match="no_such_check"):
        testing.check_engine(plugin, {"no_such_check": "x"})


def test_fast_slow_metadata() -> None:
    """Every check carries fast/slow metadata; both kinds exist, and fast_only keeps the fast ones."""
    fast = set(testing.check_names(fast_only=True))
    assert fast == {n for n, c in conformance.CHECKS.items() if not c.slow}
    assert fast and fast != set(testing.check_names())


def test_cases_have_selectable_ids() -> None:
    ids = [p.id for p in testing.conformance_cases(["mujoco"])]
    assert ids == [f"mujoco-{n}" for n in conformance.CHECKS]
