"""Compile a :class:`~pbr_xval.scenario.Scenario` into the :class:`Scene` engines simulate.

The scene is plain data in SI units, in the *scene frame*: z up, the pedestal surface at z = 0
under the rock, the rock at rest on it with its centre of mass on the z axis. Ground motion is
an :class:`~pbr_xval.motion.Excitation3D` (acceleration of the pedestal, m/s²).

Compiling models only what the scene requires and records each choice in
``Scene.reductions`` (e.g. "box primitive" for a box rock, "plane" for a flat pedestal).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING, Any, Literal, NotRequired, Required, TypedDict

import numpy as np

from pbr_xval import scenario as sc
from pbr_xval.geometry.stability import StabilityTable, critical_tilt, uplift_lever
from pbr_xval.motion.base import Excitation3D, GroundMotion

if TYPE_CHECKING:
    import trimesh

__all__ = [
    "BoxPedestalSpec",
    "BoxPrimitive",
    "CollisionSpec",
    "MeshPedestalSpec",
    "PedestalSpec",
    "PlanarModel",
    "PlanePedestalSpec",
    "RockModel",
    "Scene",
    "compile_scene",
]


# ------------------------------------------------------------- typed specs
# Plain dictionaries at run time (engines index them, they hash and pickle as before), typed
# for the checker: ``if ped["kind"] == "box"`` narrows a PedestalSpec to BoxPedestalSpec.
class BoxPrimitive(TypedDict):
    """A box rock as a primitive: ``half_extents`` (3,) m along the body axes (``RockModel.rotation``)."""

    type: Literal["box"]
    half_extents: list[float]


#: a flat pedestal: the plane z = 0 (``from`` = ``"box"`` when a box pedestal was reduced to its top)
PlanePedestalSpec = TypedDict("PlanePedestalSpec", {"kind": Literal["plane"], "from": NotRequired[str]})


class BoxPedestalSpec(TypedDict):
    """A box pedestal, top face at z = 0: ``half_extents`` (3,) m."""

    kind: Literal["box"]
    half_extents: list[float]


class MeshPedestalSpec(TypedDict):
    """A mesh pedestal in the scene frame (m); ``info`` = how the file was read (path, hash, units)."""

    kind: Literal["mesh"]
    mesh: trimesh.Trimesh
    info: dict[str, Any]


#: the pedestal as simulated
PedestalSpec = PlanePedestalSpec | BoxPedestalSpec | MeshPedestalSpec


class CollisionSpec(TypedDict, total=False):
    """The rock's contact geometry chosen by the compiler (mass properties are the full mesh's).

    ``kind``: ``"primitive"`` (:class:`BoxPrimitive`), ``"boxes"`` (``RockModel.box_parts``),
    ``"hull"``, ``"coacd"`` or ``"decimated"``; ``parts``: [(vertices (n, 3) m, faces (m, 3)
    int)] in the scene frame for the mesh kinds that were computed; ``report``/``threshold``
    (CoACD), ``cell``/``band`` (decimation, m).
    """

    kind: Required[str]
    parts: list[tuple[np.ndarray, np.ndarray]]
    report: dict[str, Any]
    threshold: float
    cell: float
    band: float


@dataclass
class RockModel:
    """The rigid rock as simulated.

    Attributes
    ----------
    shape : the scenario's shape kind.
    mass : kg.
    com : (3,) m, scene frame at rest.
    inertia : (3, 3) kg·m² about the COM, scene axes at rest.
    mesh : closed trimesh in the scene frame at rest (collision and display).
    primitive : ``{"type": "box", "half_extents": [...]}`` (body axes) when the rock is a box.
    box_parts : exact decomposition into boxes ``[(centre (3,), half_extents (3,)), ...]``
        in the scene frame, when one exists (notched block).
    rotation : (3, 3) body (primitive/mesh-native) axes → scene axes at rest.
    info : provenance (source file hash, units, repairs made).
    """

    shape: str
    mass: float
    com: np.ndarray
    inertia: np.ndarray
    mesh: trimesh.Trimesh
    primitive: BoxPrimitive | None = None
    box_parts: list[tuple[np.ndarray, np.ndarray]] | None = None
    rotation: np.ndarray = field(default_factory=lambda: np.eye(3))
    info: dict[str, Any] = field(default_factory=dict)

    @cached_property
    def stability(self) -> StabilityTable:
        """Critical tilt α(φ) and uplift levers on 72 directions (cached by geometry across scenes)."""
        return _stability_table(self.mesh.vertices, self.com)


def _content_key(*arrays: np.ndarray) -> str:
    """SHA-256 over the exact bytes of ``arrays`` (each as given: callers fix the dtypes), the key of
    the scene's per-process memos."""
    import hashlib

    h = hashlib.sha256()
    for a in arrays:
        h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()


