"""Shared machinery for the third-party engine adapters (no engine is imported here).

Each adapter builds its model from a compiled :class:`~pbr_xval.scene.Scene`, settles the rock,
then steps with the pedestal acceleration applied either as an inertial load (gravity tilted
to (−a_x, −a_y, −g − a_z) at mid-step, the default) or by moving the pedestal kinematically.
This module records the trajectory, detects toppling and blow-ups, and builds the
:class:`~pbr_xval.engine.Trajectory`.
"""

from __future__ import annotations

import contextlib
import math
import os
import tempfile
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from pbr_xval.engine import Event, Trajectory

__all__ = ["Recorder", "StderrCapture", "matrix_to_quat", "n_steps"]

GROUND_MODES = ("inertial", "moving_pedestal")


def n_steps(duration: float, dt: float) -> int:
    """Number of steps of size ``dt`` (s) that cover ``duration`` (s)."""
    return int(math.ceil(duration / dt - 1e-9))


def matrix_to_quat(r: np.ndarray) -> np.ndarray:
    """Scalar-first unit quaternion (4,) from a rotation matrix (3, 3) (Shepperd's method)."""
    m = np.asarray(r, dtype=float)
    tr = m[0, 0] + m[1, 1] + m[2, 2]
    if tr > 0:
        s = 2.0 * math.sqrt(tr + 1.0)
        q = [0.25 * s, (m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s]
    elif m[0, 0] > m[1, 1] and m[0, 0] > m[2, 2]:
        s = 2.0 * math.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2])
        q = [(m[2, 1] - m[1, 2]) / s, 0.25 * s, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s]
    elif m[1, 1] > m[2, 2]:
        s = 2.0 * math.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2])
        q = [(m[0, 2] - m[2, 0]) / s, (m[0, 1] + m[1, 0]) / s, 0.25 * s, (m[1, 2] + m[2, 1]) / s]
    else:
        s = 2.0 * math.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1])
        q = [(m[1, 0] - m[0, 1]) / s, (m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, 0.25 * s]
    qa = np.array(q)
    if qa[0] < 0:
        qa = -qa
    return qa / np.linalg.norm(qa)


@dataclass
class Recorder:
    """Collects the rock state during a run and turns it into a :class:`Trajectory`.

    Call :meth:`start` once after settling with the rest pose, then :meth:`record` after every
    engine step with the *pedestal-frame* state. Samples are kept every ``output_dt`` (s) plus
    the last step. The recorder applies the scene's toppling criterion and flags NaN or
    explosion (a COM beyond ``explode_factor`` × the rock size from its rest position, or a
    speed beyond ``max_speed`` m/s).
    """

    scene: Any
    dt: float
    explode_factor: float = 50.0
    max_speed: float = 1e3
    t: list[float] = field(default_factory=list)
    com: list[np.ndarray] = field(default_factory=list)
    quat: list[np.ndarray] = field(default_factory=list)
    omega: list[np.ndarray] = field(default_factory=list)
    events: list[Event] = field(default_factory=list)
    contacts: list[int] = field(default_factory=list)
    max_penetration: float = 0.0
    energy: list[float] = field(default_factory=list)
    failed: str = ""
    _r0t: np.ndarray = field(default_factory=lambda: np.eye(3))
    _com0: np.ndarray = field(default_factory=lambda: np.zeros(3))
    _next_out: float = 0.0
    _size: float = 1.0
    _toppled: bool = False
    _uplifted: bool = False

    def start(self, com0: np.ndarray, rot0: np.ndarray) -> None:
        """Rest pose after settling: COM (3,) m and rotation (3, 3) of the rock body."""
        self._r0t = np.asarray(rot0, dtype=float).T.copy()
        self._com0 = np.asarray(com0, dtype=float).copy()
        self._size = float(np.ptp(self.scene.rock.mesh.vertices))
        self._next_out = 0.0

    def relative_rotation(self, rot: np.ndarray) -> np.ndarray:
        """Rotation (3, 3) relative to the rest pose recorded by :meth:`start`."""
        return np.asarray(rot, dtype=float) @ self._r0t

    def record(
        self,
        t: float,
        com: np.ndarray,
        rot: np.ndarray,
        omega: np.ndarray,
        *,
        n_contacts: int | None = None,
        penetration: float | None = None,
        force: bool = False,
    ) -> bool:
        """Store one state; returns True when the run should stop (toppled or failed).

        Parameters
        ----------
        t : s since the start of the excitation.
        com : (3,) m, pedestal frame, same origin as the scene (rock COM at rest ≈ scene.rock.com).
        rot : (3, 3) body rotation (engine body frame → pedestal frame).
        omega : (3,) rad/s, pedestal frame.
        """
        com = np.asarray(com, dtype=float)
        omega = np.asarray(omega, dtype=float)
        rel = self.relative_rotation(rot)
        if n_contacts is not None:
            self.contacts.append(int(n_contacts))
        if penetration is not None:
            self.max_penetration = max(self.max_penetration, float(penetration))
        if not (np.all(np.isfinite(com)) and np.all(np.isfinite(rel)) and np.all(np.isfinite(omega))):
            self.failed = f"NaN in the state at t = {t:.6g} s"
        elif np.linalg.norm(com - self._com0) > self.explode_factor * self._size:
            self.failed = f"explosion: the COM moved {np.linalg.norm(com - self._com0):.3g} m at t = {t:.6g} s"
        elif np.linalg.norm(omega) * self._size > self.max_speed:
            self.failed = f"explosion: angular speed {np.linalg.norm(omega):.3g} rad/s at t = {t:.6g} s"
        if self.failed:
            self.events.append(Event("failed", t, {"reason": self.failed}))
            return True
        stop = False
        if not self._uplifted and math.acos(min(1.0, max(-1.0, rel[2, 2]))) > 1e-4:
            self._uplifted = True
            self.events.append(Event("uplift", t, {"tilt_rad": math.acos(min(1.0, rel[2, 2]))}))
        if not self._toppled and self.scene.is_toppled(com, rel):
            self._toppled = True
            self.events.append(Event("toppled", t, {}))
            stop = bool(self.scene.toppling.stop_on_topple)
        if force or stop or t >= self._next_out - 1e-9 * self.dt:
            self.t.append(float(t))
            self.com.append(com.copy())
            self.quat.append(matrix_to_quat(rel))
            self.omega.append(omega.copy())
            while self._next_out <= t + 1e-9 * self.dt:
                self._next_out += self.scene.output_dt
        return stop

    def trajectory(
        self,
        engine: str,
        settings: dict[str, Any],
        versions: dict[str, str],
        diagnostics: dict[str, Any] | None = None,
    ) -> Trajectory:
        """Build the Trajectory (failed if a NaN or explosion was seen)."""
        diag = {
            "max_penetration_m": self.max_penetration,
            "contacts_min": int(min(self.contacts)) if self.contacts else None,
            "contacts_max": int(max(self.contacts)) if self.contacts else None,
            "contacts_mean": float(np.mean(self.contacts)) if self.contacts else None,
            "nan_or_explosion": bool(self.failed),
        }
        diag.update(diagnostics or {})
        n = len(self.t)
        traj = Trajectory(
            engine=engine,
            t=np.asarray(self.t, dtype=float),
            com=np.asarray(self.com, dtype=float).reshape(n, 3),
            quat=np.asarray(self.quat, dtype=float).reshape(n, 4),
            omega=np.asarray(self.omega, dtype=float).reshape(n, 3),
            events=list(self.events),
            diagnostics=diag,
            settings=dict(settings),
            versions=dict(versions),
            scenario_hash=self.scene.scenario_hash,
            scene_info=self.scene.info(),
            excitation_axis=self.scene.direction.copy(),
        )
        if self.failed:
            traj.status = "failed"
            traj.message = self.failed
        return traj


class StderrCapture:
    """Capture what native code writes to file descriptor 2 (e.g. DART's LCP failure messages)."""

    def __init__(self) -> None:
        self.text = ""

    @contextlib.contextmanager
    def capture(self) -> Iterator[StderrCapture]:
        fd = 2
        saved = os.dup(fd)
        with tempfile.TemporaryFile(mode="w+b") as tmp:
            os.dup2(tmp.fileno(), fd)
            try:
                yield self
            finally:
                os.dup2(saved, fd)
                os.close(saved)
                tmp.seek(0)
                self.text += tmp.read().decode(errors="replace")

    def count(self, needle: str) -> int:
        return self.text.count(needle)


def rotation_about(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rotation matrix (3, 3) for ``angle`` rad about the unit ``axis`` (3,) (Rodrigues)."""
    a = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    k = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
    return np.eye(3) + math.sin(angle) * k + (1.0 - math.cos(angle)) * (k @ k)


def initial_pose(scene: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Initial COM (3,), rotation (3, 3) relative to rest, COM velocity (3,) and ω (3,).

    With ``scene.theta0`` ≠ 0 the rock starts tilted by θ0 about the support edge toward
    sign(θ0)·d (the pivot), rotating at ``scene.omega0`` about that edge; otherwise at rest.
    """
    com = scene.rock.com.astype(float).copy()
    th, om = float(scene.theta0), float(scene.omega0)
    e, d = scene.rocking_axis, scene.direction
    if th == 0.0 and om == 0.0:
        return com, np.eye(3), np.zeros(3), np.zeros(3)
    from pbr_xval.geometry.stability import hull_vertices, support_points

    sp = support_points(hull_vertices(scene.rock.mesh.vertices))
    x = (sp - com) @ d
    side = 1.0 if (th > 0 or (th == 0 and om > 0)) else -1.0
    px = x.max() if side > 0 else x.min()
    pivot = com + px * d
    pivot[2] = sp[:, 2].min()
    rot = rotation_about(e, th)
    com_t = pivot + rot @ (com - pivot)
    omega = om * e
    vel = np.cross(omega, com_t - pivot)
    return com_t, rot, vel, omega
