"""The backend-neutral scenario: what a user writes, as validated pydantic models.

A scenario is read from TOML, validated strictly (unknown keys are errors), written back to
TOML, and hashed for provenance. Units are SI throughout (m, kg, s, rad unless a key says
``_deg``). Example::

    name = "housner_halfsine"
    duration = 4.0

    [rock]
    shape = "box"
    half_extents = [0.2, 0.2, 0.6]
    density = 2400.0

    [excitation]
    type = "half_sine"
    amplitude = 5.638
    frequency = 1.0
    phase = "housner_uplift"

Paths inside a scenario (meshes, records) are relative to the scenario file.
"""

from __future__ import annotations

import hashlib
import json
import math
import types
import typing
from pathlib import Path
from typing import Annotated, Any, Literal, Union

import tomli_w
from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    ValidationError,
    ValidationInfo,
    field_validator,
    model_validator,
)

from pbr_xval.errors import ScenarioError
from pbr_xval.hashing import file_sha256
from pbr_xval.tomlio import read_toml, validation_lines
from pbr_xval.units import UNIT_SCALE

__all__ = [
    "UNIT_SCALE",
    "Contact",
    "Excitation",
    "Model",
    "Pedestal",
    "Rock",
    "Scenario",
    "ScenarioError",
    "Toppling",
    "file_sha256",
    "load_scenario",
]

PositiveFloat = Annotated[float, Field(gt=0, allow_inf_nan=False)]
NonNegFloat = Annotated[float, Field(ge=0, allow_inf_nan=False)]
Finite = Annotated[float, Field(allow_inf_nan=False)]
Vec3Pos = Annotated[list[PositiveFloat], Field(min_length=3, max_length=3)]
Vec3 = Annotated[list[Finite], Field(min_length=3, max_length=3)]


class Strict(BaseModel):
    """Base of every scenario table: unknown keys are errors, assignments are validated."""

    model_config = ConfigDict(extra="forbid", validate_assignment=True, frozen=False)


# ------------------------------------------------------------------------ rock
class _MassSpec(Strict):
    density: PositiveFloat | None = Field(None, description="kg/m³")
    mass: PositiveFloat | None = Field(None, description="kg")
    yaw_deg: Finite = Field(0.0, description="rotation of the rock about the vertical, degrees")

    @model_validator(mode="after")
    def _one_of_density_mass(self) -> _MassSpec:
        if self.density is not None and self.mass is not None:
            raise ValueError("give either 'density' or 'mass', not both")
        if self.density is None and self.mass is None:
            raise ValueError("give 'density' (kg/m³) or 'mass' (kg)")
        return self


class BoxRock(_MassSpec):
    """``[rock] shape = "box"``: a rectangular block, half extents (3,) m, density kg/m³ or mass kg."""

    shape: Literal["box"]
    half_extents: Vec3Pos = Field(description="half sizes along x, y, z, m")


class NotchedBlockRock(_MassSpec):
    """A box with a rectangular notch cut through its whole depth (y) at the centre of the base."""

    shape: Literal["notched_block"]
    half_extents: Vec3Pos
    notch_width: PositiveFloat = Field(description="full width of the notch along x, m")
    notch_height: PositiveFloat = Field(description="height of the notch, m")

    @model_validator(mode="after")
    def _notch_fits(self) -> NotchedBlockRock:
        bx, _, bz = self.half_extents
        if self.notch_width >= 2 * bx:
            raise ValueError(f"notch_width {self.notch_width} must be < the block width {2 * bx}")
        if self.notch_height >= 2 * bz:
            raise ValueError(f"notch_height {self.notch_height} must be < the block height {2 * bz}")
        return self


class CurvedBaseRock(_MassSpec):
    """The seed's curved-base block (science.md §8): height H, corner radius r, flat length h."""

    shape: Literal["curved_base"]
    H: PositiveFloat = Field(description="height, m")
    r: NonNegFloat = Field(description="radius of the rounded bottom corners, m")
    h: NonNegFloat = Field(description="length of the flat part of the base, m")
    depth: PositiveFloat = Field(1.0, description="extrusion depth along y for 3-D engines, m")
    arc_segments: int = Field(32, ge=2, le=4096, description="facets per quarter arc in the 3-D mesh")

    @model_validator(mode="after")
    def _fits(self) -> CurvedBaseRock:
        if self.r >= self.H:
            raise ValueError(f"r = {self.r} must be < H = {self.H}")
        if self.r == 0 and self.h == 0:
            raise ValueError("r and h cannot both be 0 (the base would be a point)")
        return self