_STABILITY_CACHE: dict[str, StabilityTable] = {}


def _stability_table(vertices: np.ndarray, com: np.ndarray) -> StabilityTable:
    """StabilityTable, memoised on the exact vertex and COM bytes.

    Threshold searches and sweeps compile the same rock many times with different motions;
    the table (72 root-finds on the hull) is the costliest part of compiling.
    """
    key = _content_key(np.asarray(vertices, dtype=np.float64), np.asarray(com, dtype=np.float64))
    table = _STABILITY_CACHE.get(key)
    if table is None:
        if len(_STABILITY_CACHE) > 256:
            _STABILITY_CACHE.clear()
        table = _STABILITY_CACHE[key] = StabilityTable(vertices, com)
    return table


_MESH_CACHE: dict[str, tuple[Any, float, np.ndarray, np.ndarray, np.ndarray, float]] = {}
_HULL_CACHE: dict[str, Any] = {}


def _mesh_key(mesh: trimesh.Trimesh, *extra: float) -> str:
    """:func:`_content_key` of a mesh's vertices and faces (and ``extra`` numbers)."""
    return _content_key(
        np.asarray(mesh.vertices, dtype=np.float64),
        np.asarray(mesh.faces, dtype=np.int64),
        np.asarray(extra, dtype=np.float64),
    )


