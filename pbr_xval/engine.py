"""Engine interface, registry and the :class:`Trajectory` every engine returns.

Every solver in pbr-xval — the analytical references, our LCP reference solver and the
PyBullet, MuJoCo and DART adapters — answers through one small protocol::

    engine = get_engine("mujoco")
    settings = engine.default_settings()          # complete, explicit dict
    traj = engine.simulate(scene, settings)       # -> Trajectory

Engines register through the entry-point group ``pbr_xval.engines`` as ``"module:Class"``
strings; nothing is imported until an engine is asked for, so ``import pbr_xval`` loads no
physics engine. A missing third-party package gives an install hint (:data:`KNOWN_ENGINES`).
"""

from __future__ import annotations

import dataclasses
import functools
import importlib
import importlib.metadata
import importlib.util
import json
import os
import platform
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar, Protocol, runtime_checkable

import numpy as np

from pbr_xval.errors import EngineNotAvailable, EngineSettingsError, NotApplicable
from pbr_xval.jsonio import jsonable as _jsonable
from pbr_xval.registry import ENTRY_POINT_GROUP, refresh_engines, registered_names
from pbr_xval.registry import entry_points as _entry_points
from pbr_xval.status import RunStatus

if TYPE_CHECKING:
    import pandas as pd

    from pbr_xval.scene import Scene

__all__ = [
    "ENTRY_POINT_GROUP",
    "KNOWN_ENGINES",
    "Capabilities",
    "Engine",
    "EngineNotAvailable",
    "EngineSettingsError",
    "Event",
    "NotApplicable",
    "RunStatus",
    "Trajectory",
    "get_engine",
    "list_engines",
    "merge_settings",
    "refresh_engines",
    "registered_names",
]

#: engine name -> the pip package that provides it (for install hints)
KNOWN_ENGINES: dict[str, str] = {
    "mujoco": "mujoco-core",
    "pybullet": "pybullet",
    "dart": "dartpy",
}


@dataclass(frozen=True)
class Capabilities:
    """What an engine can model; conformance checks and studies adapt to these tags.

    Attributes
    ----------
    dims : 2 for planar models, 3 for full 6-DOF bodies.
    shapes : rock shape kinds accepted (``"box"``, ``"notched_block"``, ``"curved_base"``, ``"mesh"``).
    sliding : whether friction/sliding is modelled (False: the contact never slips).
    restitution : whether a restitution coefficient is an input.
    vertical : whether vertical ground acceleration is modelled.
    deterministic : same scene + same settings gives a bit-identical trajectory.
    analytical : an analytical (reference) solution rather than a time-stepping engine.
    """

    dims: int = 3
    shapes: frozenset[str] = frozenset({"box", "notched_block", "curved_base", "mesh"})
    sliding: bool = True
    restitution: bool = True
    vertical: bool = True
    deterministic: bool = True
    analytical: bool = False

    def to_dict(self) -> dict[str, Any]:
        """The tags as plain JSON values (``shapes`` as a sorted list)."""
        d = dataclasses.asdict(self)
        d["shapes"] = sorted(self.shapes)
        return d