class MeshRock(_MassSpec):
    """``[rock] shape = "mesh"``: a closed mesh file in ``units``, put at rest in ``pose``."""

    shape: Literal["mesh"]
    path: str = Field(description="mesh file (OBJ, PLY, STL, OFF), relative to the scenario file")
    units: Literal["m", "cm", "mm", "km", "ft", "in"] = "m"
    inertia: Annotated[list[Finite], Field(min_length=6, max_length=6)] | None = Field(
        None, description="explicit inertia about the COM [Ixx, Iyy, Izz, Ixy, Ixz, Iyz], kg·m²"
    )
    pose: Literal["scan", "settle", "stable"] = Field(
        "settle",
        description="resting pose on a flat pedestal: 'scan' (the scan's orientation; refused when the "
        "rock is not at rest in it), 'settle' (settled onto the hull face below the COM) or 'stable' "
        "(lowest COM); the same vocabulary and default as `pbr-xval rock --pose`",
    )

    @model_validator(mode="before")
    @classmethod
    def _deprecated_orientation(cls, data: Any) -> Any:
        """Read the old key ``orientation`` (``as_scanned`` | ``stable``) as ``pose``, with a warning."""
        if isinstance(data, dict) and "orientation" in data:
            import warnings

            data = dict(data)
            old = data.pop("orientation")
            if "pose" in data:
                raise ValueError("give 'pose' only ('orientation' is its deprecated old name)")
            new = {"as_scanned": "scan"}.get(old, old)
            data["pose"] = new
            warnings.warn(
                f"key 'rock.orientation' is deprecated: write pose = {new!r} "
                f"(pose takes scan | settle | stable; 'as_scanned' is now 'scan')",
                FutureWarning,
                stacklevel=2,
            )
        return data


Rock = Annotated[
    Union[BoxRock, NotchedBlockRock, CurvedBaseRock, MeshRock],  # noqa: UP007
    Field(discriminator="shape"),
]


# -------------------------------------------------------------------- pedestal
class PlanePedestal(Strict):
    """``[pedestal] kind = "plane"``: the flat ground z = 0 (the default)."""

    kind: Literal["plane"] = "plane"


class BoxPedestal(Strict):
    """``[pedestal] kind = "box"``: a box, half extents (3,) m, top face at z = 0 under the rock."""

    kind: Literal["box"]
    half_extents: Vec3Pos = Field(description="half sizes; the top face is at z = 0 under the rock")


class MeshPedestal(Strict):
    """``[pedestal] kind = "mesh"``: a pedestal mesh file in ``units``, in the scene frame."""

    kind: Literal["mesh"]
    path: str
    units: Literal["m", "cm", "mm", "km", "ft", "in"] = "m"


Pedestal = Annotated[
    Union[PlanePedestal, BoxPedestal, MeshPedestal],  # noqa: UP007
    Field(discriminator="kind"),
]


class Contact(Strict):
    """``[contact]``: Coulomb friction μ_s, μ_d (dimensionless) and normal restitution (0–1)."""

    friction_static: NonNegFloat = Field(1.0, description="μ_s, dimensionless")
    friction_dynamic: NonNegFloat | None = Field(None, description="μ_d (defaults to μ_s)")
    restitution: Annotated[float, Field(ge=0, le=1)] = Field(0.0, description="normal velocity restitution")

    @property
    def mu_d(self) -> float:
        """Dynamic friction coefficient μ_d (dimensionless): ``friction_dynamic``, else μ_s."""
        return self.friction_static if self.friction_dynamic is None else self.friction_dynamic


# ------------------------------------------------------------------ excitation
class _MotionBase(Strict):
    start_time: NonNegFloat = Field(0.0, description="s after t = 0 at which the motion starts")


class HalfSineMotion(_MotionBase):
    """``type = "half_sine"``: one half-sine pulse of ``amplitude`` m/s² at ``frequency`` Hz."""

    type: Literal["half_sine"]
    amplitude: PositiveFloat = Field(description="m/s²")
    frequency: PositiveFloat = Field(1.0, description="Hz (ω = 2πf)")
    phase: Literal["housner_uplift"] | Finite = Field(
        0.0, description="rad, or 'housner_uplift' for a·sinφ = uplift acceleration of the rock"
    )