def rock_hull(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """The convex hull of ``mesh`` (trimesh's, qhull), memoised on the mesh's exact bytes.

    Every member of an ensemble compiles the same rock into a fresh mesh object, so trimesh's own
    per-object cache never hits; this one does. Returns a copy (the caller may change it).
    """
    key = _mesh_key(mesh)
    hull = _HULL_CACHE.get(key)
    if hull is None:
        if len(_HULL_CACHE) >= 16:
            _HULL_CACHE.clear()
        hull = _HULL_CACHE[key] = mesh.convex_hull
    return hull.copy()


def _mesh_geometry(
    mesh: trimesh.Trimesh, transform: np.ndarray | None, key: str
) -> tuple[Any, float, np.ndarray, np.ndarray, np.ndarray, float]:
    """What a rock's mass properties need of its mesh, memoised on ``key`` (:func:`_mesh_key` of the
    loaded mesh and its yaw): an ensemble compiles the same rock once per member with another mass,
    friction or time step, and the mesh integrals (passes over every triangle: most of the cost of
    compiling a scanned rock) depend on none of them.

    Returns (the posed mesh, shifted so that the COM is on the z axis and the base on z = 0; volume
    m³; centre of mass (3,) m before the shift; inertia at unit density (3, 3) m⁵ — trimesh's matrix
    before its final multiplication by the density, so ``inertia * density`` is trimesh's result
    bit for bit; the shift (3,) m; the shifted mesh's volume m³). Callers get copies of the mesh
    (:func:`_rock_model`).
    """
    hit = _MESH_CACHE.get(key)
    if hit is not None:
        return hit
    if transform is not None:
        mesh.apply_transform(transform)
    mesh.density = 1.0
    mp = mesh.mass_properties
    volume = float(mp["volume"])
    com = np.asarray(mp["center_mass"], dtype=float)
    inertia_unit = np.asarray(mp["inertia"], dtype=float)  # × 1.0: trimesh's matrix exactly
    shift = np.array([-com[0], -com[1], -mesh.bounds[0, 2]])
    mesh.apply_translation(shift)
    out = (mesh, volume, com, inertia_unit, shift, float(mesh.volume))
    if len(_MESH_CACHE) >= 8:
        _MESH_CACHE.clear()
    _MESH_CACHE[key] = out
    return out


@dataclass(frozen=True)
class PlanarModel:
    """The rock seen in the shaking plane (x' along the shaking, z up), for 2-D models.

    Pivots are relative to the COM, m; ``inertia`` is about the axis ⟂ to the plane (kg·m²).
    """

    mass: float
    inertia: float
    left: tuple[float, float]
    right: tuple[float, float]


class _Delayed(GroundMotion):
    """A motion that starts ``delay`` seconds late (zero before)."""

    def __init__(self, base: GroundMotion, delay: float) -> None:
        self.base, self.delay = base, float(delay)
        self.name = base.name

    # (n,) in, (n,) out: the kernels of the base motion, shifted
    def _acceleration(self, t: np.ndarray) -> np.ndarray:
        return self.base._acceleration(t - self.delay)

    def _velocity(self, t: np.ndarray) -> np.ndarray:
        return self.base._velocity(t - self.delay)

    def _displacement(self, t: np.ndarray) -> np.ndarray:
        return self.base._displacement(t - self.delay)

    @property
    def duration(self) -> float:
        return self.base.duration + self.delay

    @property
    def breakpoints(self) -> tuple[float, ...]:
        return (0.0, *(b + self.delay for b in self.base.breakpoints))

    def describe(self) -> dict[str, Any]:
        return {**self.base.describe(), "start_time": self.delay}


class _Zero(GroundMotion):
    name = "none"

    def _acceleration(self, t: np.ndarray) -> np.ndarray:
        return np.zeros_like(t)

    _velocity = _acceleration
    _displacement = _acceleration

    @property
    def duration(self) -> float:
        return 0.0

    def describe(self) -> dict[str, Any]:
        return {"type": "none"}


@dataclass
class Scene:
    """Everything an engine needs, engine-neutral, SI units.

    Attributes
    ----------
    name, scenario_hash : identity and provenance of the source scenario.
    rock : :class:`RockModel`.
    pedestal : :data:`PedestalSpec`: ``{"kind": "plane"}``, ``{"kind": "box", "half_extents":
        [...]}`` (top at z = 0) or ``{"kind": "mesh", "mesh": trimesh, "info": {...}}``.
    collision : :class:`CollisionSpec`, the rock's contact geometry.
    mu_s, mu_d, restitution : contact parameters.
    gravity : m/s² (magnitude, along −z).
    excitation : pedestal acceleration, :class:`Excitation3D`.
    direction : (3,) unit horizontal shaking direction.
    duration, settle_time, output_dt : s.
    theta0, omega0 : initial rocking angle (rad) and rate (rad/s) in the shaking plane.
    toppling : the scenario's toppling criterion.
    engine_settings : per-engine overrides from the scenario.
    reductions : list of {"what", "choice", "why"} records of modelling choices.
    """

    name: str
    scenario_hash: str
    scenario: sc.Scenario
    rock: RockModel
    pedestal: PedestalSpec
    mu_s: float
    mu_d: float
    restitution: float
    gravity: float
    excitation: Excitation3D
    direction: np.ndarray
    duration: float
    settle_time: float
    output_dt: float
    seed: int
    theta0: float
    omega0: float
    toppling: sc.Toppling
    engine_settings: dict[str, dict[str, Any]]
    reductions: list[dict[str, str]] = field(default_factory=list)
    collision: CollisionSpec = field(default_factory=lambda: CollisionSpec(kind="hull"))
    basal_nodes: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))

    # ------------------------------------------------------------ geometry
    @property
    def azimuth(self) -> float:
        """Shaking direction, rad from +x toward +y."""
        return float(math.atan2(self.direction[1], self.direction[0]))

    @property
    def rocking_axis(self) -> np.ndarray:
        """(3,) unit axis ez × d: a positive rotation about it moves the top toward +d."""
        return np.cross([0.0, 0.0, 1.0], self.direction)

    @cached_property
    def alpha(self) -> tuple[float, float]:
        """Critical tilt angles (rad) toward −d and +d (the 'left' and 'right' sides)."""
        v, c, d = self.rock.mesh.vertices, self.rock.com, self.direction
        return critical_tilt(v, c, -d), critical_tilt(v, c, d)

    @cached_property
    def _uplift_levers(self) -> dict[float, tuple[float, float]]:
        """(b, h) m of :func:`uplift_lever` for pedestal accelerations along +d (key 1.0) and −d (−1.0)."""
        v, c, d = self.rock.mesh.vertices, self.rock.com, self.direction
        return {s: uplift_lever(v, c, -s * d) for s in (1.0, -1.0)}

    def uplift_accel(self, sign: float = 1.0) -> float:
        """Quasi-static pedestal acceleration (m/s²) along ``sign``·d that starts rocking.

        A pedestal accelerating along +d tips the rock toward −d.
        """
        lev = self._uplift_levers.get(sign)
        b, h = (
            lev
            if lev is not None
            else uplift_lever(self.rock.mesh.vertices, self.rock.com, -sign * self.direction)
        )
        return self.gravity * b / h

    def planar_model(self) -> PlanarModel:
        """The rock as a planar two-pivot body in the shaking plane.

        Raises
        ------
        NotApplicable
            when the rock does not rock on two edges ⟂ to the shaking (e.g. a box shaken
            along a diagonal, or a rock whose inertia couples in- and out-of-plane motion).
        """
        from pbr_xval.errors import NotApplicable
        from pbr_xval.geometry.stability import hull_vertices, support_points

        d, e = self.direction, self.rocking_axis
        sp = support_points(hull_vertices(self.rock.mesh.vertices)) - self.rock.com
        xs = sp @ d
        size = float(np.ptp(self.rock.mesh.vertices))
        for side, xv in (("left", xs.min()), ("right", xs.max())):
            edge = sp[np.abs(xs - xv) <= 1e-9 * size]
            if len(edge) < 2 or np.ptp(edge @ e) <= 1e-6 * size:
                raise NotApplicable(
                    f"scene {self.name!r}: the rock does not pivot on an edge ⟂ to the shaking on the {side} "
                    f"(it would rock about a corner); a planar model does not apply — use a 3-D engine"
                )
        i = self.rock.inertia
        coupling = np.linalg.norm(i @ e - (e @ i @ e) * e) / (e @ i @ e)
        if coupling > 1e-6:
            raise NotApplicable(
                f"scene {self.name!r}: the rock's inertia couples rocking in the shaking plane with "
                f"out-of-plane motion (relative product of inertia {coupling:.2e}); a planar model does not apply"
            )
        h = float(self.rock.com[2] - (sp[:, 2].min() + self.rock.com[2]))
        return PlanarModel(
            mass=self.rock.mass,
            inertia=float(e @ i @ e),
            left=(float(xs.min()), -h),
            right=(float(xs.max()), -h),
        )

    @property
    def excitation_end(self) -> float:
        """float, s: time after which the pedestal no longer accelerates (the frame is inertial)."""
        return float(self.excitation.duration)

    def past_critical(self, rot: np.ndarray) -> bool:
        """Whether the rock's tilt is at or beyond its critical tilt α(φ) in its tilt direction.

        Parameters
        ----------
        rot : (3, 3) — rotation of the rock relative to its rest pose.
        """
        top = rot[:, 2]
        tilt = math.acos(max(-1.0, min(1.0, float(top[2]))))
        if tilt < 1e-9:
            return False
        phi = math.atan2(top[1], top[0])
        return tilt >= float(self.rock.stability.alpha_at(phi))

    def is_toppled(self, com: np.ndarray, rot: np.ndarray) -> bool:
        """Apply a first-crossing toppling criterion to one state.

        For ``criterion = "physical"`` this answers "is the rock down" (tilt ≥ the down angle);
        the physical decision itself needs the history and is taken by the engines' recorder
        (:class:`pbr_xval.stepping.Recorder`) and the analytical integrators.

        Parameters
        ----------
        com : (3,) m — COM position (pedestal frame).
        rot : (3, 3) — rotation of the rock relative to its rest pose.
        """
        crit = self.toppling
        if crit.criterion == "com_displacement":
            return bool(np.hypot(com[0] - self.rock.com[0], com[1] - self.rock.com[1]) >= crit.distance)
        top = rot[:, 2]
        tilt = math.acos(max(-1.0, min(1.0, float(top[2]))))
        if crit.criterion == "tilt_angle":
            return tilt >= math.radians(float(crit.angle_deg or 0.0))  # set: validated by Toppling
        if crit.criterion == "physical":
            return tilt >= math.radians(crit.down_angle_deg)
        if tilt < 1e-9:
            return False
        phi = math.atan2(top[1], top[0])
        return tilt >= crit.factor * float(self.rock.stability.alpha_at(phi))

    def info(self) -> dict[str, Any]:
        """Facts every Trajectory carries in ``scene_info``."""
        a_left, a_right = self.alpha
        return {
            "name": self.name,
            "rock_shape": self.rock.shape,
            "mass_kg": self.rock.mass,
            "com_m": self.rock.com.tolist(),
            "alpha_left_rad": a_left,
            "alpha_right_rad": a_right,
            "uplift_accel_m_s2": self.uplift_accel(1.0),
            "azimuth_rad": self.azimuth,
            "gravity": self.gravity,
            "excitation": self.excitation.describe(),
            "reductions": list(self.reductions),
            "rock_info": dict(self.rock.info),
            "toppling": self.toppling.describe(),
            "excitation_end_s": self.excitation_end,
        }


