"""Engine interface and registry: the protocol every engine answers through, and lookup by name.

Every solver in pbr-xval — the analytical references, our LCP reference solver and the
PyBullet, MuJoCo and DART adapters — answers through one small protocol::

    engine = get_engine("mujoco")
    settings = engine.default_settings()          # complete, explicit dict
    traj = engine.simulate(scene, settings)       # -> Trajectory

Engines register through the entry-point group ``pbr_xval.engines`` as ``"module:Class"``
strings; nothing is imported until an engine is asked for, so ``import pbr_xval`` loads no
physics engine. A missing third-party package gives an install hint (:data:`KNOWN_ENGINES`).

What ``simulate`` returns, :class:`~pbr_xval.trajectory.Trajectory` (with :class:`Event`), lives
in :mod:`pbr_xval.trajectory`; the quaternion helpers in :mod:`pbr_xval.quaternions` and
:func:`machine_info` in :mod:`pbr_xval.machine`. They are re-exported here, where they used to
live, so ``from pbr_xval.engine import Trajectory`` keeps working.
"""

from __future__ import annotations

import dataclasses
import importlib
import importlib.metadata
import importlib.util
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar, Protocol, runtime_checkable

from pbr_xval.errors import EngineNotAvailable, EngineSettingsError, NotApplicable
from pbr_xval.machine import machine_info
from pbr_xval.quaternions import axis_angle_quat, quat_to_matrix
from pbr_xval.registry import ENTRY_POINT_GROUP, refresh_engines, registered_names
from pbr_xval.registry import entry_points as _entry_points
from pbr_xval.status import RunStatus
from pbr_xval.trajectory import Event, Trajectory

if TYPE_CHECKING:
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
    "axis_angle_quat",
    "get_engine",
    "import_engine_package",
    "list_engines",
    "machine_info",
    "merge_settings",
    "quat_to_matrix",
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
