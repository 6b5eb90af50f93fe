"""Toppling thresholds of one scalar scenario parameter: a search that says exactly what it knows.

Overturning is not monotonic in amplitude (Zhang & Makris 2001: safe bands exist above the first
overturning level), so the search never assumes a single threshold:

1. **Physics first.** For a rigid rock at rest on a horizontal pedestal with no vertical shaking,
   nothing moves while the peak pedestal acceleration stays below the uplift acceleration
   g·tan α(φ) (the smaller of the two directions of the shaking axis). When the parameter scales
   the peak acceleration linearly (an amplitude, a PGA or PGV target, a record scale), the value at
   which PGA = g·tan α is a hard lower bound: values below it stand without being simulated, and
   the scan starts there.
2. **Coarse scan** of ``n_grid`` values (geometric spacing) between the bounds.
3. **Adaptive refinement** where the response came close to toppling: an interval between two
   standing runs is split when either run reached ``near`` × its critical tilt (or passed it and
   was pulled back); an interval between two toppling runs is split when the two topple in a
   different mode (other side, or a different number of impacts before toppling: a safe band can
   hide between two modes). Intervals are not split below ``min_width`` (relative) and the search
   spends at most ``max_simulations``.
4. **Each transition** between a standing and a toppling run is narrowed to ``rel_tol`` by a
   safeguarded secant on the energy margin of the standing runs: near a threshold the peak tilt
   ratio p = max θ/α approaches 1 as √(a* − a) (the energy deficit at the top of the swing is
   linear in a* − a and the potential is quadratic there), so (1 − p)² is nearly linear in the
   parameter and two standing runs extrapolate to the threshold; runs are placed just either side
   of the estimate, and a bisection step is forced whenever a step fails to halve the bracket.
   The two runs that bound the final bracket are direct runs just below and just above the
   transition, kept in the result.

The result states what is known: ``status`` is ``"bracketed"`` (a minimum toppling value with
its bracket), ``"topples_at_lo"`` (the lowest scanned value already topples: no minimum) or
``"never_toppled"`` (with the largest tilt ratio reached), and ``resolution`` says how narrow a
band the scan may have missed.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from pbr_xval.diagnostics import ensure_standard_diagnostics
from pbr_xval.engine import Engine, Trajectory, get_engine
from pbr_xval.runner import effective_settings
from pbr_xval.scenario import Scenario
from pbr_xval.scene import Scene, compile_scene

__all__ = ["Band", "Run", "ThresholdResult", "Transition", "find_threshold", "uplift_lower_bound"]

#: a standing run must reach this max θ/α before its margin is extrapolated (-)
NEAR_SECANT = 0.6

#: statuses of a search
BRACKETED, TOPPLES_AT_LO, NEVER_TOPPLED = "bracketed", "topples_at_lo", "never_toppled"


@dataclass(frozen=True)
class Run:
    """One simulation of the search (or a value decided by physics without simulating).

    Attributes
    ----------
    value : parameter value (parameter units).
    toppled : outcome.
    peak_ratio : largest tilt over the critical tilt in the tilt direction, max θ/α(φ) (-).
    toppled_at : s, the toppled event's time (None if it stood).
    side : +1/−1, sign of the rocking angle at toppling (or at the peak when it stood).
    impacts : sign changes of the rocking angle before toppling (or in the whole run).
    simulated : False for values below the uplift bound (stand by physics, not simulated).
    regime : what the rock did (:attr:`pbr_xval.engine.Trajectory.regime`, e.g. "rocked").
    """

    value: float
    toppled: bool
    peak_ratio: float
    toppled_at: float | None = None
    side: int = 0
    impacts: int = 0
    simulated: bool = True
    regime: str = ""


@dataclass(frozen=True)
class Transition:
    """A bracketed change of outcome: at ``lo`` the rock ``below``, at ``hi`` the other outcome.

    ``lo_run`` and ``hi_run`` are the direct runs that confirm the bracket from below and above.
    """

    lo: float
    hi: float
    below_toppled: bool
    lo_run: Run | None = None
    hi_run: Run | None = None

    @property
    def value(self) -> float:
        return 0.5 * (self.lo + self.hi)

    @property
    def half_width(self) -> float:
        return 0.5 * (self.hi - self.lo)


@dataclass(frozen=True)
class Band:
    """An interval of the parameter in which the rock topples (ends are bracket midpoints)."""

    start: float | None  # None: already toppling at the bottom of the scanned range
    end: float | None  # None: still toppling at the top of the scanned range
    start_tol: float | None
    end_tol: float | None


@dataclass
class ThresholdResult:
    """Outcome of a threshold search (see the module docstring).

    Attributes
    ----------
    param : dotted scenario key searched; ``unit`` its unit.
    engine : engine name; settings : the complete settings used.
    status : ``"bracketed"``, ``"topples_at_lo"`` or ``"never_toppled"``.
    lo, hi : the range searched (parameter units); ``lower_bound`` the physics bound, if any.
    grid, grid_toppled : every value searched and its outcome, sorted (coarse scan, refinement
        and bracket narrowing together).
    runs : every :class:`Run`, in the order simulated (values below the bound first).
    transitions : every bracketed transition, narrowed to ``rel_tol``.
    resolution : largest relative gap between neighbouring values with the same outcome: a band
        narrower than this may have been missed where the response stayed far from toppling.
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
    status: str = BRACKETED
    lo: float = float("nan")
    hi: float = float("nan")
    lower_bound: float | None = None
    runs: list[Run] = field(default_factory=list)
    resolution: float = float("nan")
    unit: str = ""
    criterion: dict[str, Any] = field(default_factory=dict)

    @property
    def max_peak_ratio(self) -> float:
        """Largest max θ/α(φ) over the standing runs (-), 0 without any."""
        return max((r.peak_ratio for r in self.runs if not r.toppled), default=0.0)

    @property
    def minimum(self) -> float | None:
        """Smallest toppling value (midpoint of the first stand→topple bracket).

        None when nothing toppled, and when the lowest scanned value already topples (the minimum
        is then somewhere below the range: nothing is known about it).
        """
        if self.status != BRACKETED:
            return None
        for tr in self.transitions:
            if not tr.below_toppled:
                return tr.value
        return None

    @property
    def tolerance(self) -> float | None:
        """± half-width of the bracket of :attr:`minimum` (same units as the parameter)."""
        if self.status != BRACKETED:
            return None
        for tr in self.transitions:
            if not tr.below_toppled:
                return tr.half_width
        return None

    def bands(self) -> list[Band]:
        """Every toppling band found in the searched range."""
        out: list[Band] = []
        start: tuple[float | None, float | None] | None = None
        if self.grid_toppled.size and self.grid_toppled[0]:
            start = (None, None)
        for tr in self.transitions:
            if not tr.below_toppled:
                start = (tr.value, tr.half_width)
            elif start is not None:
                out.append(Band(start[0], tr.value, start[1], tr.half_width))
                start = None
        if start is not None:
            out.append(Band(start[0], None, start[1], None))
        return out

    def message(self) -> str:
        """One sentence saying what the search found, with units and hints."""
        u = f" {self.unit}" if self.unit else ""
        if self.status == TOPPLES_AT_LO:
            return (
                f"the lowest scanned value {self.lo:.6g}{u} already topples: no minimum was bracketed (it "
                f"lies below {self.lo:.6g}{u}); lower --lo to find it"
            )
        if self.status == NEVER_TOPPLED:
            return (
                f"never toppled in [{self.lo:.6g}, {self.hi:.6g}]{u}: largest tilt {self.max_tilt:.3g} rad "
                f"(max θ/α = {self.max_peak_ratio:.3g}); raise --hi to search further"
            )
        return f"minimum toppling {self.param} = {self.minimum:.6g} ± {self.tolerance:.2g}{u}"

    def to_dict(self) -> dict[str, Any]:
        return {
            "param": self.param,
            "unit": self.unit,
            "engine": self.engine,
            "status": self.status,
            "message": self.message(),
            "minimum": self.minimum,
            "tolerance": self.tolerance,
            "rel_tol": self.rel_tol,
            "lo": self.lo,
            "hi": self.hi,
            "lower_bound": self.lower_bound,
            "resolution": self.resolution,
            "bands": [b.__dict__ for b in self.bands()],
            "transitions": [
                {
                    "lo": tr.lo,
                    "hi": tr.hi,
                    "below_toppled": tr.below_toppled,
                    "confirm_below": asdict(tr.lo_run) if tr.lo_run else None,
                    "confirm_above": asdict(tr.hi_run) if tr.hi_run else None,
                }
                for tr in self.transitions
            ],
            "runs": [asdict(r) for r in self.runs],
            "n_simulations": self.n_simulations,
            "settings": self.settings,
            "versions": self.versions,
            "scenario_hash": self.scenario_hash,
            "criterion": self.criterion,
            "wall_time": self.wall_time,
            "max_tilt_rad": self.max_tilt,
        }


