"""The engine-neutral stepping core: the loop every time-stepping engine runs in.

An engine adapter (``engines/*.py``) builds its model from a :class:`~pbr_xval.scene.Scene` and
implements the small :class:`Stepper` protocol: put the rock in its initial pose, settle, step
a block of steps natively with the drive applied (the inertial load: gravity tilted to
(−a_x, −a_y, −g − a_z) at mid-step, or the moving pedestal) while copying the rock state after
each step into a :class:`StepBlock`. :func:`run_steps` owns everything else: settling and the
initial tilt (:func:`initial_pose`), the blow-up check after settling, sampling at the output
rate, the toppling decision and NaN/explosion detection (:class:`Recorder`), failure capture
(an engine exception becomes a failed :class:`~pbr_xval.engine.Trajectory`, never an exception)
and the shared diagnostics (:mod:`pbr_xval.diagnostics`, applied by :meth:`Recorder.trajectory`).

Speed without missed events: the recorder does not run Python per step. A block of rows is
screened with vectorised tests that are *conservative* (a superset of every row at which the
per-step recorder could do anything but store a sample: uplift, a tilt beyond the smallest
critical tilt, a COM below the pedestal top, NaN, a quarter of the explosion limits); the
flagged rows go through the exact per-step :meth:`Recorder.record`, the others are stored in
bulk — bit-identical to calling :meth:`Recorder.record` after each row.

Rows at the output rate: a stepper that sets ``samples_only`` reads the state only after the
steps that will be samples (:func:`sample_steps`, the recorder's own rule evaluated ahead;
``StepBlock.keep``) and lets the engine step natively in between. Under the physical toppling
criterion nothing between two samples can change a verdict — a rock that is down, or past α(φ)
and tilting outward after the excitation, is still so at the next sample — so verdicts are the
per-step ones, dated at the first sample at or after the step (≤ ``output_dt`` later); contact
figures are those of the samples. The first-crossing criteria get a row after every step. Once
the rock reaches half its smallest critical tilt the blocks shrink to an eighth, so a run that
stops on toppling overshoots by at most that many rows.

The one exception: the ``reference`` engine (:mod:`pbr_xval.reference.adapter`) does not run on
:func:`run_steps`; it drives :class:`Recorder` itself (``Recorder.record`` at the output times and
near toppling, ``Recorder.record_block`` for the held samples once the rock is at rest). Its time
step is event-driven, not a fixed grid of steps k0 … k1 − 1: a step that penetrates deeper than
the contact band ε is taken back and retried shorter (step-back), impacts end a step early and
breakpoints of the ground motion cut it, so the number and length of its steps are known only as
they are taken, which the ``Stepper.advance(k0, k1, block)`` contract cannot express. Everything
that decides a verdict (sampling rule, toppling criterion, NaN/explosion, diagnostics) is still
the :class:`Recorder`'s, so its trajectories mean what every other engine's mean.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from pbr_xval.linalg3 import eigh3, mat3_mul, mat3_vec, norm3, rows_dot, rows_mul
from pbr_xval.quaternions import matrices_to_quats, matrix_to_quat, quats_to_mats, rotation_about
from pbr_xval.status import RunStatus
from pbr_xval.trajectory import Event, Trajectory

if TYPE_CHECKING:
    from pbr_xval.scene import Scene

__all__ = [
    "GROUND_MODES",
    "Recorder",
    "StepBlock",
    "Stepper",
    "StepperBase",
    "fail",
    "failed_trajectory",
    "gravity_sequence",
    "initial_pose",
    "matrices_to_quats",
    "matrix_to_quat",
    "n_steps",
    "quats_to_mats",
    "rotation_about",
    "run_steps",
    "sample_steps",
]

GROUND_MODES = ("inertial", "moving_pedestal")

#: ``toppling.stop_at_rest``: after the excitation has ended the rock is at rest, and its
#: outcome decided (it stands), once for REST_HOLD_SAMPLES consecutive output samples (a time
#: of REST_HOLD_SAMPLES × output_dt) its tilt stays below REST_TILT_FRACTION × the smallest
#: critical tilt α and its energy — kinetic (rotation bounded by λ_max(I)|ω|²/2, translation
#: from the COM's finite differences) plus the rise of its COM — stays below
#: REST_ENERGY_FRACTION × the toppling barrier m g h_G (1/cos α − 1) (h_G: COM height above the
#: pedestal top). With the ground at rest no work enters, so a rock with less energy than the
#: barrier cannot reach α again: the rest of the run cannot change the outcome.
REST_HOLD_SAMPLES = 20
REST_TILT_FRACTION = 0.1
REST_ENERGY_FRACTION = 0.01


def n_steps(duration: float, dt: float) -> int:
    """Number of steps of size ``dt`` (s) that cover ``duration`` (s)."""
    return math.ceil(duration / dt - 1e-9)


def _next_output(nxt: float, t: float, out_dt: float, eps: float) -> float:
    """The next output time after a sample at ``t`` (s): ``nxt`` advanced by whole ``out_dt``.

    The recorder's sampling rule (a step at t is a sample when t ≥ nxt − eps), in the one place
    that :meth:`Recorder.record`, the recorder's bulk path and :func:`sample_steps` share, so the
    samples an adapter is asked to read are exactly the ones the recorder keeps.
    """
    while nxt <= t + eps:
        nxt += out_dt
    return nxt


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
    events: list[Event] = field(default_factory=list)
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
    # samples: preallocated arrays (grown by doubling), rows 0 … _n − 1 filled; no per-sample
    # Python objects (lists of lists cost time and garbage-collector passes)
    _n: int = 0
    _T: np.ndarray = field(default_factory=lambda: np.zeros(0))
    _C: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    _R: np.ndarray = field(default_factory=lambda: np.zeros((0, 9)))
    _W: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    # contact counts: running min, max, sum and number of readings
    _nc_min: int = 0
    _nc_max: int = 0
    _nc_sum: int = 0
    _nc_cnt: int = 0
    #: the last recorded block reached half the smallest critical tilt (run_steps then takes
    #: short blocks, so that a toppling decision stops the engine soon after it is taken)
    near: bool = False
    _cos_near: float = 1.0
    #: ``toppling.stop_at_rest``: time (s) at which the run was stopped at rest, else None
    stopped_at_rest: float | None = None
    _rest_on: bool = False
    _rest_since: float | None = None
    _rest_hold: float = 0.0
    _cos_rest: float = 1.0
    _e_rest: float = 0.0
    _rest_m: float = 0.0
    _rest_i: float = 0.0
    _rest_g: float = 0.0
    _rest_prev: tuple[float, np.ndarray] | None = None

    @property
    def t(self) -> list[float]:
        """Sample times (s), a list."""
        return self._T[: self._n].tolist()

    @property
    def com(self) -> np.ndarray:
        """Sampled COM (n, 3) m, pedestal frame."""
        return self._C[: self._n]

    @property
    def rot(self) -> np.ndarray:
        """Sampled body rotations (n, 9), row-major."""
        return self._R[: self._n]

    @property
    def omega(self) -> np.ndarray:
        """Sampled angular velocity (n, 3) rad/s, pedestal frame."""
        return self._W[: self._n]

    def _reserve(self, extra: int) -> int:
        """Make room for ``extra`` more samples; returns the first free row."""
        n = self._n
        if n + extra > self._T.shape[0]:
            cap = max(2 * self._T.shape[0], n + extra, 256)
            for name, width in (("_T", 0), ("_C", 3), ("_R", 9), ("_W", 3)):
                old = getattr(self, name)
                arr = np.zeros(cap) if width == 0 else np.zeros((cap, width))
                arr[:n] = old[:n]
                setattr(self, name, arr)
        return n

    def _count_contacts(self, lo: int, hi: int, total: int, count: int) -> None:
        if self._nc_cnt == 0:
            self._nc_min, self._nc_max = lo, hi
        else:
            self._nc_min, self._nc_max = min(self._nc_min, lo), max(self._nc_max, hi)
        self._nc_sum += total
        self._nc_cnt += count

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
            fast = math.radians(float(crit.angle_deg or 0.0))  # set: validated by Toppling
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
        self._reserve(int(min(float(self.scene.duration) / self._out_dt, 1e7)) + 2)
        self._cos_near = math.cos(0.5 * alpha_min)
        self._rest_on = bool(getattr(crit, "stop_at_rest", False))
        if self._rest_on:
            rock = self.scene.rock
            self._rest_m = float(rock.mass)
            self._rest_i = float(eigh3(np.asarray(rock.inertia, dtype=float))[0].max())
            self._rest_g = float(self.scene.gravity)
            h_g = max(float(self._com0[2]), 0.0)
            barrier = self._rest_m * self._rest_g * h_g * (1.0 / math.cos(min(alpha_min, 1.5)) - 1.0)
            self._e_rest = REST_ENERGY_FRACTION * barrier
            self._cos_rest = math.cos(REST_TILT_FRACTION * alpha_min)
            self._rest_hold = REST_HOLD_SAMPLES * self._out_dt

    def uplift_due(self, rot: np.ndarray) -> bool:
        """Whether the body rotation ``rot`` (3, 3) is tilted past the uplift line while the first
        uplift is not yet recorded: a loop that records only some steps records this one, so that
        the ``uplift`` event is dated at its step (as :meth:`record_block` dates it)."""
        if self._uplifted:
            return False
        zx, zy, zz = self._z0l
        r = rot[2]
        return bool(r[0] * zx + r[1] * zy + r[2] * zz < self._cos_uplift)

    def relative_rotation(self, rot: np.ndarray) -> np.ndarray:
        """Rotation (3, 3) relative to the rest pose recorded by :meth:`start`."""
        return mat3_mul(np.asarray(rot, dtype=float), self._r0t)

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
            nc = int(n_contacts)
            self._count_contacts(nc, nc, nc, 1)
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
            rel = mat3_mul(np.asarray(r, dtype=float).reshape(3, 3), self._r0t)
            if self.scene.is_toppled(np.asarray(c), rel):
                self._toppled = True
                self.events.append(Event("toppled", t, {"rule": "first crossing"}))
                stop = bool(self.scene.toppling.stop_on_topple)
        if force or stop or t >= self._next_out - self._eps_t:
            i = self._reserve(1)
            self._T[i] = t
            self._C[i] = c
            self._R[i] = r
            self._W[i] = w
            self._n = i + 1
            self._next_out = _next_output(self._next_out, t, self._out_dt, self._eps_t)
        return stop

    def record_block(
        self,
        t: np.ndarray,
        com: np.ndarray,
        rot: np.ndarray,
        omega: np.ndarray,
        ncon: np.ndarray | None = None,
        pen: np.ndarray | None = None,
        *,
        force_last: bool = False,
    ) -> tuple[bool, int]:
        """Record m consecutive steps; the same result as :meth:`record` after each step.

        Parameters
        ----------
        t : (m,) s, increasing.
        com : (m, 3) m, pedestal frame.
        rot : (m, 9) row-major body rotations (engine body frame → pedestal frame).
        omega : (m, 3) rad/s, pedestal frame.
        ncon : (m,) contact counts, or None.
        pen : (m,) deepest penetration per step (m), or None.
        force_last : keep the last step as a sample (the run's final state).

        Returns
        -------
        (stop, used): whether the run should stop, and how many steps were consumed (the
        stopping step included).
        """
        m = len(t)
        if m == 0:
            return False, 0
        rest_stop = False
        j = self.rest_hold(t, com, rot, omega)
        if j is not None:
            m = j + 1
            t, com, rot, omega = t[:m], com[:m], rot[:m], omega[:m]
            ncon = None if ncon is None else ncon[:m]
            pen = None if pen is None else pen[:m]
            force_last = rest_stop = True
        zx, zy, zz = self._z0l
        x0, y0, z0 = self._com0l
        with np.errstate(invalid="ignore", over="ignore"):
            cos = rot[:, 6] * zx + rot[:, 7] * zy + rot[:, 8] * zz
            top = rot[:, 0:6].sum(axis=1)
            d = com - np.array([x0, y0, z0])
            dist2 = (d * d).sum(axis=1)
            om2 = (omega * omega).sum(axis=1)
            # conservative screen: a superset of the steps where record() does more than store
            flag = ~np.isfinite(dist2 + om2 + cos + top)
            flag |= (dist2 > 0.25 * self._max_dist2) | (om2 > 0.25 * self._max_omega2)
            if not self._uplifted:  # the first uplift only: the rows after it are ordinary
                up = np.flatnonzero(cos < self._cos_uplift)
                if up.size:
                    flag[up[0]] = True
            if not self._toppled:
                if self._physical:
                    flag |= (cos < self._cos_fast) | (com[:, 2] < 0.0)
                elif self._by_distance:
                    flag[:] = True
                else:
                    flag |= cos < self._cos_fast
        if force_last:
            flag[-1] = True
        self.near = not bool(np.min(cos) > self._cos_near)  # NaN counts as near
        flagged = np.flatnonzero(flag).tolist()
        i = 0
        for j in [*flagged, m]:
            if j > i:
                self._bulk(t, com, rot, omega, ncon, pen, cos, i, j)
            if j == m:
                break
            stop = self.record(
                float(t[j]),
                com[j],
                rot[j],
                omega[j],
                n_contacts=None if ncon is None else int(ncon[j]),
                penetration=None if pen is None else float(pen[j]),
                force=force_last and j == m - 1,
            )
            if stop:
                return True, j + 1
            i = j + 1
        if rest_stop and not self.failed and not self._toppled:
            self.stopped_at_rest = float(t[-1])
            return True, m
        return False, m

    def rest_hold(self, t: np.ndarray, com: np.ndarray, rot: np.ndarray, omega: np.ndarray) -> int | None:
        """``toppling.stop_at_rest`` for m consecutive steps (t (m,) s, com (m, 3) m, rot (m, 9),
        omega (m, 3) rad/s): the first of them at which the rest hold completes, else None.

        Off (None, nothing fed) unless ``stop_at_rest`` is set, the rock has not toppled and the
        last step is at or after the excitation's end. :meth:`record_block` applies it to its
        rows; an engine that records step by step with :meth:`record` feeds it every step
        itself, so that both paths stop at the same step."""
        if not self._rest_on or self._toppled or float(t[-1]) < self._t_free - self._eps_t:
            return None
        return self._rest_row(t, com, rot, omega)

    def _rest_row(self, t: np.ndarray, com: np.ndarray, rot: np.ndarray, omega: np.ndarray) -> int | None:
        """``toppling.stop_at_rest``: the first row of a block at which the rock has been at rest
        (see :data:`REST_HOLD_SAMPLES`) for the hold time after the excitation ended, else None.

        Rows before the excitation's end break the hold; the hold carries over between blocks."""
        zx, zy, zz = self._z0l
        with np.errstate(invalid="ignore", over="ignore"):
            cos = rot[:, 6] * zx + rot[:, 7] * zy + rot[:, 8] * zz
            prev_t, prev_c = self._rest_prev if self._rest_prev is not None else (math.nan, com[0])
            tt = np.concatenate(([prev_t], t))
            cc = np.concatenate((np.asarray(prev_c).reshape(1, 3), com))
            dtr = np.diff(tt)
            v2 = (np.diff(cc, axis=0) ** 2).sum(axis=1) / np.where(dtr > 0, dtr * dtr, np.nan)
            v2 = np.where(np.isfinite(v2), v2, np.inf)  # no earlier row: not yet at rest
            energy = (
                0.5 * self._rest_i * (omega * omega).sum(axis=1)
                + 0.5 * self._rest_m * v2
                + self._rest_m * self._rest_g * np.maximum(com[:, 2] - self._com0[2], 0.0)
            )
            ok = (t >= self._t_free - self._eps_t) & (cos >= self._cos_rest) & (energy < self._e_rest)
        self._rest_prev = (float(t[-1]), np.array(com[-1], dtype=float))
        since = self._rest_since
        for j, (tj, okj) in enumerate(zip(t.tolist(), ok.tolist(), strict=True)):
            if not okj:
                since = None
                continue
            if since is None:
                since = tj
            if tj - since >= self._rest_hold - self._eps_t:
                self._rest_since = since
                return j
        self._rest_since = since
        return None

    def _bulk(
        self,
        t: np.ndarray,
        com: np.ndarray,
        rot: np.ndarray,
        omega: np.ndarray,
        ncon: np.ndarray | None,
        pen: np.ndarray | None,
        cos: np.ndarray,
        i: int,
        j: int,
    ) -> None:
        """Steps i..j−1 of a block, none of which can change the recorder's state but by a sample."""
        if ncon is not None:
            seg = ncon[i:j]
            self._count_contacts(int(seg.min()), int(seg.max()), int(seg.sum()), j - i)
        if pen is not None:
            p = float(pen[i:j].max())
            if p != p:  # a NaN among them: the finite values still count
                seg = pen[i:j][np.isfinite(pen[i:j])]
                p = float(seg.max()) if seg.size else p
            if p > self.max_penetration:
                self.max_penetration = p
        if self._physical:
            self._past = False
            self._outward = bool(cos[j - 1] <= (cos[j - 2] if j - 2 >= i else self._prev_cos))
            self._prev_cos = float(cos[j - 1])
        eps, out_dt, nxt = self._eps_t, self._out_dt, self._next_out
        tb = t[i:j]
        # usual case (rows at the output samples, or output_dt = dt): every row is a sample and
        # advances the next output time by exactly one output_dt. Checked vectorised; np.cumsum
        # adds in sequence, so the output times are the loop's own, bit for bit.
        nx = np.cumsum(np.concatenate(([nxt], np.full(j - i, out_dt))))
        idx: list[int] | range
        if np.all(tb >= nx[:-1] - eps) and np.all(nx[:-1] <= tb + eps) and np.all(nx[1:] > tb + eps):
            idx, nxt = range(i, j), float(nx[-1])
        else:
            idx = []
            for k, tk in enumerate(tb.tolist()):  # the rule of record(), one comparison per row
                if tk >= nxt - eps:
                    idx.append(i + k)
                    nxt = _next_output(nxt, tk, out_dt, eps)
        self._next_out = nxt
        if idx:
            m = len(idx)
            r0 = self._reserve(m)
            sel: slice | list[int] = slice(idx[0], idx[0] + m) if idx[-1] - idx[0] == m - 1 else list(idx)
            self._T[r0 : r0 + m] = t[sel]
            self._C[r0 : r0 + m] = com[sel]
            self._R[r0 : r0 + m] = rot[sel]
            self._W[r0 : r0 + m] = omega[sel]
            self._n = r0 + m

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
        rel = mat3_mul(np.asarray(r, dtype=float).reshape(3, 3), self._r0t)
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
        if not self._physical or self._toppled or self.failed or not self._past or not self._n:
            return
        if self._outward:
            self._decide(
                float(self._T[self._n - 1]),
                "past the critical tilt and not tilting back at the end of the run",
            )
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
            "contacts_min": self._nc_min if self._nc_cnt else None,
            "contacts_max": self._nc_max if self._nc_cnt else None,
            "contacts_mean": self._nc_sum / self._nc_cnt if self._nc_cnt else None,
            "nan_or_explosion": bool(self.failed),
            "toppling_undecided": bool(self.undecided),
        }
        if self._rest_on:
            diag["stopped_at_rest"] = self.stopped_at_rest is not None
            diag["stopped_at_rest_s"] = self.stopped_at_rest
        diag.update(diagnostics or {})
        n = self._n
        rel = rows_mul(self._R[:n].reshape(3 * n, 3), self._r0t).reshape(n, 3, 3)  # R R0ᵀ, no BLAS
        traj = Trajectory(
            engine=engine,
            t=self._T[:n].copy(),
            com=self._C[:n].copy(),
            quat=matrices_to_quats(rel).reshape(n, 4),
            omega=self._W[:n].copy(),
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


def initial_pose(scene: Scene) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Initial COM (3,), rotation (3, 3) relative to rest, COM velocity (3,) and ω (3,).

    With ``scene.theta0`` ≠ 0 the rock starts tilted by θ0 about the support edge toward
    sign(θ0)·d (the pivot), rotating at ``scene.omega0`` about that edge; otherwise at rest.
    A scanned base can have hull vertices beyond that edge a little above the pedestal (SP2: a
    vertex 0.1 mm below the pedestal at θ0 = −0.002 rad, 0.3 mm at −0.005): the tilt would push
    them into it, and the rock then rests on the lowest of them instead — it is lifted until
    that vertex is on the pedestal (the pose of rolling about the edge and then onto the vertex,
    to first order in θ0), and rotates about it. Lifts below round-off (1e-9 of the hull's size)
    are not made, so a block tilted about its edge is unchanged.
    """
    com = scene.rock.com.astype(float).copy()
    th, om = float(scene.theta0), float(scene.omega0)
    e, d = scene.rocking_axis, scene.direction
    if th == 0.0 and om == 0.0:
        return com, np.eye(3), np.zeros(3), np.zeros(3)
    from pbr_xval.geometry.stability import hull_vertices, support_points

    hv = hull_vertices(scene.rock.mesh.vertices)
    sp = support_points(hv)
    x = rows_dot(sp - com, d)  # (sp − com)·d
    side = 1.0 if (th > 0 or (th == 0 and om > 0)) else -1.0
    px = x.max() if side > 0 else x.min()
    pivot = com + px * d
    pivot[2] = sp[:, 2].min()
    rot = rotation_about(e, th)
    com_t = pivot + mat3_vec(rot, com - pivot)
    z = com_t[2] + rows_dot(hv - com, rot[2])
    lift = pivot[2] - float(z.min())
    if lift > 1e-9 * max(1.0, float(np.ptp(hv))):
        k = int(np.argmin(z))
        com_t = com_t + np.array([0.0, 0.0, lift])
        pivot = com_t + mat3_vec(rot, hv[k] - com)
    omega = om * e
    vel = np.cross(omega, com_t - pivot)
    return com_t, rot, vel, omega


# ------------------------------------------------------------------ the loop
def fail(rec: Recorder, t: float, msg: str) -> None:
    """Mark the run failed at ``t`` (s) with the reason ``msg`` (once)."""
    if not rec.failed:
        rec.failed = msg
        rec.events.append(Event("failed", t, {"reason": msg}))


def gravity_sequence(scene: Scene, t_mid: np.ndarray) -> np.ndarray:
    """The inertial load: gravity (n, 3) m/s² = (−a_x, −a_y, −g − a_z) at the times ``t_mid`` (n,) s."""
    n = len(t_mid)
    acc = np.ascontiguousarray(np.asarray(scene.excitation.acceleration(t_mid), dtype=float).reshape(n, 3))
    grav = np.empty((n, 3))
    grav[:, 0] = -acc[:, 0]
    grav[:, 1] = -acc[:, 1]
    grav[:, 2] = -float(scene.gravity) - acc[:, 2]
    return grav


@dataclass
class StepBlock:
    """Per-step rock state written by :meth:`Stepper.advance` (row i: after the i-th step).

    Attributes
    ----------
    com : (size, 3) m, pedestal frame (or the world frame with :attr:`Stepper.pedestal_offset`).
    rot : (size, 9) row-major rotation, engine body frame → pedestal frame.
    omega : (size, 3) rad/s.
    ncon : (size,) contact count.
    pen : (size,) deepest penetration, m.
    n : rows filled so far (the adapter updates it after each step, so a step that raises
        loses nothing already computed).
    keep : per-step flags of the whole run (list of n bools, step k → ``keep[k]``) when the
        stepper records samples only (:attr:`StepperBase.samples_only`): the adapter writes a
        row only after the steps flagged, and steps the others without reading anything.
        None: a row after every step.
    """

    size: int
    keep: list[bool] | None = None
    com: np.ndarray = field(init=False)
    rot: np.ndarray = field(init=False)
    omega: np.ndarray = field(init=False)
    ncon: np.ndarray = field(init=False)
    pen: np.ndarray = field(init=False)
    n: int = 0

    def __post_init__(self) -> None:
        self.com = np.zeros((self.size, 3))
        self.rot = np.zeros((self.size, 9))
        self.omega = np.zeros((self.size, 3))
        self.ncon = np.zeros(self.size, dtype=np.int64)
        self.pen = np.zeros(self.size)


class Stepper(Protocol):
    """What an engine adapter supplies to :func:`run_steps` (everything engine-specific)."""

    #: rotation (3, 3) of the engine's rock body at the untilted rest pose
    rest_rotation: np.ndarray

    def set_initial(self, com: np.ndarray, rot: np.ndarray, vel: np.ndarray, omega: np.ndarray) -> None:
        """Place the rock at COM (3,) m, rotation (3, 3) relative to rest, v (3,) m/s, ω (3,) rad/s."""

    def settle(self, n: int) -> None:
        """Step ``n`` times under gravity alone with the pedestal at rest."""

    def state(self) -> tuple[np.ndarray, np.ndarray, float]:
        """Rock COM (3,) m, rotation (3, 3) and speed bound |v| + |ω|·size (m/s) after settling."""

    def begin(self, n: int) -> None:
        """Prepare the drive of the ``n`` steps of the run (called once, after settling)."""

    def sample(self, block: StepBlock) -> None:
        """Write the current state into row 0 of ``block`` (the t = 0 sample)."""

    def advance(self, k0: int, k1: int, block: StepBlock) -> None:
        """Take steps k0 … k1 − 1 with the drive, writing the state after each into ``block``."""

    def end(self) -> None:
        """Remove the drive (e.g. restore gravity)."""


class StepperBase:
    """Defaults for a :class:`Stepper`: rest pose along the scene axes, no t = 0 sample, no drive to remove."""

    rest_rotation: np.ndarray = np.eye(3)
    #: the adapter honours :attr:`StepBlock.keep` (writes rows at the output samples only)
    samples_only: bool = False

    def sample(self, block: StepBlock) -> None:
        raise NotImplementedError(f"{type(self).__name__} records from the first step (sample_start=False)")

    def end(self) -> None:
        return None

    @staticmethod
    def speed(v: Any, w: Any, scene: Scene) -> float:
        """Speed bound |v| + |ω|·size (m/s) from COM velocity (3,) m/s and ω (3,) rad/s."""
        return norm3(v) + norm3(w) * float(np.ptp(scene.rock.mesh.vertices))


def failed_trajectory(engine: str, scene: Scene, message: str, settings: Any, versions: Any) -> Trajectory:
    """An empty failed :class:`Trajectory` for a model that could not be built (with the scene's provenance)."""
    return Trajectory.failed(
        engine,
        message,
        settings=settings,
        versions=versions,
        scenario_hash=scene.scenario_hash,
        scene_info=scene.info(),
        excitation_axis=scene.direction.copy(),
    )


def sample_steps(rec: Recorder, n: int) -> list[int] | None:
    """Steps (0-based, step k ends at t = (k + 1)·dt) that ``rec`` will keep as samples, the last included.

    The recorder's own rule (a sample once t ≥ the next output time, the output times advanced by
    repeated addition of ``output_dt``) evaluated ahead, so an adapter can skip reading the state
    at every other step. None when every step is a sample (``output_dt`` ≤ dt).
    """
    dt, out_dt, eps = rec.dt, rec._out_dt, rec._eps_t
    if out_dt <= dt or n <= 0:
        return None
    tl = (np.arange(1, n + 1) * dt).tolist()
    rows: list[int] = []
    nxt, k = rec._next_out, 0
    while True:
        k = bisect.bisect_left(tl, nxt - eps, k)
        if k >= n:
            break
        rows.append(k)
        nxt = _next_output(nxt, tl[k], out_dt, eps)
        k += 1
    if not rows or rows[-1] != n - 1:
        rows.append(n - 1)
    return None if len(rows) == n else rows


def run_steps(
    stepper: Stepper,
    scene: Scene,
    dt: float,
    *,
    settle: bool = True,
    sample_start: bool = False,
    block: int = 256,
    name: str = "engine",
) -> tuple[Recorder, dict[str, Any]]:
    """Run a scene on ``stepper``: settle or tilt, drive, sample, decide; never raises.

    Parameters
    ----------
    stepper : the engine adapter's :class:`Stepper`.
    scene : the compiled scene.
    dt : s, the time step.
    settle : settle for ``scene.settle_time`` when the rock starts at rest.
    sample_start : also record the state at t = 0.
    block : rows (steps, or output samples for a samples-only stepper) per recorder call; an
        eighth of it once the rock has reached half its smallest critical tilt.
    name : engine name for failure messages.

    Returns
    -------
    The :class:`Recorder` (call :meth:`Recorder.trajectory`) and the loop's diagnostics
    (``settle_steps`` or ``settle_skipped``, ``steps``, ``wall_loop_s``, ``wall_per_step_us``).
    """
    import time

    rec = Recorder(scene, dt)
    diag: dict[str, Any] = {}
    k = 0
    k_err: int | None = None
    try:
        com0, rot0, vel0, om0 = initial_pose(scene)
        if scene.theta0 != 0.0 or scene.omega0 != 0.0:
            stepper.set_initial(com0, rot0, vel0, om0)
            diag["settle_skipped"] = (
                "initial tilt/rate given: the run starts from the tilted pose, no settling"
            )
            rec.start(scene.rock.com, stepper.rest_rotation)
        else:
            nset = n_steps(float(scene.settle_time), dt) if settle and scene.settle_time > 0 else 0
            stepper.settle(nset)
            diag["settle_steps"] = nset
            com, rot, speed = stepper.state()
            size = float(np.ptp(scene.rock.mesh.vertices))
            moved = norm3(np.asarray(com, dtype=float) - scene.rock.com)
            if (
                not (np.all(np.isfinite(rot)) and math.isfinite(moved))
                or moved > rec.explode_factor * size
                or speed > rec.max_speed
            ):
                rec.start(scene.rock.com, stepper.rest_rotation)
                fail(
                    rec,
                    0.0,
                    f"{name}: blow-up during settling (COM moved {moved:.3g} m, speed {speed:.3g} m/s)",
                )
                return rec, diag
            rec.start(com, rot)
        n = n_steps(float(scene.duration), dt)
        stepper.begin(n)
        buf = StepBlock(max(1, int(block)))
        if sample_start:
            stepper.sample(buf)
            rec.record(
                0.0,
                buf.com[0],
                buf.rot[0],
                buf.omega[0],
                n_contacts=int(buf.ncon[0]),
                penetration=float(buf.pen[0]),
            )
        rows = sample_steps(rec, n) if getattr(stepper, "samples_only", False) and rec._physical else None
        if rows is not None:
            keep = [False] * n
            for r in rows:
                keep[r] = True
            buf.keep = keep
            diag["recorded_steps"] = "output samples"
        t_loop = time.perf_counter()
        stop = False
        r = 0
        while not stop and k < n:
            size = max(1, buf.size // 8) if rec.near else buf.size  # near α: short blocks, little overshoot
            if rows is None:  # a row after every step
                k1 = min(n, k + size)
                steps = np.arange(k, k1)
            else:  # rows at the output samples only: as many steps as the next `size` samples need
                r1 = min(len(rows), r + size)
                k1 = rows[r1 - 1] + 1
                steps = np.asarray(rows[r:r1])
            buf.n = 0
            try:
                stepper.advance(k, k1, buf)
            except Exception as exc:
                m = buf.n
                t = (steps[:m] + 1) * dt
                rec.record_block(t, buf.com[:m], buf.rot[:m], buf.omega[:m], buf.ncon[:m], buf.pen[:m])
                k = int(steps[m - 1]) + 1 if m else k
                k_err = int(steps[m]) + 1 if rows is not None and m < len(steps) else None
                raise exc
            m = len(steps)
            t = (steps + 1) * dt
            stop, used = rec.record_block(
                t, buf.com[:m], buf.rot[:m], buf.omega[:m], buf.ncon[:m], buf.pen[:m], force_last=k1 == n
            )
            k = int(steps[used - 1]) + 1
            r += used
        wall = time.perf_counter() - t_loop
        diag.update(wall_loop_s=wall, wall_per_step_us=1e6 * wall / max(k, 1))
        stepper.end()
    except Exception as exc:  # an engine error never escapes: a failed trajectory
        diag["exception"] = f"{type(exc).__name__}: {exc}"
        # reading at the samples only, the error came after the last sample (step k) and by the next
        where = f"after {k} steps (t = {k * dt:.6g} s)"
        if k_err is not None and k_err > k + 1:
            where = f"between steps {k} and {k_err} (t = {k * dt:.6g}–{k_err * dt:.6g} s; samples only)"
        fail(rec, k * dt, f"{name}: engine error {where}: {type(exc).__name__}: {exc}")
    diag["steps"] = k
    return rec, diag