# --------------------------------------------------------------------- compile
def _rock_model(scn: sc.Scenario, reductions: list[dict[str, str]]) -> tuple[float, RockModel]:
    """(the rock mesh's volume in the scene frame, m³; the rock model)."""
    from pbr_xval.geometry import shapes

    rock = scn.rock
    yaw = math.radians(rock.yaw_deg)
    rz = np.array(
        [[math.cos(yaw), -math.sin(yaw), 0.0], [math.sin(yaw), math.cos(yaw), 0.0], [0.0, 0.0, 1.0]]
    )
    primitive: BoxPrimitive | None = None
    box_parts = None
    info: dict[str, Any] = {}
    if isinstance(rock, sc.BoxRock):
        mesh = shapes.box_mesh(np.array(rock.half_extents))
        primitive = {"type": "box", "half_extents": list(rock.half_extents)}
    elif isinstance(rock, sc.NotchedBlockRock):
        mesh = shapes.notched_block_mesh(np.array(rock.half_extents), rock.notch_width, rock.notch_height)
        box_parts = shapes.notched_block_boxes(
            np.array(rock.half_extents), rock.notch_width, rock.notch_height
        )
    elif isinstance(rock, sc.CurvedBaseRock):
        mesh = shapes.curved_base_mesh(rock.H, rock.r, rock.h, rock.depth, rock.arc_segments)
        reductions.append(
            {
                "what": "rock geometry",
                "choice": f"extruded profile, {rock.arc_segments} facets per quarter arc",
                "why": "3-D engines need a mesh of the curved base",
            }
        )
    elif isinstance(rock, sc.MeshRock):
        from pbr_xval.geometry.interface import NotAtRestError, load_rock_mesh

        try:
            mesh, info = load_rock_mesh(
                scn.resolve_path(rock.path), units=rock.units, pose=rock.pose, hint='use pose = "settle"'
            )
        except NotAtRestError as exc:
            raise sc.ScenarioError(f"scenario {scn.name!r}: key 'rock.pose': {exc}") from None
    else:  # pragma: no cover - the union is closed
        raise TypeError(type(rock))

    transform = np.block([[rz, np.zeros((3, 1))], [np.zeros((1, 3)), np.ones((1, 1))]]) if yaw else None
    if box_parts is not None and yaw:
        box_parts = [(rz @ c, h) for c, h in box_parts]
    # the mesh integrals and the shift, once per mesh (an ensemble's members share them)
    shared, volume, com, inertia_unit, shift, shifted_volume = _mesh_geometry(
        mesh, transform, _mesh_key(mesh, rock.yaw_deg)
    )
    if not (volume > 0):
        raise sc.ScenarioError(
            f"scenario {scn.name!r}: key 'rock': the rock mesh has volume {volume} m³ (expected > 0)"
        )
    mesh = shared.copy()
    if rock.density is not None:
        density = rock.density
    else:
        assert rock.mass is not None  # the scenario requires density or mass
        density = rock.mass / volume
    mesh.density = density
    mass = density * volume  # trimesh's MassProperties.mass
    inertia = inertia_unit * density  # trimesh's MassProperties.inertia
    if isinstance(rock, sc.MeshRock) and rock.inertia is not None:
        ixx, iyy, izz, ixy, ixz, iyz = rock.inertia
        inertia = rz @ np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]]) @ rz.T
        info["inertia_source"] = "scenario"
    # the COM on the z axis; the base already sits on z = 0 (the shift was applied to the mesh)
    com = com + shift
    if box_parts is not None:
        box_parts = [(c + shift, h) for c, h in box_parts]
    info.update(volume_m3=volume, density_kg_m3=density)
    return shifted_volume, RockModel(
        shape=rock.shape,
        mass=float(mass),
        com=com,
        inertia=inertia,
        mesh=mesh,
        primitive=primitive,
        box_parts=box_parts,
        rotation=rz,
        info=info,
    )