class SawtoothMotion(_MotionBase):
    """``type = "sawtooth"``: a sawtooth velocity pulse of peak ``pgv`` m/s and period ``period`` s."""

    type: Literal["sawtooth"]
    pgv: PositiveFloat = Field(description="peak ground velocity, m/s")
    period: PositiveFloat = Field(description="T, s")
    skew: Annotated[float, Field(gt=0, lt=1)] = Field(0.5, description="rise fraction s of T")


class OneSineMotion(_MotionBase):
    """``type = "one_sine"``: one full sine cycle of ``amplitude`` m/s² at ``frequency`` Hz."""

    type: Literal["one_sine"]
    amplitude: PositiveFloat
    frequency: PositiveFloat


class OneCosineMotion(_MotionBase):
    """``type = "one_cosine"``: one full cosine cycle of ``amplitude`` m/s² at ``frequency`` Hz."""

    type: Literal["one_cosine"]
    amplitude: PositiveFloat
    frequency: PositiveFloat


class RectangularMotion(_MotionBase):
    """``type = "rectangular"``: a constant ``amplitude`` m/s² for ``pulse_duration`` s."""

    type: Literal["rectangular"]
    amplitude: PositiveFloat
    pulse_duration: PositiveFloat = Field(description="s")


class RickerMotion(_MotionBase):
    """``type = "ricker"``: a Ricker wavelet of peak ``amplitude`` m/s², central ``frequency`` Hz."""

    type: Literal["ricker"]
    amplitude: PositiveFloat
    frequency: PositiveFloat
    t0: PositiveFloat | None = None


class _RecordSource(Strict):
    """Where one recorded component comes from and in which units (docs/scenarios.md)."""

    path: str = Field(description="record file, relative to the scenario file")
    format: Literal["auto", "at2", "table", "npz"] = Field(
        "auto", description="auto: .at2 → at2 (PEER, in g), .npz → npz, anything else → table"
    )
    units: Literal["m/s2", "g", "cm/s2"] | None = Field(
        None,
        validate_default=True,
        description="acceleration units of a table or npz array (required: never guessed); AT2 is g",
    )
    dt: PositiveFloat | None = Field(
        None, description="sample interval, s (tables without a time column, npz)"
    )
    column: str | Annotated[int, Field(ge=0)] | None = Field(
        None, description="table: the acceleration column, by header name or 0-based index"
    )
    time_column: str | Annotated[int, Field(ge=0)] | None = Field(
        None, description="table: the time column (s), by header name or 0-based index"
    )
    array: str | None = Field(None, description="npz: name of the acceleration array")
    dt_array: str | None = Field(None, description="npz: name of the array holding dt (s)")
    component_azimuth_deg: Finite | None = Field(
        None,
        description="direction of this component, degrees from +x toward +y (default: along the shaking azimuth)",
    )

    @field_validator("units", mode="after")
    @classmethod
    def _units_stated(cls, v: str | None, info: Any) -> str | None:
        fmt = info.data.get("format", "auto")
        path = str(info.data.get("path", ""))
        is_at2 = fmt == "at2" or (fmt == "auto" and path.lower().endswith(".at2"))
        if v is None and not is_at2:
            raise ValueError(
                "missing: the acceleration units of this record (one of 'g', 'm/s2', 'cm/s2'); "
                "units are never guessed"
            )
        if is_at2 and v not in (None, "g"):
            raise ValueError(f"a PEER AT2 file is in units of g; found units = {v!r}")
        return v


class RecordComponent(_RecordSource):
    """The second horizontal component of a two-component record (``excitation.second``)."""

    component_azimuth_deg: Finite = Field(
        description="direction of this component, degrees from +x toward +y"
    )


