"""What every engine setting may be: type, range and unit, checked in one place for every engine.

:func:`pbr_xval.engine.merge_settings` (and so ``EngineBase.resolve_settings``) applies
:func:`check_settings` to the complete settings of every run, before anything is simulated, so an
adapter never sees a zero time step, a negative iteration count or a NaN tolerance (a zero or
negative ``timestep`` used to make the reference solver loop forever). The same table validates
``[engines.<name>]`` tables of scenarios and ``[settings.<name>]`` tables of catalogs when they
are read (:func:`check_settings` with ``complete=False``), so a typo is reported before a run.

The module also bounds the size of a run (:func:`check_sample_count`, :func:`check_step_count`):
a duration of 1e9 s used to end in a 7 TiB allocation traceback.

Only ``numpy``-free standard library code here: the scenario, the engine base class and the
catalog import it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

__all__ = [
    "MAX_SAMPLES",
    "MAX_STEPS",
    "SPECS",
    "Spec",
    "check_sample_count",
    "check_settings",
    "check_step_count",
    "spec_for",
]

#: most samples a recorded trajectory may hold: 5e6 samples × 13 float64 columns ≈ 0.5 GB as a table
MAX_SAMPLES = 5_000_000
#: most engine steps one run may take (settling included); 1e8 steps is hours for any engine here
MAX_STEPS = 100_000_000
#: largest time step accepted, s. Only absurd values are refused (a duration typed as the step,
#: 1e9): steps of 0.01–1 s are poor for a rocking block (its impacts last milliseconds) but legal,
#: and the engines must report the blow-ups they cause as failed runs (the DART test provokes one
#: with 1 s steps; 0.1 s steps still run without failing there)
MAX_TIMESTEP = 1.0


@dataclass(frozen=True)
class Spec:
    """One setting: its kind and the values it accepts.

    kind : ``"float"``, ``"int"``, ``"bool"``, ``"choice"`` or ``"list"``.
    lo, hi : bounds for numbers (``lo_open``/``hi_open``: strict inequality).
    unit : SI unit shown in messages (``""`` for dimensionless).
    choices : allowed values of a ``choice`` (strings or numbers).
    none : ``None`` is allowed (meaning "the engine's / scene's own value").
    words : strings allowed besides numbers (e.g. ``"scene"``: take it from the scenario).
    length : length of a ``list``; ``item`` its items' spec.
    """

    kind: str
    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    hi_open: bool = False
    unit: str = ""
    choices: tuple[Any, ...] = ()
    none: bool = False
    words: tuple[str, ...] = ()
    length: int | None = None
    item: Spec | None = None

    def expected(self) -> str:
        """What the setting accepts, in words (for messages)."""
        if self.kind == "choice":
            text = "one of " + ", ".join(repr(c) for c in self.choices)
        elif self.kind == "bool":
            text = "true or false"
        elif self.kind == "list":
            assert self.item is not None
            text = f"a list of {self.length} values, each {self.item.expected()}"
        else:
            what = "an integer" if self.kind == "int" else "a finite number"
            parts = []
            if self.lo is not None:
                parts.append(f"{'>' if self.lo_open else '≥'} {self.lo:g}")
            if self.hi is not None:
                parts.append(f"{'<' if self.hi_open else '≤'} {self.hi:g}")
            text = (
                what + (" " + " and ".join(parts) if parts else "") + (f" {self.unit}" if self.unit else "")
            )
        alts = [repr(w) for w in self.words] + (["none (omit the key)"] if self.none else [])
        return text + (" or " + " or ".join(alts) if alts else "")

    def ok(self, v: Any) -> bool:
        """True if ``v`` is an accepted value."""
        if v is None:
            return self.none
        if isinstance(v, str) and v in self.words:
            return True
        if self.kind == "choice":
            return any(v == c and type(v) is type(c) for c in self.choices)
        if self.kind == "bool":
            return isinstance(v, bool)
        if self.kind == "list":
            assert self.item is not None
            return (
                isinstance(v, list | tuple)
                and (self.length is None or len(v) == self.length)
                and all(self.item.ok(x) for x in v)
            )
        if isinstance(v, bool) or not isinstance(v, int | float):
            return False
        if self.kind == "int" and not (isinstance(v, int) or (isinstance(v, float) and v.is_integer())):
            return False
        x = float(v)
        if not math.isfinite(x):
            return False
        if self.lo is not None and (x <= self.lo if self.lo_open else x < self.lo):
            return False
        return not (self.hi is not None and (x >= self.hi if self.hi_open else x > self.hi))


def _f(lo: float | None = None, hi: float | None = None, unit: str = "", **kw: Any) -> Spec:
    return Spec("float", lo, hi, unit=unit, **kw)


def _pos(unit: str = "", hi: float | None = None, **kw: Any) -> Spec:
    return Spec("float", 0.0, hi, lo_open=True, unit=unit, **kw)


def _nonneg(unit: str = "", hi: float | None = None, **kw: Any) -> Spec:
    return Spec("float", 0.0, hi, unit=unit, **kw)


def _int(lo: int, hi: int | None = None) -> Spec:
    return Spec("int", lo, hi)


def _choice(*c: Any) -> Spec:
    return Spec("choice", choices=c)


BOOL = Spec("bool")
TIMESTEP = _pos("s", MAX_TIMESTEP)
GROUND = _choice("inertial", "moving_pedestal")
COLLISION = _choice("auto", "primitive", "boxes", "hull", "coacd", "decimated", "mesh")
#: CoACD's concavity threshold is a fraction of the mesh size, in (0, 1]
COACD = {"coacd_threshold": _pos(hi=1.0), "coacd_seed": _int(0)}
HALF_EXTENTS = Spec("list", length=3, item=_pos("m"))
PEDESTAL_MASS = _pos("kg")
#: relative / absolute ODE tolerances: below 1e-15 is under float64 round-off, a solver never
#: meets it and runs forever; above 1 is no accuracy at all
RTOL = Spec("float", 1e-15, 1.0)
ATOL = _pos(hi=1.0)

#: engine name -> setting -> spec; every key of every profile of the built-in engines is here
#: (``tests/test_settings_spec.py`` checks it)
SPECS: dict[str, dict[str, Spec]] = {
    "housner": {
        "variant": _choice("exact", "linearized", "housner1963"),
        "rtol": RTOL,
        "atol": ATOL,
        "max_step": _pos("s", none=True),
        "omega_rest": _nonneg("rad/s"),
        # θ̇ after / θ̇ before an impact; None: the angular-momentum rule
        "impact_ratio": _nonneg(hi=1.0, none=True),
    },
    "curved_base": {
        "rtol": RTOL,
        "atol": ATOL,
        "max_step": _pos("s", none=True),
        "clamp": _pos("m"),
        "omega_rest": _nonneg("rad/s"),
        "impact_ratio": _nonneg(hi=1.0, none=True),
    },
    "reference": {
        "timestep": TIMESTEP,
        "epsilon": _pos("m", 0.1),
        "max_stepbacks": _int(0, 60),
        "min_timestep": _pos("s", MAX_TIMESTEP),
        "iterations": _int(1),
        "iteration_tol": _pos(hi=1.0),
        "orthogonality_tol": _pos(hi=1.0),
        "lcp_method": _choice("dantzig", "lemke"),
        "impact_selection": _choice("closest_to_previous", "min_norm"),
        "impact_velocity": _nonneg("m/s"),
        "separation_velocity": _nonneg("m/s"),
        "slip_velocity": _nonneg("m/s"),
        "nodes": _choice("scene", "hull", "grid", "vertices"),
        "max_nodes": _int(3, 100_000),
        "ground_motion": GROUND,
        "rest_velocity": _nonneg("m/s"),
        "static_hold": BOOL,
        "compiled": BOOL,
        "support_hull": BOOL,
        "side_nodes": BOOL,
        "max_cpu_per_simulated_s": _nonneg("s/s"),
    },
    "mujoco": {
        "timestep": TIMESTEP,
        "ground_motion": GROUND,
        "pedestal_mass": PEDESTAL_MASS,
        "plane_box_half_extents": HALF_EXTENTS,
        "settle": BOOL,
        "integrator": _choice("Euler", "RK4", "implicit", "implicitfast", "discrete"),
        "solver": _choice("PGS", "CG", "Newton"),
        "iterations": _int(1),
        "ls_iterations": _int(1),
        # MuJoCo's tolerance 0 is legal: it disables early termination (iterations run to the cap)
        "tolerance": _nonneg(hi=1.0),
        "noslip_iterations": _int(0),
        "cone": _choice("pyramidal", "elliptic"),
        "impratio": _pos(),
        "condim": _choice(1, 3, 4, 6),
        # [timeconst s, dampratio], or negative [−stiffness, −damping] (MuJoCo's direct form)
        "solref": Spec("list", length=2, item=_f(none=True)),
        "solimp": Spec("list", length=5, item=_f()),
        # [sliding, torsional, rolling]; None sliding -> the scene's μ
        "friction": Spec("list", length=3, item=_nonneg(none=True)),
        "margin": _nonneg("m"),
        "multiccd": BOOL,
        "refsafe": BOOL,
        "sleep": BOOL,
        "collision": COLLISION,
        **COACD,
    },
    "pybullet": {
        "timestep": TIMESTEP,
        "ground_motion": GROUND,
        "settle": BOOL,
        "collision": COLLISION,
        **COACD,
        "plane_pedestal": _choice("box", "plane"),
        "plane_box_half_extents": HALF_EXTENTS,
        "enable_sat": BOOL,
        "pedestal_mass": PEDESTAL_MASS,
        "num_solver_iterations": _int(1),
        "num_sub_steps": _int(0),
        "solver_type": _choice("si", "pgs", "dantzig"),
        "friction": _nonneg(words=("scene",)),
        "restitution": _nonneg(hi=1.0, words=("scene",)),
        "linear_damping": _nonneg("1/s"),
        "angular_damping": _nonneg("1/s"),
        "contact_stiffness": _pos("N/m", none=True),
        "contact_damping": _nonneg("N·s/m", none=True),
        "collision_margin": _nonneg("m", none=True),
    },
    "dart": {
        "timestep": TIMESTEP,
        "ground_motion": GROUND,
        "settle": BOOL,
        "collision_detector": _choice("fcl", "ode", "dart", "bullet"),
        "lcp_solver": _choice("dantzig", "pgs", "nsgs", "fbf"),
        "pgs_iterations": _int(1),
        "split_impulse": BOOL,
        "collision": COLLISION,
        **COACD,
        "plane_half_extents": HALF_EXTENTS,
        "pedestal_mass": PEDESTAL_MASS,
        "friction": _nonneg(words=("scene",)),
        "restitution": _nonneg(hi=1.0, words=("scene",)),
        "sleep": BOOL,
        "sleep_linear_threshold": _nonneg("m/s"),
        "sleep_angular_threshold": _nonneg("rad/s"),
        "sleep_time": _nonneg("s"),
    },
}

#: specs by key name for engines without their own table (plugins): the common meanings
GENERIC: dict[str, Spec] = {
    "timestep": TIMESTEP,
    "ground_motion": GROUND,
    "rtol": RTOL,
    "atol": ATOL,
    "iterations": _int(1),
    "tolerance": _nonneg(hi=1.0),
    "pedestal_mass": PEDESTAL_MASS,
    "settle": BOOL,
}


def spec_for(engine: str, key: str) -> Spec | None:
    """The spec of ``engine``'s setting ``key`` (None: nothing is known about it)."""
    table = SPECS.get(engine)
    if table is not None:
        return table.get(key)
    return GENERIC.get(key)


