"""The engine test suite, public: :func:`check_engine` runs every conformance check that applies.

Like scikit-learn's ``check_estimator`` and xarray's shared backend tests, an engine adapter —
one of ours or a plugin registered under the ``pbr_xval.engines`` entry-point group — proves
itself with one call::

    from pbr_xval.testing import check_engine

    check_engine("myengine")                 # raises ConformanceError listing what failed
    results = check_engine("myengine", raise_on_failure=False)
    results["housner_threshold"].figures     # {"threshold": 5.6381, "reference": 5.638, ...}

The checks themselves (their references, tolerances and measured values) are in
:mod:`pbr_xval.conformance`. Which ones run depends on the engine's
:class:`~pbr_xval.engine.Capabilities` (shapes, determinism, ground-motion modes); each check
carries ``slow`` metadata (``fast_only=True`` runs the fast ones, for a quick loop while an
adapter is written). Known gaps are declared on the engine class as
``expected_failures = {check_name: reason}``; :func:`check_engine` merges the ones passed to
it over those, and reports a declared gap that no longer fails as ``"xpassed"`` — a failure,
so a closed gap is noticed (pytest's strict xfail).

Outcomes, per check: ``"passed"``, ``"failed"``, ``"xfailed"`` (failed as declared),
``"xpassed"`` (declared, but passed), ``"skipped"`` (does not apply; the reason is the
message).
"""

from __future__ import annotations

import enum
import time
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, cast

from pbr_xval import conformance
from pbr_xval.engine import get_engine

if TYPE_CHECKING:
    from pbr_xval.engine import Engine

__all__ = [
    "CheckOutcome",
    "CheckResult",
    "ConformanceError",
    "check_engine",
    "check_names",
    "conformance_cases",
    "run_case",
]


class CheckOutcome(enum.StrEnum):
    """What one conformance check did (a ``str`` enum: ``outcome == "passed"`` works)."""

    PASSED = "passed"
    FAILED = "failed"
    XFAILED = "xfailed"
    XPASSED = "xpassed"
    SKIPPED = "skipped"


@dataclass(frozen=True)
class CheckResult:
    """The outcome of one check on one engine.

    Attributes
    ----------
    name : the check's name (a key of :data:`pbr_xval.conformance.CHECKS`).
    outcome : :class:`CheckOutcome`.
    message : the assertion message of a failure, the declared reason of an expected failure,
        or why the check was skipped; empty when it passed.
    figures : the measured figures the check returned (SI units; keys name them), empty if
        it did not complete.
    seconds : wall-clock time of the check, s.
    slow : the check's ``slow`` metadata.
    """

    name: str
    outcome: CheckOutcome
    message: str = ""
    figures: Mapping[str, Any] = field(default_factory=dict)
    seconds: float = 0.0
    slow: bool = False

    @property
    def ok(self) -> bool:
        """Passed, skipped, or failed as declared."""
        return self.outcome in (CheckOutcome.PASSED, CheckOutcome.XFAILED, CheckOutcome.SKIPPED)


class ConformanceError(AssertionError):
    """An engine failed conformance checks; ``results`` holds every check's :class:`CheckResult`."""

    def __init__(self, engine: str, results: Mapping[str, CheckResult]) -> None:
        self.results = dict(results)
        bad = [r for r in results.values() if not r.ok]
        lines = [f"engine {engine!r}: {len(bad)} of {len(results)} conformance checks failed"]
        for r in bad:
            what = "passed, but is declared as an expected failure" if r.outcome == "xpassed" else r.message
            lines.append(f"  {r.name}: {what}")
        super().__init__("\n".join(lines))


def check_names(*, fast_only: bool = False) -> list[str]:
    """Names of the registered conformance checks (the fast ones only if ``fast_only``)."""
    return [n for n, c in conformance.CHECKS.items() if not (fast_only and c.slow)]


def _engine_label(engine: str | type | Engine) -> str:
    if isinstance(engine, str):
        return engine
    return str(getattr(engine, "name", "") or getattr(engine, "__name__", type(engine).__name__))


def _declared_gaps(eng: Engine) -> dict[str, str]:
    return dict(getattr(eng, "expected_failures", None) or {})


