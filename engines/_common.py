"""Shared machinery for the third-party engine adapters (no engine is imported here).

Each adapter builds its model from a compiled :class:`~pbr_xval.scene.Scene`, settles the rock,
then steps with the pedestal acceleration applied either as an inertial load (gravity tilted
to (−a_x, −a_y, −g − a_z) at mid-step, the default) or by moving the pedestal kinematically.
This module records the trajectory, detects toppling and blow-ups, and builds the
:class:`~pbr_xval.engine.Trajectory`.
"""

from __future__ import annotations

import contextlib
import hashlib
import math
import os
import tempfile
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from pbr_xval.engine import Event, Trajectory
from pbr_xval.status import RunStatus

if TYPE_CHECKING:
    from pbr_xval.scene import Scene

__all__ = ["Recorder", "StderrCapture", "initial_pose", "matrices_to_quats", "matrix_to_quat", "n_steps"]

GROUND_MODES = ("inertial", "moving_pedestal")


def n_steps(duration: float, dt: float) -> int:
    """Number of steps of size ``dt`` (s) that cover ``duration`` (s)."""
    return math.ceil(duration / dt - 1e-9)


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


def matrices_to_quats(r: np.ndarray) -> np.ndarray:
    """Vectorised :func:`matrix_to_quat`: (n, 3, 3) rotations → (n, 4) scalar-first quaternions.

    Each row uses the numerically best of Shepperd's four branches (largest diagonal term).
    """
    m = np.asarray(r, dtype=float).reshape(-1, 3, 3)
    n = m.shape[0]
    tr = m[:, 0, 0] + m[:, 1, 1] + m[:, 2, 2]
    cand = np.stack([tr, m[:, 0, 0], m[:, 1, 1], m[:, 2, 2]], axis=1)
    k = np.argmax(cand, axis=1)
    q = np.empty((n, 4))
    d21, d02, d10 = m[:, 2, 1] - m[:, 1, 2], m[:, 0, 2] - m[:, 2, 0], m[:, 1, 0] - m[:, 0, 1]
    s01, s02, s12 = m[:, 0, 1] + m[:, 1, 0], m[:, 0, 2] + m[:, 2, 0], m[:, 1, 2] + m[:, 2, 1]
    with np.errstate(invalid="ignore", divide="ignore"):
        s0 = 2.0 * np.sqrt(np.maximum(tr + 1.0, 0.0))
        s1 = 2.0 * np.sqrt(np.maximum(1.0 + m[:, 0, 0] - m[:, 1, 1] - m[:, 2, 2], 0.0))
        s2 = 2.0 * np.sqrt(np.maximum(1.0 + m[:, 1, 1] - m[:, 0, 0] - m[:, 2, 2], 0.0))
        s3 = 2.0 * np.sqrt(np.maximum(1.0 + m[:, 2, 2] - m[:, 0, 0] - m[:, 1, 1], 0.0))
        b0 = np.stack([0.25 * s0, d21 / s0, d02 / s0, d10 / s0], axis=1)
        b1 = np.stack([d21 / s1, 0.25 * s1, s01 / s1, s02 / s1], axis=1)
        b2 = np.stack([d02 / s2, s01 / s2, 0.25 * s2, s12 / s2], axis=1)
        b3 = np.stack([d10 / s3, s02 / s3, s12 / s3, 0.25 * s3], axis=1)
    for i, b in enumerate((b0, b1, b2, b3)):
        q[k == i] = b[k == i]
    q[q[:, 0] < 0] *= -1.0
    return q / np.linalg.norm(q, axis=1, keepdims=True)