class RecordMotion(_MotionBase, _RecordSource):
    """``type = "record"``: a recorded accelerogram (AT2, table or npz), processed and scaled."""

    type: Literal["record"]
    second: RecordComponent | None = Field(
        None, description="second horizontal component (H2); both are projected onto the shaking azimuth"
    )
    baseline: Literal["none", "mean", "linear", "polynomial"] = Field(
        "none", description="baseline correction of each component (scipy.signal.detrend / polynomial fit)"
    )
    baseline_order: Annotated[int, Field(ge=0, le=10)] = Field(
        2, description="order of the polynomial baseline"
    )
    highpass_hz: PositiveFloat | None = Field(None, description="Butterworth high-pass corner, Hz")
    lowpass_hz: PositiveFloat | None = Field(None, description="Butterworth low-pass corner, Hz")
    filter_order: Annotated[int, Field(ge=1, le=12)] = Field(4, description="Butterworth order")
    zero_phase: bool = Field(True, description="filter forward and backward (sosfiltfilt), no phase shift")
    scale: PositiveFloat = 1.0
    target_pga: PositiveFloat | None = Field(None, description="scale the record to this PGA, m/s²")
    target_pgv: PositiveFloat | None = Field(None, description="scale the record to this PGV, m/s")
    sign: Literal[1, -1] = 1

    @model_validator(mode="after")
    def _one_target(self) -> RecordMotion:
        if self.target_pga is not None and self.target_pgv is not None:
            raise ValueError("give at most one of 'target_pga' and 'target_pgv'")
        if self.second is not None and self.component_azimuth_deg is None:
            raise ValueError(
                "a two-component record needs 'component_azimuth_deg' for the first component "
                "(and 'second.component_azimuth_deg')"
            )
        if (
            self.highpass_hz is not None
            and self.lowpass_hz is not None
            and self.highpass_hz >= self.lowpass_hz
        ):
            raise ValueError(
                f"highpass_hz = {self.highpass_hz} must be below lowpass_hz = {self.lowpass_hz} (a band-pass)"
            )
        return self


Motion = Annotated[
    Union[  # noqa: UP007
        HalfSineMotion,
        SawtoothMotion,
        OneSineMotion,
        OneCosineMotion,
        RectangularMotion,
        RickerMotion,
        RecordMotion,
    ],
    Field(discriminator="type"),
]


class _Shaking(Strict):
    azimuth_deg: Finite = Field(0.0, description="direction of shaking, degrees from +x toward +y")
    vertical: Motion | None = Field(None, description="optional vertical component (+z up)")


def _excitation_class(motion_cls: type[BaseModel]) -> type[BaseModel]:
    return types.new_class(motion_cls.__name__.replace("Motion", "Excitation"), (motion_cls, _Shaking), {})


HalfSineExcitation = _excitation_class(HalfSineMotion)
SawtoothExcitation = _excitation_class(SawtoothMotion)
OneSineExcitation = _excitation_class(OneSineMotion)
OneCosineExcitation = _excitation_class(OneCosineMotion)
RectangularExcitation = _excitation_class(RectangularMotion)
RickerExcitation = _excitation_class(RickerMotion)
RecordExcitation = _excitation_class(RecordMotion)


class NoExcitation(Strict):
    """No ground motion (free rocking from an initial tilt, or rest)."""

    type: Literal["none"]
    azimuth_deg: Finite = 0.0
    vertical: None = None


Excitation = Annotated[
    Union[  # noqa: UP007
        HalfSineExcitation,  # type: ignore[valid-type]
        SawtoothExcitation,  # type: ignore[valid-type]
        OneSineExcitation,  # type: ignore[valid-type]
        OneCosineExcitation,  # type: ignore[valid-type]
        RectangularExcitation,  # type: ignore[valid-type]
        RickerExcitation,  # type: ignore[valid-type]
        RecordExcitation,  # type: ignore[valid-type]
        NoExcitation,
    ],
    Field(discriminator="type"),
]


class InitialState(Strict):
    """Initial rocking state in the shaking plane (for free-rocking tests)."""

    theta: Finite = Field(0.0, description="initial rocking angle, rad (positive: top toward +d)")
    theta_over_alpha: Finite | None = Field(None, description="initial angle as a fraction of α")
    omega: Finite = Field(0.0, description="initial rocking rate, rad/s")

    @model_validator(mode="after")
    def _one(self) -> InitialState:
        if self.theta != 0.0 and self.theta_over_alpha is not None:
            raise ValueError("give either 'theta' or 'theta_over_alpha', not both")
        return self