@dataclass(frozen=True)
class Event:
    """A discrete event in a trajectory.

    ``kind`` is one of ``"uplift"``, ``"impact"``, ``"rest"``, ``"toppled"``, ``"failed"``
    (engines may add others); ``t`` is the time in s from the start of the excitation;
    ``data`` holds kind-specific values (e.g. ``ratio`` for impacts) in SI units.
    """

    kind: str
    t: float
    data: Mapping[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """``{"kind", "t" (s), **data}`` as plain JSON values (:func:`pbr_xval.jsonio.jsonable`)."""
        return {"kind": self.kind, "t": float(self.t), **{k: _jsonable(v) for k, v in self.data.items()}}


def quat_to_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrices from unit quaternions.

    Parameters
    ----------
    q : (n, 4) float, scalar-first (w, x, y, z).

    Returns
    -------
    (n, 3, 3) float
    """
    q = np.asarray(q, dtype=float)
    w, x, y, z = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    r = np.empty((q.shape[0], 3, 3))
    r[:, 0, 0] = 1 - 2 * (y * y + z * z)
    r[:, 0, 1] = 2 * (x * y - w * z)
    r[:, 0, 2] = 2 * (x * z + w * y)
    r[:, 1, 0] = 2 * (x * y + w * z)
    r[:, 1, 1] = 1 - 2 * (x * x + z * z)
    r[:, 1, 2] = 2 * (y * z - w * x)
    r[:, 2, 0] = 2 * (x * z - w * y)
    r[:, 2, 1] = 2 * (y * z + w * x)
    r[:, 2, 2] = 1 - 2 * (x * x + y * y)
    return r


def axis_angle_quat(axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Quaternions (n, 4), scalar first, for rotations by ``angle`` (n,) rad about a unit ``axis`` (3,)."""
    angle = np.asarray(angle, dtype=float)
    axis = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    half = 0.5 * angle
    q = np.empty((angle.size, 4))
    q[:, 0] = np.cos(half)
    q[:, 1:] = np.sin(half)[:, None] * axis[None, :]
    return q


@dataclass
class Trajectory:
    """What one simulation returns, engine-neutral, in SI units.

    Positions are in the pedestal frame (z up, the pedestal surface at z = 0 under the rock's
    initial contact), time is measured from the start of the excitation (settling, if any, is
    before t = 0 and not recorded).

    Attributes
    ----------
    engine : engine name.
    t : (n,) float, s.
    com : (n, 3) float, m — centre of mass position.
    quat : (n, 4) float — orientation of the rock, scalar-first quaternion, relative to its
        resting pose at t = 0 (identity = not tilted).
    omega : (n, 3) float, rad/s — angular velocity in the pedestal (world) frame.
    events : list of :class:`Event`.
    diagnostics : dict of scalar or small-list diagnostics (max penetration, energy drift,
        solver warnings, impacts, ...).
    settings : the complete settings dictionary used.
    versions : engine and library versions.
    scenario_hash : SHA-256 of the scenario (content + referenced files).
    scene_info : what the scene compiler chose (reductions) and geometry facts (e.g. the
        critical tilt angle in the excitation direction, rad).
    excitation_axis : (3,) unit horizontal vector of the shaking direction.
    wall_time : s of wall-clock time spent in ``simulate``.
    status : :class:`~pbr_xval.status.RunStatus` (``"ok"`` or ``"failed"``); ``message`` says why a run failed.
    """

    engine: str
    t: np.ndarray
    com: np.ndarray
    quat: np.ndarray
    omega: np.ndarray
    events: list[Event] = field(default_factory=list)
    diagnostics: dict[str, Any] = field(default_factory=dict)
    settings: dict[str, Any] = field(default_factory=dict)
    versions: dict[str, str] = field(default_factory=dict)
    scenario_hash: str = ""
    scene_info: dict[str, Any] = field(default_factory=dict)
    excitation_axis: np.ndarray = field(default_factory=lambda: np.array([1.0, 0.0, 0.0]))
    wall_time: float = 0.0
    status: RunStatus = RunStatus.OK
    message: str = ""

    SCHEMA_VERSION: ClassVar[int] = 1

    # ------------------------------------------------------------------ derived
    @property
    def ok(self) -> bool:
        """True if the run completed (``status`` is :attr:`RunStatus.OK`), toppled or not."""
        return self.status == RunStatus.OK

    @property
    def toppled(self) -> bool:
        """True if a ``toppled`` event was recorded."""
        return any(e.kind == "toppled" for e in self.events)

    @property
    def toppled_at(self) -> float | None:
        """Time of the ``toppled`` event, s from the start of the excitation; None if it stood."""
        for e in self.events:
            if e.kind == "toppled":
                return e.t
        return None

    def impacts(self) -> list[Event]:
        """The ``impact`` events, in time order (``t`` in s; ``data`` e.g. the velocity ratio)."""
        return [e for e in self.events if e.kind == "impact"]

    @property
    def regime(self) -> str:
        """What the rock did, from the standard diagnostics (:mod:`pbr_xval.diagnostics`):
        ``"at rest"``, ``"rocked"``, ``"slid 0.12 m"``, ``"rocked and slid 0.012 m"``, with
        ``", jumped (0.03 s airborne)"`` when it lost all contact; ``"unknown"`` without them."""
        from pbr_xval.diagnostics import regime_label

        return regime_label(self.diagnostics)

    def rotation_matrices(self) -> np.ndarray:
        """(n, 3, 3) rotation matrices of the rock relative to its resting pose."""
        return quat_to_matrix(self.quat)

    def tilt(self) -> np.ndarray:
        """(n,) tilt angle in rad: angle between the rock's initially vertical axis and the vertical."""
        r = self.rotation_matrices()
        return np.arccos(np.clip(r[:, 2, 2], -1.0, 1.0))

    def rocking_angle(self) -> np.ndarray:
        """(n,) planar rocking angle θ in rad about the horizontal axis ⟂ to the shaking.

        θ > 0 is a rotation about ``ez × d`` (d the shaking direction): the top moves toward
        +d. For shaking along +x this is the rotation about +y, ``atan2(R[0,2], R[2,2])``.
        """
        d = np.asarray(self.excitation_axis, dtype=float)
        r = self.rotation_matrices()
        top = r[:, :, 2]  # image of the body z axis
        return np.arctan2(top @ d, top[:, 2])

    # ---------------------------------------------------------------- exporting
    def to_dataframe(self) -> pd.DataFrame:
        """One row per sample: t, COM (m), quaternion, ω (rad/s), θ and tilt (rad)."""
        import pandas as pd

        return pd.DataFrame(
            {
                "t": self.t,
                "com_x": self.com[:, 0],
                "com_y": self.com[:, 1],
                "com_z": self.com[:, 2],
                "q_w": self.quat[:, 0],
                "q_x": self.quat[:, 1],
                "q_y": self.quat[:, 2],
                "q_z": self.quat[:, 3],
                "omega_x": self.omega[:, 0],
                "omega_y": self.omega[:, 1],
                "omega_z": self.omega[:, 2],
                "theta": self.rocking_angle(),
                "tilt": self.tilt(),
            }
        )

    def metadata(self) -> dict[str, Any]:
        """Provenance and summary as a JSON-serialisable dict."""
        from pbr_xval.version import __version__

        return {
            "schema": self.SCHEMA_VERSION,
            "engine": self.engine,
            "status": self.status,
            "message": self.message,
            "toppled": self.toppled,
            "toppled_at": self.toppled_at,
            "events": [e.to_dict() for e in self.events],
            "diagnostics": _jsonable(self.diagnostics),
            "settings": _jsonable(self.settings),
            "versions": dict(self.versions),
            "scenario_hash": self.scenario_hash,
            "scene_info": _jsonable(self.scene_info),
            "excitation_axis": [float(x) for x in self.excitation_axis],
            "wall_time": self.wall_time,
            "pbr_xval_version": __version__,
            "machine": machine_info(),
        }

    def summary(self) -> dict[str, Any]:
        """Short, human-oriented figures (used by the CLI)."""
        theta = self.rocking_angle() if self.t.size else np.zeros(0)
        return {
            "engine": self.engine,
            "status": self.status,
            "toppled": self.toppled,
            "toppled_at_s": self.toppled_at,
            "peak_abs_theta_rad": float(np.max(np.abs(theta))) if theta.size else 0.0,
            "peak_tilt_rad": float(np.max(self.tilt())) if self.t.size else 0.0,
            "regime": self.regime,
            "impacts": int(self.diagnostics.get("impacts", len(self.impacts()))),
            "samples": int(self.t.size),
            "wall_time_s": self.wall_time,
        }

    def save_parquet(self, path: str | os.PathLike[str]) -> Path:
        """Write the samples to Parquet, provenance in the schema metadata, atomically."""
        import pyarrow as pa

        from pbr_xval.atomic import write_parquet_atomic

        table = pa.Table.from_pandas(self.to_dataframe(), preserve_index=False)
        meta = dict(table.schema.metadata or {})
        meta[b"pbr_xval"] = json.dumps(self.metadata(), sort_keys=True).encode()
        return write_parquet_atomic(path, table.replace_schema_metadata(meta))

    @classmethod
    def load_parquet(cls, path: str | os.PathLike[str]) -> Trajectory:
        """Read a trajectory written by :meth:`save_parquet`."""
        import pyarrow.parquet as pq

        table = pq.read_table(path)
        meta = json.loads(table.schema.metadata[b"pbr_xval"])
        df = table.to_pandas()
        return cls(
            engine=meta["engine"],
            t=df["t"].to_numpy(),
            com=df[["com_x", "com_y", "com_z"]].to_numpy(),
            quat=df[["q_w", "q_x", "q_y", "q_z"]].to_numpy(),
            omega=df[["omega_x", "omega_y", "omega_z"]].to_numpy(),
            events=[
                Event(e["kind"], e["t"], {k: v for k, v in e.items() if k not in ("kind", "t")})
                for e in meta["events"]
            ],
            diagnostics=meta["diagnostics"],
            settings=meta["settings"],
            versions=meta["versions"],
            scenario_hash=meta["scenario_hash"],
            scene_info=meta["scene_info"],
            excitation_axis=np.asarray(meta["excitation_axis"]),
            wall_time=meta["wall_time"],
            status=RunStatus(meta["status"]),
            message=meta["message"],
        )

    def fingerprint(self) -> str:
        """SHA-256 of the sampled arrays and events (for bit-identity checks)."""
        import hashlib

        h = hashlib.sha256()
        for a in (self.t, self.com, self.quat, self.omega):
            h.update(np.ascontiguousarray(a, dtype=np.float64).tobytes())
        h.update(json.dumps([e.to_dict() for e in self.events], sort_keys=True).encode())
        return h.hexdigest()

    @classmethod
    def failed(cls, engine: str, message: str, **kw: Any) -> Trajectory:
        """An empty trajectory marked failed, with the reason."""
        z = np.zeros((0, 3))
        return cls(
            engine=engine,
            t=np.zeros(0),
            com=z,
            quat=np.zeros((0, 4)),
            omega=z,
            events=[Event("failed", float("nan"), {"reason": message})],
            status=RunStatus.FAILED,
            message=message,
            **kw,
        )


@functools.lru_cache(maxsize=1)
@functools.cache
def _cpu_model() -> str:
    try:
        with open("/proc/cpuinfo", encoding="utf-8", errors="replace") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or ""


def machine_info() -> dict[str, str]:
    """Machine facts recorded with every result.

    ``cpu_model`` and ``blas_coretype`` (``OPENBLAS_CORETYPE`` when set, else "auto": OpenBLAS
    picks its kernels by CPU) matter because results can move with the CPU: a chaotic rocking
    run can flip on a last-bit difference (docs/validation.md, "Machine dependence").
    """
    return {
        "python": platform.python_version(),
        "platform": platform.platform(),
        "machine": platform.machine(),
        "processor": platform.processor() or "",
        "cpu_model": _cpu_model(),
        "blas_coretype": os.environ.get("OPENBLAS_CORETYPE", "auto"),
        "cpu_count": str(os.cpu_count()),
    }


# ---------------------------------------------------------------------- protocol
@runtime_checkable
class Engine(Protocol):
    """The protocol every solver implements.

    ``profiles()`` returns named, complete settings dictionaries (e.g. ``faithful`` and
    ``engine-default``); ``default_settings()`` returns the profile used when none is named.
    ``simulate`` must not raise for numerical blow-ups: it returns a failed Trajectory.
    It raises :class:`NotApplicable` for scenes the engine cannot represent.
    """

    name: ClassVar[str]
    capabilities: ClassVar[Capabilities]

    def default_settings(self) -> dict[str, Any]:
        """The complete settings of the default profile (SI units: ``timestep`` in s, …)."""
        ...

    def profiles(self) -> dict[str, dict[str, Any]]:
        """Profile name -> complete settings dictionary (e.g. ``faithful``, ``engine-default``)."""
        ...

    def versions(self) -> dict[str, str]:
        """Package name -> version of everything the engine's results depend on (provenance)."""
        ...

    def simulate(self, scene: Scene, settings: Mapping[str, Any] | None = None) -> Trajectory:
        """Simulate a compiled scene.

        Parameters
        ----------
        scene : Scene
            The reduced model in SI units, pedestal frame (z up, surface at z = 0).
        settings : mapping, optional
            A profile name (``"profile"``) and overrides of its keys; unknown keys are an error.

        Returns
        -------
        Trajectory
            Sampled every ``scene.output_dt`` s: ``t`` (n,) s, ``com`` (n, 3) m, ``quat`` (n, 4),
            ``omega`` (n, 3) rad/s, events; a numerical failure is a failed trajectory
            (``status = "failed"``), never an exception.

        Raises
        ------
        NotApplicable
            The engine cannot represent the scene.
        EngineSettingsError
            A setting is unknown or out of range.
        """
        ...


class EngineBase:
    """Convenience base class: profile handling and settings validation."""

    name: ClassVar[str] = ""
    capabilities: ClassVar[Capabilities] = Capabilities()
    #: top-level module of the third-party package the engine needs (checked by get_engine)
    requires: ClassVar[str | None] = None
    #: name of the profile ``default_settings`` returns
    default_profile: ClassVar[str] = "faithful"

    def profiles(self) -> dict[str, dict[str, Any]]:  # pragma: no cover - abstract
        """Profile name -> complete settings dictionary; every adapter defines it."""
        raise NotImplementedError

    def default_settings(self) -> dict[str, Any]:
        """A copy of the ``default_profile`` settings."""
        return dict(self.profiles()[self.default_profile])

    def versions(self) -> dict[str, str]:
        """``{"pbr_xval": version}``; adapters add their engine package's version."""
        return {"pbr_xval": _pkg_version("pbr-xval")}

    def resolve_settings(self, settings: Mapping[str, Any] | None) -> dict[str, Any]:
        """Complete settings: a profile (``settings['profile']``) plus explicit overrides.

        Unknown keys raise :class:`EngineSettingsError` naming the key and the known keys.
        """
        settings = dict(settings or {})
        profile = settings.pop("profile", self.default_profile)
        profiles = self.profiles()
        if profile not in profiles:
            raise EngineSettingsError(
                f"engine {self.name!r}: unknown profile {profile!r}; expected one of {sorted(profiles)}"
            )
        base = dict(profiles[profile])
        return merge_settings(self.name, base, settings) | {"profile": profile}


def merge_settings(engine: str, base: Mapping[str, Any], overrides: Mapping[str, Any]) -> dict[str, Any]:
    """``base`` updated by ``overrides``; unknown override keys are an error.

    The result is checked against the central table of setting types, ranges and units
    (:mod:`pbr_xval.settings_spec`) for every engine: a bad value raises
    :class:`EngineSettingsError` naming the key, what was found and what was expected.
    """
    from pbr_xval.settings_spec import check_settings

    out = dict(base)
    for k, v in overrides.items():
        if k not in base:
            raise EngineSettingsError(
                f"engine {engine!r}: unknown setting {k!r}; expected one of {sorted(base)}"
            )
        out[k] = v
    problems = check_settings(engine, out)
    if problems:
        raise EngineSettingsError("; ".join(problems))
    return out


def _pkg_version(dist: str) -> str:
    try:
        return importlib.metadata.version(dist)
    except importlib.metadata.PackageNotFoundError:
        return "not installed"


# ---------------------------------------------------------------------- registry
def list_engines() -> dict[str, dict[str, Any]]:
    """Every registered engine with its target, whether it imports, and its versions.

    Importing is attempted here (this is the one place that does), so call it only when
    the caller wants to know what is installed.
    """
    out: dict[str, dict[str, Any]] = {}
    for name, target in sorted(_entry_points().items()):
        info: dict[str, Any] = {"target": target}
        try:
            eng = get_engine(name)
            info.update(available=True, versions=eng.versions(), capabilities=eng.capabilities.to_dict())
        except EngineNotAvailable as exc:
            info.update(available=False, error=str(exc))
        out[name] = info
    return out


def get_engine(name: str | type | Engine) -> Engine:
    """Return an engine instance by registered name (or pass through a class/instance)."""
    if not isinstance(name, str):
        return name() if isinstance(name, type) else name
    eps = _entry_points()
    if name not in eps:
        hint = ""
        if name in KNOWN_ENGINES:
            hint = f" Install it with: pip install {KNOWN_ENGINES[name]}"
        raise EngineNotAvailable(f"unknown engine {name!r}; registered engines: {sorted(eps)}.{hint}")
    module, _, attr = eps[name].partition(":")
    try:
        cls = getattr(importlib.import_module(module), attr)
    except ImportError as exc:
        if (exc.name or "").startswith("pbr_xval"):
            raise EngineNotAvailable(
                f"engine {name!r} is registered as {eps[name]!r} but {exc.name!r} cannot be imported ({exc}); "
                "reinstall pbr-xval"
            ) from exc
        pkg = KNOWN_ENGINES.get(name, exc.name or "?")
        raise EngineNotAvailable(
            f"engine {name!r} needs the package {pkg!r}, which could not be imported ({exc}). "
            f"Install it with: pip install {pkg}"
        ) from exc
    req = getattr(cls, "requires", None)
    if req and importlib.util.find_spec(req) is None:
        pkg = KNOWN_ENGINES.get(name, req)
        raise EngineNotAvailable(
            f"engine {name!r} needs the package {pkg!r} (module {req!r}), which is not installed. "
            f"Install it with: pip install {pkg}"
        )
    return cls()


def import_engine_package(engine: str, module: str) -> Any:
    """Import a third-party engine package on first use, with an install hint if it is missing."""
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        pkg = KNOWN_ENGINES.get(engine, module)
        raise EngineNotAvailable(
            f"engine {engine!r} needs the package {pkg!r}, which could not be imported ({exc}). "
            f"Install it with: pip install {pkg}"
        ) from exc