# ----------------------------------------------------------------------------- physics
def _pga(scene: Scene) -> float:
    """Peak horizontal pedestal acceleration magnitude of a scene (m/s²), sampled finely."""
    h = scene.excitation.horizontal
    pga = getattr(h, "pga", None)
    if pga is not None and math.isfinite(float(pga)):
        return float(pga)
    t_end = max(float(scene.excitation.duration), 1e-3)
    t = np.linspace(0.0, t_end, 20001)
    return float(np.max(np.abs(np.asarray(h.acceleration(t), dtype=float))))


def uplift_lower_bound(scenario: Scenario, param: str, v0: float | None = None) -> float | None:
    """Parameter value below which a rigid rock cannot topple (its PGA stays under g·tan α).

    Valid when the pedestal is horizontal (plane or box), there is no vertical shaking, the rock
    starts at rest, the criterion is not a COM displacement (a sliding rock can move without
    rocking), and the parameter scales the peak acceleration linearly (checked numerically at v0
    and 2·v0). Returns None when any condition fails.
    """
    scn = scenario if v0 is None else scenario.with_value(param, v0)
    v0 = float(scn.get_value(param))
    if not (v0 > 0 and math.isfinite(v0)):
        return None
    try:
        s1 = compile_scene(scn)
        s2 = compile_scene(scn.with_value(param, 2.0 * v0))
    except Exception:
        return None
    if s1.pedestal.get("kind") not in ("plane", "box") or s1.excitation.vertical is not None:
        return None
    if s1.theta0 != 0.0 or s1.omega0 != 0.0 or s1.toppling.criterion == "com_displacement":
        return None
    p1, p2 = _pga(s1), _pga(s2)
    if not (p1 > 0 and abs(p2 / p1 - 2.0) < 1e-6):
        return None
    uplift = min(s1.uplift_accel(1.0), s1.uplift_accel(-1.0))
    if not (uplift > 0 and math.isfinite(uplift)):
        return None
    return v0 * uplift / p1


