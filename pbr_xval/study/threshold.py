"""Toppling thresholds: coarse scan of a scalar scenario parameter, then bisection of every transition.

Overturning is not monotonic in amplitude (Zhang & Makris 2001: safe bands exist above the
first overturning level), so the search never assumes a single threshold: it scans a grid,
finds every change between "stands" and "topples", and bisects each to the tolerance. The
minimum toppling value is the upper end of the first bracket.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from pbr_xval.engine import Engine, get_engine
from pbr_xval.runner import effective_settings
from pbr_xval.scenario import Scenario
from pbr_xval.scene import compile_scene

__all__ = ["Band", "ThresholdResult", "find_threshold"]


@dataclass(frozen=True)
class Transition:
    """A bracketed change of outcome: at ``lo`` the rock ``below``, at ``hi`` it ``above``."""

    lo: float
    hi: float
    below_toppled: bool

    @property
    def value(self) -> float:
        return 0.5 * (self.lo + self.hi)

    @property
    def half_width(self) -> float:
        return 0.5 * (self.hi - self.lo)


@dataclass(frozen=True)
class Band:
    """An interval of the parameter in which the rock topples (ends are bracket midpoints)."""

    start: float
    end: float | None  # None: still toppling at the top of the scanned range
    start_tol: float
    end_tol: float | None


@dataclass
class ThresholdResult:
    """Outcome of a threshold search.

    Attributes
    ----------
    param : dotted scenario key searched.
    engine : engine name; settings : the complete settings used.
    grid, grid_toppled : the coarse scan.
    transitions : every bracketed transition, bisected to ``rel_tol``.
    n_simulations : simulations spent in total.
    """

    param: str
    engine: str
    settings: dict[str, Any]
    grid: np.ndarray
    grid_toppled: np.ndarray
    transitions: list[Transition]
    rel_tol: float
    n_simulations: int
    versions: dict[str, str] = field(default_factory=dict)
    scenario_hash: str = ""
    wall_time: float = 0.0
    #: largest tilt (rad) seen in any simulation of the search (0: the rock never rocked)
    max_tilt: float = 0.0

    @property
    def minimum(self) -> float | None:
        """Smallest toppling value (midpoint of the first stand→topple bracket), or None."""
        if self.grid_toppled.size and self.grid_toppled[0]:
            return float(self.grid[0])
        for tr in self.transitions:
            if not tr.below_toppled:
                return tr.value
        return None

    @property
    def tolerance(self) -> float | None:
        """± half-width of the bracket of :attr:`minimum` (same units as the parameter)."""
        for tr in self.transitions:
            if not tr.below_toppled:
                return tr.half_width
        return None

    def bands(self) -> list[Band]:
        """Every toppling band found in the scanned range."""
        out: list[Band] = []
        start: tuple[float, float] | None = None
        if self.grid_toppled.size and self.grid_toppled[0]:
            start = (float(self.grid[0]), 0.0)
        for tr in self.transitions:
            if not tr.below_toppled:
                start = (tr.value, tr.half_width)
            elif start is not None:
                out.append(Band(start[0], tr.value, start[1], tr.half_width))
                start = None
        if start is not None:
            out.append(Band(start[0], None, start[1], None))
        return out

    def to_dict(self) -> dict[str, Any]:
        return {
            "param": self.param,
            "engine": self.engine,
            "minimum": self.minimum,
            "tolerance": self.tolerance,
            "rel_tol": self.rel_tol,
            "bands": [b.__dict__ for b in self.bands()],
            "n_simulations": self.n_simulations,
            "settings": self.settings,
            "versions": self.versions,
            "scenario_hash": self.scenario_hash,
            "wall_time": self.wall_time,
            "max_tilt_rad": self.max_tilt,
        }


def find_threshold(
    scenario: Scenario,
    engine: str | Engine,
    param: str = "excitation.amplitude",
    *,
    lo: float | None = None,
    hi: float | None = None,
    n_grid: int = 16,
    rel_tol: float = 1e-4,
    settings: Mapping[str, Any] | None = None,
    all_transitions: bool = True,
    progress: Callable[[int, float, bool], None] | None = None,
) -> ThresholdResult:
    """Scan ``param`` on a geometric grid in [lo, hi], then bisect every transition.

    Parameters
    ----------
    lo, hi : scan range (parameter units). Default: 0.5× and 2× the scenario's current value.
    n_grid : coarse grid points (geometric spacing).
    rel_tol : bisection stops when (hi − lo) ≤ rel_tol × hi of each bracket; the reported
        tolerance is the bracket half-width.
    all_transitions : False bisects only the first stand→topple transition (the minimum).
    progress : called after each simulation with (count, value, toppled).
    """
    import time

    eng = get_engine(engine)
    v0 = float(scenario.get_value(param))
    lo = 0.5 * v0 if lo is None else float(lo)
    hi = 2.0 * v0 if hi is None else float(hi)
    if not (0 < lo < hi):
        raise ValueError(f"threshold search needs 0 < lo < hi, got lo={lo}, hi={hi}")
    count = 0
    max_tilt = [0.0]
    used_settings: dict[str, Any] = {}
    versions: dict[str, str] = {}
    t_start = time.perf_counter()

    def toppled(value: float) -> bool:
        nonlocal count, used_settings, versions
        scene = compile_scene(scenario.with_value(param, value))
        full = effective_settings(eng, scene, settings)
        traj = eng.simulate(scene, full)
        count += 1
        if not traj.ok:
            raise RuntimeError(f"engine {eng.name!r} failed at {param} = {value}: {traj.message}")
        used_settings, versions = full, traj.versions or eng.versions()
        if traj.t.size:
            max_tilt[0] = max(max_tilt[0], float(np.max(traj.tilt())))
        out = traj.toppled
        if progress is not None:
            progress(count, value, out)
        return out

    grid = np.geomspace(lo, hi, n_grid)
    flags = []
    for g in grid:
        flags.append(toppled(float(g)))
        if not all_transitions and flags[-1]:
            break
    grid = grid[: len(flags)]
    flags_a = np.array(flags, dtype=bool)
    transitions: list[Transition] = []
    for i in range(len(flags_a) - 1):
        if flags_a[i] == flags_a[i + 1]:
            continue
        a, b = float(grid[i]), float(grid[i + 1])
        below = bool(flags_a[i])
        while b - a > rel_tol * b:
            mid = 0.5 * (a + b)
            if toppled(mid) == below:
                a = mid
            else:
                b = mid
        transitions.append(Transition(a, b, below))
        if not all_transitions:
            break
    return ThresholdResult(
        param=param,
        engine=eng.name,
        settings=used_settings,
        grid=grid,
        grid_toppled=flags_a,
        transitions=transitions,
        rel_tol=rel_tol,
        n_simulations=count,
        versions=versions,
        scenario_hash=scenario.content_hash(),
        wall_time=time.perf_counter() - t_start,
        max_tilt=max_tilt[0],
    )