class Toppling(Strict):
    """When a run counts as toppled (the full definition is in ``docs/toppling.md``).

    * ``physical`` (default): the rock has toppled when it can no longer return. Passing the
      critical tilt α(φ) while the ground still moves is not enough — the reversing half of a
      pulse can pull the rock back. The decision is taken

      - at any time, once the rock is plainly **down**: it is past its critical tilt α(φ) and
        its tilt reaches ``down_angle_deg`` (90° by default: the rock lies on another face; see
        the docs for why shaking cannot lift it back), or its centre of mass drops below the
        pedestal top (it fell off the pedestal);
      - after the excitation has ended (the pedestal frame is inertial again), once the rock is
        past its critical tilt α(φ) and still tilting outward: past α the moment of gravity
        about the pivot points outward and nothing reverses it;
      - at the end of the run, if the rock is past α(φ) and not tilting back.

      Otherwise the run goes on to the end of ``duration``. The toppled event's time is the
      last outward crossing of α(φ) (the instant of no return); ``decided_at`` and ``rule``
      say when and why it was decided.
    * ``critical_tilt``: the first crossing of ``factor`` × α(φ) (the seed's θ/α > 1 for a
      block). This is the first-crossing rule: it misses safe bands above the first
      overturning level (a rock pulled back after crossing α counts as toppled).
    * ``tilt_angle``: the first time the tilt exceeds ``angle_deg``.
    * ``com_displacement``: the first time the horizontal COM displacement exceeds
      ``distance`` (m).
    """

    criterion: Literal["physical", "critical_tilt", "tilt_angle", "com_displacement"] = "physical"
    factor: PositiveFloat = 1.0
    angle_deg: Annotated[float, Field(gt=0, lt=180)] | None = None
    distance: PositiveFloat | None = None
    down_angle_deg: Annotated[float, Field(gt=0, le=180)] = Field(
        90.0,
        description="physical criterion: tilt at which the rock is down whatever the ground does, degrees",
    )
    stop_on_topple: bool = True
    stop_at_rest: bool = Field(
        False,
        description=(
            "stop the run once the rock is at rest after the excitation has ended (its outcome is "
            "then decided: it stands); pbr_xval.stepping.REST_* define 'at rest'"
        ),
    )

    @model_validator(mode="after")
    def _params(self) -> Toppling:
        if self.criterion == "tilt_angle" and self.angle_deg is None:
            raise ValueError("criterion 'tilt_angle' needs 'angle_deg'")
        if self.criterion == "com_displacement" and self.distance is None:
            raise ValueError("criterion 'com_displacement' needs 'distance'")
        return self

    def describe(self) -> dict[str, Any]:
        """The criterion as recorded in every result's provenance."""
        d: dict[str, Any] = {"criterion": self.criterion}
        if self.criterion == "physical":
            d["down_angle_deg"] = self.down_angle_deg
            d["definition"] = (
                "toppled when it cannot return: down (past the critical tilt with tilt >= down_angle_deg, "
                "or COM below the pedestal top) at any time, or past the critical tilt and still tilting "
                "outward after the excitation ended, or past it and not tilting back at the end of the run"
            )
        elif self.criterion == "critical_tilt":
            d["factor"] = self.factor
            d["definition"] = "first crossing of factor x critical tilt alpha(phi)"
        elif self.criterion == "tilt_angle":
            d["angle_deg"] = self.angle_deg
            d["definition"] = "first crossing of angle_deg"
        else:
            d["distance"] = self.distance
            d["definition"] = "first horizontal COM displacement >= distance"
        d["stop_on_topple"] = self.stop_on_topple
        if self.stop_at_rest:
            d["stop_at_rest"] = True
        return d


class Model(Strict):
    """What the scene compiler may simplify (model only what the scene requires).

    Mass properties always come from the full closed mesh; these options choose only the
    geometry used for contact. ``auto`` picks the smallest faithful model and the compiler
    records each choice in the scene.

    * ``collision``: ``primitive`` (boxes), ``boxes`` (exact box decomposition, e.g. the
      notched block), ``hull`` (one convex hull), ``coacd`` (CoACD convex parts, for rocks
      whose concavities can touch the pedestal), ``decimated`` (a mesh simplified away from
      the base, basal patch kept at full resolution). ``auto``: primitive / boxes when exact,
      else hull.
    * ``pedestal``: ``plane`` for a flat pedestal (``auto`` does this for plane and box pedestals).
    * ``basal_nodes``: number of contact nodes the reference solver uses on the rock's base
      (``auto``: the convex-hull vertices near the base).
    """

    collision: Literal["auto", "primitive", "boxes", "hull", "coacd", "decimated"] = "auto"
    coacd_threshold: Annotated[float, Field(gt=0, le=1)] = 0.05
    decimate_cell: PositiveFloat | None = Field(
        None, description="decimation cell size away from the base, m (default: 1/20 of the rock size)"
    )
    basal_band: PositiveFloat | None = Field(
        None, description="height above the lowest point kept at full resolution / searched for nodes, m"
    )
    pedestal: Literal["auto", "plane", "as_given"] = "auto"
    basal_nodes: Literal["auto"] | Annotated[int, Field(ge=3, le=100_000)] = "auto"