@dataclass
class Recorder:
    """Collects the rock state during a run and turns it into a :class:`Trajectory`.

    Call :meth:`start` once after settling with the rest pose, then :meth:`record` after every
    engine step with the *pedestal-frame* state. Samples are kept every ``output_dt`` (s) plus
    the last step. The recorder applies the scene's toppling criterion and flags NaN or
    explosion (a COM beyond ``explode_factor`` × the rock size from its rest position, or a
    speed beyond ``max_speed`` m/s).

    The per-step cost is kept small (it runs once per engine step): the toppling test is a
    dot product until the tilt exceeds the smallest critical angle of the rock, and rotations
    are converted to quaternions once, at the end.
    """

    scene: Scene
    dt: float
    explode_factor: float = 50.0
    max_speed: float = 1e3
    t: list[float] = field(default_factory=list)
    com: list[list[float]] = field(default_factory=list)
    rot: list[list[float]] = field(default_factory=list)
    omega: list[list[float]] = field(default_factory=list)
    events: list[Event] = field(default_factory=list)
    contacts: list[int] = field(default_factory=list)
    max_penetration: float = 0.0
    failed: str = ""
    #: physical criterion: the run ended with the rock past α(φ) but tilting back
    undecided: bool = False
    _r0t: np.ndarray = field(default_factory=lambda: np.eye(3))
    _z0: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))
    _com0: np.ndarray = field(default_factory=lambda: np.zeros(3))
    _next_out: float = 0.0
    _size: float = 1.0
    _max_dist2: float = 1.0
    _max_omega2: float = 1.0
    _cos_fast: float = 1.0
    _cos_uplift: float = math.cos(1e-4)
    _toppled: bool = False
    _uplifted: bool = False
    _physical: bool = False
    _cos_down: float = 0.0
    _t_free: float = 0.0
    _past: bool = False
    _outward: bool = False
    _prev_cos: float = 1.0
    _t_cross: float | None = None
    _by_distance: bool = False
    _z0l: list[float] = field(default_factory=lambda: [0.0, 0.0, 1.0])
    _com0l: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])
    _out_dt: float = 1e-3
    _eps_t: float = 1e-12

    def start(self, com0: np.ndarray, rot0: np.ndarray) -> None:
        """Rest pose after settling: COM (3,) m and rotation (3, 3) of the rock body."""
        self._r0t = np.ascontiguousarray(np.asarray(rot0, dtype=float).T)
        # rel = R R0ᵀ, so the image of the rest vertical is R @ (R0ᵀ)[:, 2]
        self._z0 = np.ascontiguousarray(self._r0t[:, 2])
        self._com0 = np.asarray(com0, dtype=float).copy()
        self._size = float(np.ptp(self.scene.rock.mesh.vertices))
        self._max_dist2 = (self.explode_factor * self._size) ** 2
        self._max_omega2 = (self.max_speed / self._size) ** 2
        crit = self.scene.toppling
        alpha_min = float(np.min(self.scene.rock.stability.alpha))
        if crit.criterion == "critical_tilt":
            fast = crit.factor * alpha_min
        elif crit.criterion == "tilt_angle":
            fast = math.radians(crit.angle_deg)
        elif crit.criterion == "physical":
            # below the smallest critical tilt nothing can be decided (and the rock is not down)
            fast = min(alpha_min, math.radians(crit.down_angle_deg))
        else:
            fast = math.pi
        self._cos_fast = math.cos(min(fast, math.pi))
        self._physical = crit.criterion == "physical"
        self._cos_down = math.cos(math.radians(crit.down_angle_deg))
        self._t_free = float(self.scene.excitation_end)
        self._past = False
        self._outward = False
        self._prev_cos = 1.0
        self._t_cross = None
        self._by_distance = crit.criterion == "com_displacement"
        self._z0l = self._z0.tolist()
        self._com0l = self._com0.tolist()
        self._out_dt = float(self.scene.output_dt)
        self._eps_t = 1e-9 * self.dt
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
        # plain Python floats: numpy calls on 3-vectors cost more than the arithmetic
        c = com.tolist() if isinstance(com, np.ndarray) else [float(x) for x in com]
        r = (
            rot.ravel().tolist()
            if isinstance(rot, np.ndarray)
            else np.asarray(rot, dtype=float).ravel().tolist()
        )
        w = omega.tolist() if isinstance(omega, np.ndarray) else [float(x) for x in omega]
        if n_contacts is not None:
            self.contacts.append(int(n_contacts))
        if penetration is not None and penetration > self.max_penetration:
            self.max_penetration = float(penetration)
        zx, zy, zz = self._z0l
        top0 = r[0] * zx + r[1] * zy + r[2] * zz
        top1 = r[3] * zx + r[4] * zy + r[5] * zz
        cos_tilt = r[6] * zx + r[7] * zy + r[8] * zz
        x0, y0, z0 = self._com0l
        dist2 = (c[0] - x0) ** 2 + (c[1] - y0) ** 2 + (c[2] - z0) ** 2
        om2 = w[0] * w[0] + w[1] * w[1] + w[2] * w[2]
        if not math.isfinite(dist2 + om2 + cos_tilt + top0 + top1):
            self.failed = f"NaN in the state at t = {t:.6g} s"
        elif dist2 > self._max_dist2:
            self.failed = f"explosion: the COM moved {math.sqrt(dist2):.3g} m at t = {t:.6g} s"
        elif om2 > self._max_omega2:
            self.failed = f"explosion: angular speed {math.sqrt(om2):.3g} rad/s at t = {t:.6g} s"
        if self.failed:
            self.events.append(Event("failed", t, {"reason": self.failed}))
            return True
        stop = False
        if not self._uplifted and cos_tilt < self._cos_uplift:
            self._uplifted = True
            self.events.append(Event("uplift", t, {"tilt_rad": math.acos(min(1.0, cos_tilt))}))
        if self._physical:
            if not self._toppled and (cos_tilt < self._cos_fast or c[2] < 0.0):
                stop = self._physical_step(t, c, r, cos_tilt)
            else:
                self._past = False
            self._outward = cos_tilt <= self._prev_cos
            self._prev_cos = cos_tilt
        elif not self._toppled and (cos_tilt < self._cos_fast or self._by_distance):
            rel = np.asarray(r, dtype=float).reshape(3, 3) @ self._r0t
            if self.scene.is_toppled(np.asarray(c), rel):
                self._toppled = True
                self.events.append(Event("toppled", t, {"rule": "first crossing"}))
                stop = bool(self.scene.toppling.stop_on_topple)
        if force or stop or t >= self._next_out - self._eps_t:
            self.t.append(float(t))
            self.com.append(c)
            self.rot.append(r)
            self.omega.append(w)
            while self._next_out <= t + self._eps_t:
                self._next_out += self._out_dt
        return stop

    def _decide(self, t: float, rule: str) -> bool:
        """Record the physical toppling decision at ``t`` (s); returns whether to stop."""
        self._toppled = True
        t_cross = self._t_cross if self._t_cross is not None else t
        self.events.append(Event("toppled", t_cross, {"decided_at": t, "rule": rule}))
        return bool(self.scene.toppling.stop_on_topple)

    def _physical_step(self, t: float, c: list[float], r: list[float], cos_tilt: float) -> bool:
        """One step of the physical toppling decision (see :class:`pbr_xval.scenario.Toppling`).

        Called only when the tilt exceeds the smallest critical tilt or the COM is below the
        pedestal top; returns True when the run should stop.
        """
        if c[2] < 0.0:
            return self._decide(t, "down: the centre of mass dropped below the pedestal top")
        rel = np.asarray(r, dtype=float).reshape(3, 3) @ self._r0t
        past = self.scene.past_critical(rel)
        if past and not self._past:
            self._t_cross = t
        self._past = past
        # down: past the critical tilt and beyond the down angle (a squat rock whose α(φ) exceeds
        # the down angle in some direction is not down until it is past α there too)
        if past and cos_tilt <= self._cos_down + 1e-12:
            return self._decide(t, "down: tilt reached the down angle")
        if past and t >= self._t_free - self._eps_t and cos_tilt <= self._prev_cos:
            return self._decide(t, "past the critical tilt and tilting outward after the excitation ended")
        return False

    def finish(self) -> None:
        """End-of-run part of the physical decision: past α(φ) and not tilting back → toppled.

        Called by :meth:`trajectory`; a rock past α(φ) but tilting back when the run ends is not
        counted as toppled and ``toppling_undecided`` is set in the diagnostics.
        """
        if not self._physical or self._toppled or self.failed or not self._past or not self.t:
            return
        if self._outward:
            self._decide(self.t[-1], "past the critical tilt and not tilting back at the end of the run")
        else:
            self.undecided = True

    def trajectory(
        self,
        engine: str,
        settings: dict[str, Any],
        versions: dict[str, str],
        diagnostics: dict[str, Any] | None = None,
    ) -> Trajectory:
        """Build the Trajectory (failed if a NaN or explosion was seen)."""
        self.finish()
        diag = {
            "max_penetration_m": self.max_penetration,
            "contacts_min": int(min(self.contacts)) if self.contacts else None,
            "contacts_max": int(max(self.contacts)) if self.contacts else None,
            "contacts_mean": float(np.mean(self.contacts)) if self.contacts else None,
            "nan_or_explosion": bool(self.failed),
            "toppling_undecided": bool(self.undecided),
        }
        diag.update(diagnostics or {})
        n = len(self.t)
        rel = np.asarray(self.rot, dtype=float).reshape(n, 3, 3) @ self._r0t
        traj = Trajectory(
            engine=engine,
            t=np.asarray(self.t, dtype=float),
            com=np.asarray(self.com, dtype=float).reshape(n, 3),
            quat=matrices_to_quats(rel).reshape(n, 4),
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
            traj.status = RunStatus.FAILED
            traj.message = self.failed
        from pbr_xval.diagnostics import apply_standard_diagnostics

        return apply_standard_diagnostics(traj, self.scene)  # regime, impacts, energy, rest: one meaning


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


def initial_pose(scene: Scene) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
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


# ------------------------------------------------------------------ geometry
COLLISION_CHOICES = ("auto", "primitive", "boxes", "hull", "coacd", "decimated", "mesh")


def cache_dir() -> Path:
    """Cache directory for derived geometry (``$PBR_XVAL_CACHE`` or ``~/.cache/pbr_xval``)."""
    env = os.environ.get("PBR_XVAL_CACHE")
    return Path(env) if env else Path.home() / ".cache" / "pbr_xval"


def write_obj(vertices: np.ndarray, faces: np.ndarray, tag: str) -> Path:
    """An OBJ file for a triangle mesh in the cache, named by its content, written atomically.

    Parameters
    ----------
    vertices : (n, 3) float, m.
    faces : (m, 3) int.
    """
    v = np.ascontiguousarray(vertices, dtype=np.float64)
    f = np.ascontiguousarray(faces, dtype=np.int64)
    h = hashlib.sha256(v.tobytes())
    h.update(f.tobytes())
    path = cache_dir() / "obj" / f"{tag}_{h.hexdigest()[:24]}.obj"
    if not path.exists():
        from pbr_xval.atomic import write_text_atomic

        lines = [f"v {x!r} {y!r} {z!r}" for x, y, z in v.tolist()]
        lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in f.tolist()]
        write_text_atomic(path, "\n".join(lines) + "\n")
    return path