def check_settings(
    engine: str, settings: Mapping[str, Any], *, complete: bool = True, where: str = ""
) -> list[str]:
    """One message per bad setting (empty: all good).

    ``complete``: ``settings`` is the full resolved dictionary (cross-key rules apply, e.g.
    ``min_timestep ≤ timestep``). Otherwise it is a partial override table (a scenario's
    ``[engines.<name>]``): keys a built-in engine does not have are reported too.
    ``where`` prefixes each message (e.g. the file and table).
    """
    pre = where or f"engine {engine!r}"
    out = []
    table = SPECS.get(engine)
    for key, v in settings.items():
        if key == "profile":
            continue
        spec = spec_for(engine, key)
        if spec is None:
            if table is not None and not complete:
                out.append(f"{pre}: unknown setting {key!r}; expected one of {', '.join(sorted(table))}")
            continue
        if not spec.ok(v):
            out.append(f"{pre}: setting {key!r} = {v!r}; expected {spec.expected()}")
    if complete and not out:
        dt, dt_min = settings.get("timestep"), settings.get("min_timestep")
        if dt is not None and dt_min is not None and dt_min > dt:
            out.append(
                f"{pre}: setting 'min_timestep' = {dt_min!r} s is larger than 'timestep' = {dt!r} s; "
                "expected min_timestep ≤ timestep"
            )
    return out