class Scenario(Strict):
    """One rock on one pedestal under one ground motion."""

    name: str = Field(pattern=r"^[A-Za-z0-9_.\-]+$")
    description: str = ""
    gravity: PositiveFloat = Field(9.81, description="m/s²")
    duration: PositiveFloat = Field(description="simulated time after the start of the excitation, s")
    settle_time: NonNegFloat = Field(0.5, description="engine settling before t = 0, s")
    output_dt: PositiveFloat = Field(1e-3, description="sampling of the recorded trajectory, s")
    seed: int = Field(0, ge=0)
    rock: Rock
    pedestal: Pedestal = Field(default_factory=PlanePedestal)
    contact: Contact = Field(default_factory=Contact)
    excitation: Excitation
    initial: InitialState = Field(default_factory=InitialState)
    toppling: Toppling = Field(default_factory=Toppling)
    model: Model = Field(default_factory=Model)
    engines: dict[str, dict[str, Any]] = Field(
        default_factory=dict, description="per-engine settings overrides, e.g. [engines.mujoco]"
    )
    uncertainty: dict[str, Any] | None = Field(
        None,
        description="ensemble: distributions of dotted scenario keys, engines mixture, members, seed, "
        "sampling (pbr_xval.uncertainty; docs/scenarios.md); single runs use the values written above",
    )

    # where relative paths are resolved (set by load_scenario); not part of the content
    _base_dir: Path = Path(".")
    _source: Path | None = None

    # ------------------------------------------------------------------ paths
    def resolve_path(self, p: str) -> Path:
        """A path written in the scenario, relative to the scenario file's folder (absolute kept)."""
        q = Path(p)
        return q if q.is_absolute() else (self._base_dir / q)

    def referenced_files(self) -> dict[str, Path]:
        """Key path → file, for every file the scenario refers to."""
        out: dict[str, Path] = {}
        if isinstance(self.rock, MeshRock):
            out["rock.path"] = self.resolve_path(self.rock.path)
        if isinstance(self.pedestal, MeshPedestal):
            out["pedestal.path"] = self.resolve_path(self.pedestal.path)
        if isinstance(self.excitation, RecordMotion):
            out["excitation.path"] = self.resolve_path(self.excitation.path)
            if self.excitation.second is not None:
                out["excitation.second.path"] = self.resolve_path(self.excitation.second.path)
        v = getattr(self.excitation, "vertical", None)
        if v is not None and v.type == "record":
            out["excitation.vertical.path"] = self.resolve_path(v.path)
        return out

    @field_validator("engines")
    @classmethod
    def _check_engines_table(cls, engines: dict[str, dict[str, Any]]) -> dict[str, dict[str, Any]]:
        """Engine names must be registered (a typo'd table is not ignored); values are range-checked."""
        from pbr_xval.registry import registered_names
        from pbr_xval.settings_spec import check_settings

        known = registered_names()
        for k, v in engines.items():
            if k not in known:
                raise ValueError(f"unknown engine {k!r}; expected one of {', '.join(known)}")
            problems = check_settings(k, v, complete=False, where=f"engines.{k}")
            if problems:
                raise ValueError(problems[0])
        return engines

    @field_validator("output_dt")
    @classmethod
    def _bounded_samples(cls, output_dt: float, info: ValidationInfo) -> float:
        """Refuse runs whose recorded trajectory would not fit in memory (duration 1e9 s did)."""
        from pbr_xval.settings_spec import check_sample_count

        duration = info.data.get("duration")
        if duration is not None:
            problem = check_sample_count(duration, output_dt)
            if problem:
                raise ValueError(problem)
        return output_dt

    # -------------------------------------------------------------- hashing
    def normalised(self) -> dict[str, Any]:
        """Content with defaults filled in, JSON types only (the input to the hash).

        ``[uncertainty]`` enters in its parsed form (defaults filled in, dotted keys flat); a
        scenario without one hashes as before the table existed.
        """
        d = self.model_dump(mode="json", exclude={"description", "uncertainty"})
        if not self.toppling.stop_at_rest:  # a scenario that does not set it hashes as before it existed
            d["toppling"].pop("stop_at_rest", None)
        if self.uncertainty is not None:
            from pbr_xval.uncertainty import parse_uncertainty

            d["uncertainty"] = parse_uncertainty(self.uncertainty).normalised()
        return d

    def content_hash(self) -> str:
        """SHA-256 over the normalised content and the SHA-256 of every referenced file."""
        h = hashlib.sha256()
        h.update(json.dumps(self.normalised(), sort_keys=True, separators=(",", ":")).encode())
        for key, path in sorted(self.referenced_files().items()):
            h.update(key.encode())
            h.update(file_sha256(path).encode())
        return h.hexdigest()

    # ------------------------------------------------------------- TOML i/o
    def to_toml(self) -> str:
        """TOML text of what was set (defaults that were not written stay unwritten)."""
        return tomli_w.dumps(_drop_none(self.model_dump(mode="json", exclude_unset=True)))

    def with_value(self, key: str, value: Any) -> Scenario:
        """A copy with one dotted key (e.g. ``excitation.amplitude``) replaced, validated."""
        data = self.model_dump(mode="json", exclude_unset=True)
        node = data
        parts = key.split(".")
        model: Any = self
        for p in parts[:-1]:
            model = getattr(model, p, None)
            if p not in node and isinstance(model, BaseModel):
                # a table left at its defaults (e.g. [contact] not written)
                node[p] = model.model_dump(mode="json")
            if not isinstance(node.get(p), dict):
                raise ScenarioError(f"scenario {self.name!r}: no table {p!r} on the way to key {key!r}")
            node = node[p]
        node[parts[-1]] = value
        out = _validate(data, self._source)
        out._base_dir = self._base_dir
        out._source = self._source
        return out

    def from_tables(self, data: dict[str, Any]) -> Scenario:
        """Another scenario validated from ``data``, read from this one's file (paths, messages)."""
        out = _validate(data, self._source)
        out._base_dir = self._base_dir
        out._source = self._source
        return out

    def get_value(self, key: str) -> Any:
        """The value at a dotted key (``"excitation.amplitude"``), SI units as written in the file."""
        node: Any = self
        for p in key.split("."):
            if not hasattr(node, p):
                raise ScenarioError(f"scenario {self.name!r}: no key {key!r} (stopped at {p!r})")
            node = getattr(node, p)
        return node