def describe_run(traj: Trajectory, scene: Scene) -> tuple[float, int, int]:
    """(max θ/α(φ), side, impacts) of one trajectory, engine-neutral.

    ``impacts`` counts sign changes of the rocking angle θ (hysteresis 1 % of the smaller
    critical tilt) before the toppled event, or over the whole run when it stood.
    """
    if traj.t.size == 0:
        return 0.0, 0, 0
    r = traj.rotation_matrices()
    top = r[:, :, 2]
    tilt = np.arccos(np.clip(top[:, 2], -1.0, 1.0))
    phi = np.arctan2(top[:, 1], top[:, 0])
    alpha = np.asarray(scene.rock.stability.alpha_at(phi), dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(alpha > 0, tilt / alpha, 0.0)
    theta = traj.rocking_angle()
    t_end = traj.toppled_at
    sel = theta if t_end is None else theta[traj.t <= t_end + 1e-12]
    hyst = 0.01 * float(np.min(scene.rock.stability.alpha))
    signs = np.sign(sel[np.abs(sel) > hyst])
    impacts = int(np.count_nonzero(np.diff(signs))) if signs.size > 1 else 0
    k = int(np.argmax(np.abs(theta))) if t_end is None else int(np.searchsorted(traj.t, t_end))
    k = min(k, theta.size - 1)
    side = int(np.sign(theta[k]))
    return float(np.nanmax(ratio)), side, impacts


# ------------------------------------------------------------------------------ search
def _search_range(
    scenario: Scenario, param: str, lo: float | None, hi: float | None, physics_bound: bool
) -> tuple[float, float, float | None]:
    """(lo, hi, uplift lower bound or None) of a search; ValueError for a bad range or parameter."""
    raw = scenario.get_value(param)
    if isinstance(raw, (int, float)) and not isinstance(raw, bool):
        v0 = float(raw)
    elif raw is None and lo is not None and hi is not None:
        v0 = math.nan  # unset in the file: the range given is scanned
    else:
        found = "it is unset" if raw is None else f"found {raw!r}"
        raise ValueError(
            f"--param {param}: the scenario {scenario.name!r} has no number there ({found}); expected a "
            "numeric key, set in the scenario or with both --lo and --hi"
        )
    bound = uplift_lower_bound(scenario, param) if physics_bound else None
    hi = 2.0 * v0 if hi is None else float(hi)
    if lo is None:
        lo = bound if (bound is not None and bound < hi) else 0.5 * v0
    lo = float(lo)
    if not (0 < lo < hi and math.isfinite(hi)):
        raise ValueError(f"threshold search needs 0 < lo < hi, got lo={lo}, hi={hi}")
    return lo, hi, bound


def _needs_split(k: int, runs_sorted: list[Run], min_width: float, near: float) -> bool:
    """Whether the interval between runs k and k + 1 (sorted by value) may hide a transition."""
    a, b = runs_sorted[k], runs_sorted[k + 1]
    if b.value - a.value <= min_width * b.value or a.toppled != b.toppled:
        return False  # narrow enough, or a transition (narrowed below)
    if a.toppled:
        # two toppling runs in different modes: a safe band may separate them
        return a.side != b.side or a.impacts != b.impacts
    # two standing runs: a toppling band needs the peak response to rise toward α and fall
    # again inside the interval, i.e. a local maximum of max θ/α near it that comes close to 1
    if max(a.peak_ratio, b.peak_ratio) < near:
        return False
    p = [r.peak_ratio if not r.toppled else math.inf for r in runs_sorted]
    lo_k, hi_k = max(k - 1, 0), min(k + 2, len(p) - 1)
    window = p[lo_k : hi_k + 1]
    inner = max(p[k], p[k + 1])
    return inner >= max(window) and ((window[0] < inner and window[-1] < inner) or len(window) < 4)


def _outcome(
    scanned: list[Run], transitions: list[Transition], cache: dict[float, Run]
) -> tuple[str, np.ndarray, np.ndarray, float]:
    """(status, values run, toppled flags, resolution) of a finished search; resolution is the
    widest relative gap between neighbouring simulated runs with the same outcome."""
    all_runs = sorted(cache.values(), key=lambda r: r.value)
    first = scanned[0] if scanned else None
    if first is not None and first.toppled:
        status = TOPPLES_AT_LO
    elif any(not tr.below_toppled for tr in transitions):
        status = BRACKETED
    else:
        status = NEVER_TOPPLED
    values = np.array([r.value for r in all_runs])
    flags = np.array([r.toppled for r in all_runs], dtype=bool)
    same = [
        (values[k + 1] - values[k]) / values[k + 1]
        for k in range(values.size - 1)
        if flags[k] == flags[k + 1] and all_runs[k].simulated
    ]
    return status, values, flags, float(max(same)) if same else 0.0


def find_threshold(
    scenario: Scenario,
    engine: str | Engine,
    param: str = "excitation.amplitude",
    *,
    lo: float | None = None,
    hi: float | None = None,
    n_grid: int = 8,
    rel_tol: float = 1e-3,
    settings: Mapping[str, Any] | None = None,
    all_transitions: bool = True,
    progress: Callable[[int, float, bool], None] | None = None,
    refine: bool = True,
    near: float = 0.9,
    min_width: float = 0.01,
    max_simulations: int = 80,
    physics_bound: bool = True,
) -> ThresholdResult:
    """Search ``param`` in [lo, hi] for every stand/topple transition (see the module docstring).

    Parameters
    ----------
    lo, hi : search range (parameter units). Default lo: the uplift lower bound when it applies,
        else 0.5× the scenario's value; default hi: 2× the scenario's value.
    n_grid : coarse-scan values (geometric spacing), ≥ 2.
    rel_tol : each transition is narrowed until (hi − lo) ≤ rel_tol × hi of its bracket.
    all_transitions : False narrows only the first stand→topple transition (the minimum) and
        scans no further once a value topples.
    progress : called after each simulation with (count, value, toppled).
    refine : split intervals where the response came close to toppling (module docstring).
    near : max θ/α(φ) of a standing run above which its neighbouring intervals are refined (-).
    min_width : relative width below which an interval is not refined further (-).
    max_simulations : budget for the whole search (the narrowing of transitions always finishes).
    physics_bound : use the uplift lower bound (values below it stand without simulation).

    Raises
    ------
    ValueError
        for an invalid range or grid, before anything is simulated.
    """
    from pbr_xval.units import unit as unit_of

    if int(n_grid) != n_grid or n_grid < 2:
        raise ValueError(f"n_grid: expected an integer ≥ 2 (a scan needs two values), got {n_grid}")
    if not (0 < rel_tol < 0.5):
        raise ValueError(f"rel_tol: expected 0 < rel_tol < 0.5, got {rel_tol}")
    eng = get_engine(engine)
    lo, hi, bound = _search_range(scenario, param, lo, hi, physics_bound)

    runs: list[Run] = []
    count = 0
    max_tilt = 0.0
    used_settings: dict[str, Any] = {}
    versions: dict[str, str] = {}
    criterion: dict[str, Any] = {}
    t_start = time.perf_counter()
    cache: dict[float, Run] = {}

    def simulate(value: float) -> Run:
        nonlocal count, used_settings, versions, max_tilt, criterion
        value = float(value)
        if value in cache:
            return cache[value]
        if bound is not None and value <= bound * (1.0 + 1e-12):
            run = Run(value, False, 0.0, simulated=False)
        else:
            scene = compile_scene(scenario.with_value(param, value))
            full = effective_settings(eng, scene, settings)
            traj = eng.simulate(scene, full)
            count += 1
            if not traj.ok:
                raise RuntimeError(f"engine {eng.name!r} failed at {param} = {value}: {traj.message}")
            used_settings, versions = full, traj.versions or eng.versions()
            criterion = scene.toppling.describe()
            if traj.t.size:
                max_tilt = max(max_tilt, float(np.max(traj.tilt())))
            peak, side, impacts = describe_run(traj, scene)
            regime = ensure_standard_diagnostics(traj, scene).regime
            run = Run(value, traj.toppled, peak, traj.toppled_at, side, impacts, regime=regime)
            if progress is not None:
                progress(count, value, run.toppled)
        cache[value] = run
        runs.append(run)
        return run

    # -- coarse scan (values below the physics bound stand without simulation)
    grid = [float(x) for x in np.geomspace(lo, hi, int(n_grid))]
    scanned: list[Run] = []
    for g in grid:
        scanned.append(simulate(g))
        if not all_transitions and scanned[-1].toppled:
            break

    # -- adaptive refinement near toppling
    if refine and all_transitions:
        changed = True
        while changed and count < max_simulations:
            changed = False
            scanned.sort(key=lambda r: r.value)
            splits = [k for k in range(len(scanned) - 1) if _needs_split(k, scanned, min_width, near)]
            for k in splits:
                if count >= max_simulations:
                    break
                scanned.append(simulate(math.sqrt(scanned[k].value * scanned[k + 1].value)))
                changed = True
    scanned.sort(key=lambda r: r.value)

    # -- narrow every transition
    transitions: list[Transition] = []
    for i in range(len(scanned) - 1):
        a, b = scanned[i], scanned[i + 1]
        if a.toppled == b.toppled:
            continue
        standing = [r for r in scanned if not r.toppled]
        transitions.append(_narrow(a, b, standing, rel_tol, simulate))
        if not all_transitions:
            break

    status, values, flags, resolution = _outcome(scanned, transitions, cache)
    return ThresholdResult(
        param=param,
        engine=eng.name,
        settings=used_settings,
        grid=values,
        grid_toppled=flags,
        transitions=transitions,
        rel_tol=rel_tol,
        n_simulations=count,
        versions=versions,
        scenario_hash=scenario.content_hash(),
        wall_time=time.perf_counter() - t_start,
        max_tilt=max_tilt,
        status=status,
        lo=lo,
        hi=hi,
        lower_bound=bound,
        runs=runs,
        resolution=resolution,
        unit=unit_of(param),
        criterion=criterion,
    )


def _narrow(
    a: Run, b: Run, standing: list[Run], rel_tol: float, simulate: Callable[[float], Run]
) -> Transition:
    """Narrow the bracket [a, b] (one standing, one toppling run) to ``rel_tol``."""
    below_toppled = a.toppled
    lo_run, hi_run = a, b
    # standing runs on the standing side of this transition, nearest first
    if not below_toppled:
        pool = sorted((r for r in standing if r.value <= a.value and r.simulated), key=lambda r: -r.value)
    else:
        pool = sorted((r for r in standing if r.value >= b.value and r.simulated), key=lambda r: r.value)
    force_bisect = False
    while hi_run.value - lo_run.value > rel_tol * hi_run.value:
        lo_v, hi_v = lo_run.value, hi_run.value
        width = hi_v - lo_v
        est = None if force_bisect else _secant_estimate(pool)
        step_bisect = True
        x = 0.5 * (lo_v + hi_v)
        if est is not None and lo_v < est < hi_v:
            off = 0.4 * rel_tol * est
            # Standing runs carry the margin that improves the estimate, toppling runs do not: try
            # just inside the standing side of the estimate first, then just beyond it.
            toward_topple = est + off if not below_toppled else est - off
            toward_stand = est - off if not below_toppled else est + off
            far_topple = (hi_v - est) if not below_toppled else (est - lo_v)
            far_stand = (est - lo_v) if not below_toppled else (hi_v - est)
            if far_stand > 1.5 * off:
                x, step_bisect = toward_stand, False
            elif far_topple > 1.5 * off:
                x, step_bisect = toward_topple, False
            x = min(max(x, lo_v + 1e-3 * width), hi_v - 1e-3 * width)
        r = simulate(x)
        if r.toppled == lo_run.toppled:
            lo_run = r
        else:
            hi_run = r
        if not r.toppled and r.simulated:
            pool.insert(0, r)
        force_bisect = (not step_bisect) and (hi_run.value - lo_run.value) > 0.5 * width
    return Transition(lo_run.value, hi_run.value, below_toppled, lo_run, hi_run)


def _secant_estimate(pool: list[Run]) -> float | None:
    """Extrapolate (1 − p)² of the two standing runs nearest the transition to zero.

    ``pool`` holds standing runs ordered from the nearest to the farthest from the transition.
    Returns None when fewer than two usable runs exist or the margin does not shrink toward the
    transition.
    """
    pts = [(r.value, (1.0 - r.peak_ratio) ** 2) for r in pool if 0.0 < r.peak_ratio < 1.0]
    # the square-root law holds near the top of the swing only: extrapolate from close runs
    if len(pts) < 2 or pts[0][1] > (1.0 - NEAR_SECANT) ** 2:
        return None
    (x1, g1), (x2, g2) = pts[0], pts[1]
    if not (g1 < g2) or x1 == x2:
        return None
    return x1 - g1 * (x1 - x2) / (g1 - g2)