def _choose_collision(scn: sc.Scenario, rock: RockModel, reductions: list[dict[str, str]]) -> CollisionSpec:
    """The rock's contact geometry (mass properties are always the full mesh's)."""
    opt = scn.model
    kind = opt.collision
    if kind == "auto":
        if rock.primitive is not None:
            kind, why = "primitive", "the rock is a box"
        elif rock.box_parts is not None:
            kind, why = "boxes", f"the rock is exactly {len(rock.box_parts)} boxes"
        else:
            kind, why = "hull", "a flat pedestal touches only the convex hull (concavities cannot reach it)"
    else:
        why = "scenario model.collision"
    if kind == "primitive" and rock.primitive is None:
        raise sc.ScenarioError(
            f"scenario {scn.name!r}: key 'model.collision': 'primitive' needs a box rock, found {rock.shape!r}"
        )
    if kind == "boxes" and rock.box_parts is None:
        raise sc.ScenarioError(
            f"scenario {scn.name!r}: key 'model.collision': 'boxes' needs a rock made of boxes, found {rock.shape!r}"
        )
    out = CollisionSpec(kind=kind)
    size = float(np.ptp(rock.mesh.vertices))
    if kind == "coacd":
        from pbr_xval.geometry.decompose import convex_parts, decomposition_report

        parts = convex_parts(rock.mesh, threshold=opt.coacd_threshold, seed=scn.seed)
        rep = decomposition_report(rock.mesh, parts)
        out["parts"] = [(np.asarray(p.vertices, float), np.asarray(p.faces, np.int64)) for p in parts]
        out["report"] = rep
        out["threshold"] = opt.coacd_threshold
        why += f"; CoACD threshold {opt.coacd_threshold}: {rep['n_parts']} parts, volume error {rep['rel_volume_error']:+.2e}"
    elif kind == "decimated":
        from pbr_xval.geometry.reduce import decimate_keep_base

        cell = opt.decimate_cell or size / 20
        band = opt.basal_band or 0.02 * float(np.ptp(rock.mesh.vertices[:, 2]))
        dec = decimate_keep_base(rock.mesh, cell, band)
        out["parts"] = [(np.asarray(dec.vertices, float), np.asarray(dec.faces, np.int64))]
        out["cell"], out["band"] = cell, band
        why += f"; {len(rock.mesh.faces)} → {len(dec.faces)} faces, cell {cell:.3g} m, base band {band:.3g} m kept"
    elif kind == "hull":
        hull = rock_hull(rock.mesh)
        why += f"; {len(hull.vertices)} hull vertices"
    reductions.append({"what": "rock collision", "choice": kind, "why": why})
    return out