def _drop_none(d: Any) -> Any:
    if isinstance(d, dict):
        return {k: _drop_none(v) for k, v in d.items() if v is not None}
    if isinstance(d, list):
        return [_drop_none(v) for v in d]
    return d


# ------------------------------------------------------------------- loading
def _model_at(loc: tuple[Any, ...]) -> type[BaseModel] | None:
    """The pydantic model class that owns the key at ``loc`` (for 'expected one of' hints)."""
    cls: Any = Scenario
    i = 0
    while i < len(loc) - 1:
        name = loc[i]
        if not (isinstance(cls, type) and issubclass(cls, BaseModel)) or name not in cls.model_fields:
            return None
        ann = cls.model_fields[name].annotation
        members = [a for a in _union_members(ann) if isinstance(a, type) and issubclass(a, BaseModel)]
        if len(members) == 1:
            cls = members[0]
        else:  # discriminated union: next loc element is the tag
            tag = loc[i + 1] if i + 1 < len(loc) else None
            match = [m for m in members if _tag_of(m) == tag]
            if not match:
                return None
            cls = match[0]
            i += 1
        i += 1
    return cls


def _union_members(ann: Any) -> list[Any]:
    origin = typing.get_origin(ann)
    if origin is Annotated:
        return _union_members(typing.get_args(ann)[0])
    if origin in (Union, types.UnionType):
        out: list[Any] = []
        for a in typing.get_args(ann):
            out += _union_members(a)
        return out
    return [ann]


def _tag_of(cls: type[BaseModel]) -> str | None:
    for f in ("shape", "kind", "type"):
        if f in cls.model_fields:
            args = typing.get_args(cls.model_fields[f].annotation)
            if args:
                return args[0]
    return None


