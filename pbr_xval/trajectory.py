"""The :class:`Trajectory` every engine returns, and its :class:`Event` records.

A trajectory is engine-neutral plain data in SI units: the sampled rock state (time, centre of
mass, orientation quaternion, angular velocity), the discrete events (uplift, impacts, toppled),
the standard diagnostics, and the provenance of the run (settings, versions, scenario hash,
machine). It converts to a pandas DataFrame and round-trips through Parquet. The engine
interface (:mod:`pbr_xval.engine`) and the stepping core (:mod:`pbr_xval.stepping`) build on it;
it imports neither.
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from pbr_xval.jsonio import jsonable as _jsonable
from pbr_xval.machine import machine_info
from pbr_xval.quaternions import quat_to_matrix
from pbr_xval.status import RunStatus

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["Event", "Trajectory"]


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