def collision_parts(
    scene: Scene, choice: str, coacd_threshold: float | None = None, coacd_seed: int = 0
) -> tuple[str, list[tuple[np.ndarray, np.ndarray]]]:
    """Resolve an adapter's ``collision`` setting against the scene compiler's choice.

    ``"auto"`` follows ``scene.collision`` (chosen and recorded by the compiler from the
    scenario's ``[model]``). Returns the kind and, for mesh kinds, the parts as
    [(vertices (n, 3) m, faces (m, 3) int)] in the scene frame; primitive kinds return [].
    """
    if choice not in COLLISION_CHOICES:
        raise ValueError(f"collision {choice!r}; expected one of {COLLISION_CHOICES}")
    sc = scene.collision
    kind = sc["kind"] if choice == "auto" else choice
    rock = scene.rock
    if kind == "primitive" and rock.primitive is None:
        kind = "hull"
    if kind == "boxes" and rock.box_parts is None:
        kind = "hull"
    if kind in ("primitive", "boxes"):
        return kind, []
    if (
        kind == sc["kind"]
        and "parts" in sc
        and (kind != "coacd" or coacd_threshold in (None, sc.get("threshold")))
    ):
        return kind, list(sc["parts"])
    if kind == "hull":
        hull = rock.mesh.convex_hull
        return kind, [(np.asarray(hull.vertices, float), np.asarray(hull.faces, np.int64))]
    if kind == "mesh":
        return kind, [(np.asarray(rock.mesh.vertices, float), np.asarray(rock.mesh.faces, np.int64))]
    if kind == "coacd":
        from pbr_xval.geometry.decompose import convex_parts

        parts = convex_parts(rock.mesh, threshold=coacd_threshold or 0.05, seed=coacd_seed)
        return kind, [(np.asarray(p.vertices, float), np.asarray(p.faces, np.int64)) for p in parts]
    from pbr_xval.geometry.reduce import decimate_keep_base

    size = float(np.ptp(rock.mesh.vertices))
    dec = decimate_keep_base(rock.mesh, size / 20, 0.02 * float(np.ptp(rock.mesh.vertices[:, 2])))
    return kind, [(np.asarray(dec.vertices, float), np.asarray(dec.faces, np.int64))]