def _format_errors(exc: ValidationError, source: Path | None) -> str:
    def known(loc: tuple[Any, ...]) -> list[str]:
        owner = _model_at(loc)
        return sorted(owner.model_fields) if owner else []

    where = str(source) if source else "<scenario>"
    # discriminator tags are not keys
    return "\n".join(validation_lines(exc, where, loc=_strip_tags, known_keys=known))


def _strip_tags(loc: tuple[Any, ...]) -> list[str]:
    out: list[str] = []
    cls: Any = Scenario
    i = 0
    while i < len(loc):
        part = loc[i]
        out.append(str(part))
        if isinstance(cls, type) and issubclass(cls, BaseModel) and part in cls.model_fields:
            members = [
                a
                for a in _union_members(cls.model_fields[part].annotation)
                if isinstance(a, type) and issubclass(a, BaseModel)
            ]
            if len(members) > 1 and i + 1 < len(loc):
                match = [m for m in members if _tag_of(m) == loc[i + 1]]
                if match:
                    cls = match[0]
                    i += 2
                    continue
            cls = members[0] if len(members) == 1 else None
        else:
            cls = None
        i += 1
    return out


def _validate(data: dict[str, Any], source: Path | None) -> Scenario:
    try:
        scn = Scenario.model_validate(data)
    except ValidationError as exc:
        raise ScenarioError(_format_errors(exc, source)) from None
    if scn.uncertainty is not None:
        _check_uncertainty(scn, source)
    return scn


def _check_uncertainty(scn: Scenario, source: Path | None) -> None:
    """The ``[uncertainty]`` table: parameters, then every key against the scenario."""
    from pbr_xval.uncertainty import UncertaintyError, check_keys, parse_uncertainty

    where = str(source) if source else "<scenario>"
    try:
        spec = parse_uncertainty(scn.uncertainty or {}, where)
    except UncertaintyError as exc:
        raise ScenarioError(str(exc)) from None
    lines = check_keys(scn, spec, where)
    if lines:
        raise ScenarioError("\n".join(lines))


def load_scenario(path: str | Path, *, check_files: bool = True) -> Scenario:
    """Read and validate a scenario TOML file.

    Raises
    ------
    ScenarioError
        naming the file, the key, what was found and what was expected.
    """
    path = Path(path)
    data = read_toml(
        path, what="scenario", expected="name, duration, [rock], [excitation]", error=ScenarioError
    )
    scn = scenario_from_dict(data, source=path)
    if check_files:
        for key, f in scn.referenced_files().items():
            if not f.is_file():
                raise ScenarioError(
                    f"{path}: key '{key}': file not found: {f} (expected an existing file{_maker_hint(f)})"
                )
    return scn


def _maker_hint(missing: Path) -> str:
    """``"; it is derived, not committed: `python X.py` writes it"`` when a script beside ``missing`` names it.

    A derived input that is not committed (SP2's mesh, reconstructed from the shared point cloud by
    ``examples/validation/make_sp2_mesh.py``) is written by a script in the scenario's folder whose
    module docstring starts with what it writes; the hint names that script. Only the first 1,000
    characters of each ``*.py`` beside the file are read; nothing is run.
    """
    try:
        scripts = sorted(missing.parent.glob("*.py"))
    except OSError:
        return ""
    for script in scripts:
        try:
            head = script.read_text(errors="replace")[:1000]
        except OSError:
            continue
        if missing.name in head:
            return f"; it is derived, not committed: `python {script}` writes it"
    return ""


def scenario_from_dict(data: dict[str, Any], *, source: Path | None = None) -> Scenario:
    """Validate parsed scenario tables; ``source`` (the file) anchors relative paths and messages.

    Raises
    ------
    ScenarioError
        naming the file, the key, what was found and what was expected.
    """
    scn = _validate(data, source)
    if source is not None:
        scn._base_dir = Path(source).resolve().parent
        scn._source = Path(source)
    return scn


def save_scenario(scn: Scenario, path: str | Path) -> None:
    """Write ``scn`` as TOML to ``path`` (round-trips through :func:`load_scenario`)."""
    Path(path).write_text(scn.to_toml())


def deg(x: float) -> float:
    """Degrees -> radians (``x`` in °, returns rad)."""
    return math.radians(x)