def check_sample_count(duration: float, output_dt: float, *, where: str = "") -> str | None:
    """A message if ``duration / output_dt`` samples would exceed :data:`MAX_SAMPLES` (else None)."""
    n = duration / output_dt
    if not n <= MAX_SAMPLES:
        return (
            f"{where + ': ' if where else ''}duration {duration:g} s / output_dt {output_dt:g} s = {n:.3g} "
            f"samples; expected at most {MAX_SAMPLES:.0e} (shorten 'duration' or raise 'output_dt')"
        )
    return None


def check_step_count(
    engine: str, settings: Mapping[str, Any], duration: float, settle_time: float = 0.0, *, where: str = ""
) -> str | None:
    """A message if the run would take more than :data:`MAX_STEPS` engine steps (else None)."""
    dt = settings.get("timestep")
    if not isinstance(dt, int | float) or isinstance(dt, bool) or not dt > 0:
        return None  # analytical engines; a bad timestep is reported by check_settings
    total = duration + (settle_time if settings.get("settle", True) else 0.0)
    n = total / dt
    if not n <= MAX_STEPS:
        return (
            f"{where + ': ' if where else ''}engine {engine!r}: (duration + settling) {total:g} s / timestep "
            f"{dt:g} s = {n:.3g} steps; expected at most {MAX_STEPS:.0e} (shorten 'duration' or raise 'timestep')"
        )
    return None