def check_engine(
    engine: str | type | Engine,
    expected_failures: Mapping[str, str] | None = None,
    *,
    fast_only: bool = False,
    checks: Iterable[str] | None = None,
    raise_on_failure: bool = True,
) -> dict[str, CheckResult]:
    """Run every conformance check that applies to ``engine``; one result per check.

    Parameters
    ----------
    engine : str, Engine class or instance
        A registered engine name (``"mujoco"``), or an engine class/instance that is not
        registered (its checks then run on it directly).
    expected_failures : mapping of check name -> reason, optional
        Known gaps, merged over the engine class's own ``expected_failures``. A listed check
        that fails is ``"xfailed"``; one that passes is ``"xpassed"`` (a failure).
    fast_only : bool
        Run only the checks not marked ``slow``; the others are reported as skipped.
    checks : iterable of str, optional
        Run only these checks (names of :data:`pbr_xval.conformance.CHECKS`).
    raise_on_failure : bool
        Raise :class:`ConformanceError` (an ``AssertionError``) naming every failed or
        xpassed check after all checks ran; with False, just return the results.

    Returns
    -------
    dict of str -> CheckResult
        In the order of :data:`pbr_xval.conformance.CHECKS`.

    Raises
    ------
    KeyError
        ``checks`` or ``expected_failures`` names a check that does not exist.
    pbr_xval.engine.EngineNotAvailable
        The engine is not registered or its package is missing (with an install hint).
    ConformanceError
        Some check failed (only with ``raise_on_failure``).
    """
    eng = get_engine(engine)
    label = _engine_label(engine)
    gaps = _declared_gaps(eng) | dict(expected_failures or {})
    wanted = list(conformance.CHECKS) if checks is None else list(checks)
    unknown = sorted((set(wanted) | set(gaps)) - set(conformance.CHECKS))
    if unknown:
        raise KeyError(f"unknown conformance checks {unknown}; expected some of {sorted(conformance.CHECKS)}")
    # the check functions call get_engine, which passes an engine object through unchanged,
    # so an unregistered engine is checked by handing them the object instead of a name
    target = engine if isinstance(engine, str) else cast(str, eng)
    results: dict[str, CheckResult] = {}
    for name in wanted:
        check = conformance.CHECKS[name]
        why = conformance.applicable(target, check)
        if why is None and fast_only and check.slow:
            why = "slow check (fast_only=True)"
        if why is not None:
            results[name] = CheckResult(name, CheckOutcome.SKIPPED, why, slow=check.slow)
            continue
        t0 = time.perf_counter()
        try:
            figures = check.func(target)
        except AssertionError as exc:
            dt = time.perf_counter() - t0
            if name in gaps:
                results[name] = CheckResult(
                    name, CheckOutcome.XFAILED, gaps[name], seconds=dt, slow=check.slow
                )
            else:
                results[name] = CheckResult(name, CheckOutcome.FAILED, str(exc), seconds=dt, slow=check.slow)
            continue
        dt = time.perf_counter() - t0
        outcome = CheckOutcome.XPASSED if name in gaps else CheckOutcome.PASSED
        results[name] = CheckResult(name, outcome, gaps.get(name, ""), dict(figures), dt, check.slow)
    if raise_on_failure and not all(r.ok for r in results.values()):
        raise ConformanceError(label, results)
    return results


def conformance_cases(engines: Iterable[str] | None = None, *, fast_only: bool = False) -> list[Any]:
    """``pytest.param(engine, check, id="engine-check", marks=…)`` for every engine × check.

    For a plugin's own test suite (``@pytest.mark.parametrize(("engine", "check"),
    conformance_cases(["myengine"]))``) and ``tests/conformance/``: ids are selectable with
    ``-k`` (``-k "mujoco and threshold"``). No pytest mark is added: the project's ``slow``
    mark only labels tests over ~10 s (they run in CI like every other test, and CI runs every
    check); ``fast_only`` leaves the slow checks out, for a quick local loop. Engines default to every registered one. Run a case with :func:`run_case`.
    """
    import pytest

    from pbr_xval.registry import registered_names

    out = []
    for engine in registered_names() if engines is None else engines:
        for name in check_names(fast_only=fast_only):
            out.append(pytest.param(engine, name, id=f"{engine}-{name}"))
    return out


def run_case(engine: str | type | Engine, check: str) -> Mapping[str, Any]:
    """Run one check under pytest: skip when it does not apply (or the engine is missing),
    strict xfail for a gap declared on the engine class; returns the check's figures."""
    import pytest

    from pbr_xval.engine import EngineNotAvailable

    try:
        eng = get_engine(engine)
    except EngineNotAvailable as exc:
        pytest.skip(str(exc))
    target = engine if isinstance(engine, str) else cast(str, eng)  # see check_engine
    c = conformance.CHECKS[check]
    why = conformance.applicable(target, c)
    if why:
        pytest.skip(why)
    gaps = _declared_gaps(eng)
    if check not in gaps:
        return c.func(target)
    try:
        c.func(target)
    except AssertionError as exc:
        pytest.xfail(f"{gaps[check]} ({exc})")
    pytest.fail(f"{check} passed, but is declared as an expected failure of the engine: {gaps[check]}")