def _motion(spec: Any, scn: sc.Scenario, uplift: float | None) -> GroundMotion:
    from pbr_xval.motion import pulses

    t = spec.type
    if t == "half_sine":
        if spec.phase == "housner_uplift":
            if uplift is None:
                raise sc.ScenarioError(
                    f"scenario {scn.name!r}: 'housner_uplift' phase is only for horizontal motion"
                )
            m: GroundMotion = pulses.HalfSine.housner(spec.amplitude, uplift, spec.frequency)
        else:
            m = pulses.HalfSine(spec.amplitude, spec.frequency, spec.phase)
    elif t == "sawtooth":
        m = pulses.Sawtooth(spec.pgv, spec.period, spec.skew)
    elif t == "one_sine":
        m = pulses.OneSine(spec.amplitude, spec.frequency)
    elif t == "one_cosine":
        m = pulses.OneCosine(spec.amplitude, spec.frequency)
    elif t == "rectangular":
        m = pulses.Rectangular(spec.amplitude, spec.pulse_duration)
    elif t == "ricker":
        m = pulses.Ricker(spec.amplitude, spec.frequency, spec.t0)
    elif t == "record":
        from pbr_xval.motion.processing import RecordSpecError, record_from_spec

        horizontal = spec is scn.excitation
        try:
            m = record_from_spec(
                spec,
                scn.resolve_path,
                azimuth_deg=scn.excitation.azimuth_deg if horizontal else None,
                key="excitation" if horizontal else "excitation.vertical",
            )
        except RecordSpecError as exc:
            raise sc.ScenarioError(f"scenario {scn.name!r}: {exc}") from None
    elif t == "none":
        return _Zero()
    else:  # pragma: no cover
        raise TypeError(t)
    if spec.start_time:
        m = _Delayed(m, spec.start_time)
    return m


def compile_scene(scn: sc.Scenario) -> Scene:
    """Build the :class:`Scene` for ``scn``, recording every modelling choice."""
    reductions: list[dict[str, str]] = []
    mesh_volume, rock = _rock_model(scn, reductions)
    from pbr_xval.plausibility import check_rock

    check_rock(scn.rock, rock.mass, mesh_volume, rock.mesh.extents, where=f"scenario {scn.name!r}")
    az = math.radians(scn.excitation.azimuth_deg)
    direction = np.array([math.cos(az), math.sin(az), 0.0])
    if abs(direction[0]) < 1e-15:
        direction[0] = 0.0
    if abs(direction[1]) < 1e-15:
        direction[1] = 0.0

    collision = _choose_collision(scn, rock, reductions)
    ped = scn.pedestal
    if isinstance(ped, sc.PlanePedestal):
        pedestal: PedestalSpec = {"kind": "plane"}
        reductions.append({"what": "pedestal", "choice": "plane", "why": "flat pedestal"})
    elif isinstance(ped, sc.BoxPedestal):
        pedestal = {"kind": "box", "half_extents": list(ped.half_extents)}
        foot = rock.mesh.vertices[:, :2]
        covers = bool(np.all(np.abs(foot) <= np.asarray(ped.half_extents[:2]) - 1e-9))
        if scn.model.pedestal == "plane" or (scn.model.pedestal == "auto" and covers):
            pedestal = {"kind": "plane", "from": "box"}
            reductions.append(
                {
                    "what": "pedestal",
                    "choice": "plane",
                    "why": "the box pedestal's top face extends beyond the rock's footprint: only that face can be touched",
                }
            )
        else:
            reductions.append(
                {"what": "pedestal", "choice": "box", "why": "the rock overhangs the pedestal's edge"}
            )
    else:
        from pbr_xval.geometry.mesh import load_mesh

        pm, pinfo = load_mesh(scn.resolve_path(ped.path), units=ped.units)
        pedestal = {"kind": "mesh", "mesh": pm, "info": pinfo}

    # uplift acceleration of a positive pulse along +d (tips the rock toward -d)
    b, h = uplift_lever(rock.mesh.vertices, rock.com, -direction)
    uplift = scn.gravity * b / h
    horiz = _motion(scn.excitation, scn, uplift)
    vert = _motion(scn.excitation.vertical, scn, None) if scn.excitation.vertical is not None else None
    excitation = Excitation3D(horiz, az, vert)

    from pbr_xval.geometry.reduce import basal_nodes

    count = None if scn.model.basal_nodes == "auto" else int(scn.model.basal_nodes)
    nodes = basal_nodes(rock.mesh.vertices, rock.com, count, scn.model.basal_band)
    reductions.append(
        {
            "what": "basal nodes (reference solver)",
            "choice": f"{len(nodes)} nodes",
            "why": "convex-hull vertices below the COM"
            if count is None
            else f"support polygon filled with ~{count} nodes",
        }
    )

    theta0 = scn.initial.theta
    if scn.initial.theta_over_alpha is not None:
        a_left, a_right = (
            critical_tilt(rock.mesh.vertices, rock.com, -direction),
            critical_tilt(rock.mesh.vertices, rock.com, direction),
        )
        f = scn.initial.theta_over_alpha
        theta0 = f * (a_right if f >= 0 else a_left)

    return Scene(
        name=scn.name,
        scenario_hash=scn.content_hash(),
        scenario=scn,
        rock=rock,
        pedestal=pedestal,
        mu_s=scn.contact.friction_static,
        mu_d=scn.contact.mu_d,
        restitution=scn.contact.restitution,
        gravity=scn.gravity,
        excitation=excitation,
        direction=direction,
        duration=scn.duration,
        settle_time=scn.settle_time,
        output_dt=scn.output_dt,
        seed=scn.seed,
        theta0=float(theta0),
        omega0=float(scn.initial.omega),
        toppling=scn.toppling,
        engine_settings={k: dict(v) for k, v in scn.engines.items()},
        reductions=reductions,
        collision=collision,
        basal_nodes=nodes,
    )
