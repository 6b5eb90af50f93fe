"""One meaning per diagnostic: the regime and the quality figures of every run, engine-neutral.

Every engine — analytical, the reference solver, PyBullet, MuJoCo, DART — returns a
:class:`~pbr_xval.engine.Trajectory` of sampled states (t, COM, orientation relative to rest, ω).
The figures below are computed here, once, from those samples, the scene's geometry (mass,
inertia, COM, hull, the critical tilts α toward ±d) and the one contact figure every engine
reports (``max_penetration_m``). Adapters do not compute them. The full definitions, with the
reasons for every threshold, are in ``docs/diagnostics.md``; in short:

Scales (from the scene, m and J)
    ``b`` = the smaller horizontal lever from the COM to the support edge toward ±d
    (:func:`~pbr_xval.geometry.stability.uplift_lever`), ``w`` = the base width along d (sum
    of the two levers), ``ΔU = m g h_G (1/cos α_min − 1)`` = the potential-energy barrier to
    toppling in the shaking plane (h_G the COM height above the base, α_min the smaller
    critical tilt toward ±d).

Contact tolerance ``δ = max(p_max, 10⁻³ b)`` (m)
    A compliant contact lets two base points differ in height by at most the deepest
    penetration p_max without any of them leaving the pedestal, so only a larger difference
    is an uplift; 10⁻³ b is a floor for rigid models (p_max = 0) — a tilt of about
    5·10⁻⁴ rad for a box.

Rocked
    some base point (hull point touching the pedestal at rest) rose more than δ above
    another (``uplift_max_m`` > δ).
Slid
    the contact slid more than ``0.01 b`` away from where it started (``slip_max_m``, m): from
    each sample to the next, the contact — the centroid of the hull points within δ of the
    lowest, taken as a material point of the rock — moves by Δ horizontally; the accumulated
    Σ Δ is the slip vector and its largest length is ``slip_max_m`` (``slip_end_m`` at the end;
    in a flight Δ is the base's own displacement). A pivot (rocking about an edge or a corner)
    and a rolling contact do not move, so rocking and rolling give no slip; the vector sum lets
    a compliant contact's jitter cancel. 1 % of b is ≥ 20× the largest creep
    measured in pure rocking and rolling (see the docs).
Jumped
    the lowest hull point was more than δ above the pedestal top (the base plane at rest) at
    one sample or more: the rock lost all contact. A flight lasts while the lowest point is
    more than ``10⁻⁴ b`` above the pedestal top (crossings linearly interpolated; closer counts
    as contact: the reference solver holds resting contacts up to its band ε = 10⁻⁵ m above);
    ``flights`` counts them, ``airborne_s`` sums them (s), ``airborne_max_s`` is the longest.
    Flights that never rise δ above the pedestal between two samples are not seen.
At rest
    none of the three. The regime is evaluated up to the toppling time when the rock toppled.
Impacts
    the rock lands each time it comes back from an excursion on one side (rocking angle θ
    beyond ``θ_h = δ / w``) to |θ| ≤ θ_h/2 or past 0 to the other side; ``impacts`` counts
    those landings and ``impact_times_s`` gives the θ = 0 crossing times (linear
    interpolation). This is the event the analytical engines record at θ = 0.
Energy
    E(t) = ½ m|v|² + ½ ωᵀ I_w ω + m g (z_G − z_G,rest) + W(t), W = ∫ m a_g·v dt the work
    against the pedestal-frame inertial load, v from the samples by second-order differences
    on the smoothest three-point stencil (an ENO choice, so a velocity jump at an impact is
    not smeared); E is constant in smooth rigid motion and only falls at impacts and in
    friction. ``energy_max_rel_change`` = max |E(t) − E(t₀)| / ΔU; ``energy_gain_rel`` = the
    largest rise max_{s≤t} (E(t) − E(s)) / ΔU — energy created by the numerics (or released by
    a compliant contact), which a physical contact cannot do.
Settled / at rest
    the kinetic energy is below 10⁻⁴ ΔU — too little to lift a base point by δ, to slide by
    the slip tolerance or to hop by δ — (and, for ``settled``, the tilt below θ_h):
    ``settled`` — the run starts at rest in the rest pose (at t = 0, extrapolated from the
    first samples when the first sample is later; false for a tilted start),
    ``at_rest_end`` — at rest at the last sample, ``at_rest_from_s`` — from when on it stays so.
Penetration
    ``max_penetration_m`` as the engine reports it (deepest contact over all steps); an
    engine that reports none gets the depth of the lowest hull point below the pedestal top
    from the samples (zero for the rigid analytical models).
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from pbr_xval.scene import Scene
    from pbr_xval.trajectory import Trajectory

__all__ = [
    "DEFINITION",
    "KEYS",
    "SceneScales",
    "apply_standard_diagnostics",
    "com_velocity",
    "energy_series",
    "ensure_standard_diagnostics",
    "impact_times",
    "regime_label",
    "scene_scales",
    "standard_diagnostics",
]

#: version tag of the definitions, recorded with every result
DEFINITION = "pbr_xval.diagnostics/1 (docs/diagnostics.md)"
#: uplift/contact tolerance floor as a fraction of the lever b (rigid models: p_max = 0)
UPLIFT_REL = 1e-3
#: a flight lasts while the lowest point is this fraction of b above the pedestal top
AIR_FLOOR_REL = 1e-4
#: slip tolerance as a fraction of the lever b
SLIP_REL = 1e-2
#: at rest: kinetic energy below this fraction of the toppling barrier ΔU
REST_ENERGY_REL = 1e-4
#: hull points processed per chunk of samples (bounds the memory of the (n, k, 3) arrays)
_CHUNK = 2_000_000

#: every key :func:`standard_diagnostics` writes (the cross-engine tables show these)
KEYS = (
    "diagnostics_definition",
    "regime",
    "rocked",
    "slid",
    "jumped",
    "uplift_max_m",
    "slip_max_m",
    "slip_end_m",
    "flights",
    "airborne_s",
    "airborne_max_s",
    "impacts",
    "impact_times_s",
    "max_penetration_m",
    "penetration_source",
    "energy_barrier_J",
    "energy_start_J",
    "energy_end_J",
    "energy_max_rel_change",
    "energy_gain_rel",
    "settled",
    "at_rest_end",
    "at_rest_from_s",
    "tolerance_contact_m",
    "tolerance_slip_m",
    "tolerance_theta_rad",
    "evaluated_until_s",
)


@dataclass(frozen=True)
class SceneScales:
    """Geometry facts of a scene that the definitions use (SI units).

    Attributes
    ----------
    hull : (k, 3) float, m — convex-hull vertices relative to the COM, scene axes at rest.
    support : (j,) int — indices into ``hull`` of the points touching the pedestal at rest.
    base_z : float, m — height of the pedestal top (lowest hull point at rest).
    com : (3,) float, m — COM at rest.
    lever : float, m — b, the smaller horizontal lever COM → support edge toward ±d.
    width : float, m — w, the base width along d (sum of the two levers).
    barrier : float, J — ΔU, the potential-energy barrier to toppling in the shaking plane.
    mass : float, kg.
    inertia : (3, 3) float, kg·m² — about the COM, scene axes at rest.
    gravity : float, m/s².
    """

    hull: np.ndarray
    support: np.ndarray
    base_z: float
    com: np.ndarray
    lever: float
    width: float
    barrier: float
    mass: float
    inertia: np.ndarray
    gravity: float


_SCALES_CACHE: dict[str, SceneScales] = {}


def scene_scales(scene: Scene) -> SceneScales:
    """The :class:`SceneScales` of ``scene`` (memoised on the geometry: searches reuse it)."""
    from pbr_xval.geometry.stability import hull_vertices, uplift_lever

    v = np.ascontiguousarray(scene.rock.mesh.vertices, dtype=np.float64)
    com = np.asarray(scene.rock.com, dtype=np.float64)
    d = np.asarray(scene.direction, dtype=np.float64)
    h = hashlib.sha256(v.tobytes())
    for a in (com, d, np.asarray(scene.rock.inertia, dtype=np.float64)):
        h.update(np.ascontiguousarray(a).tobytes())
    h.update(repr((float(scene.rock.mass), float(scene.gravity))).encode())
    key = h.hexdigest()
    hit = _SCALES_CACHE.get(key)
    if hit is not None:
        return hit
    hull = hull_vertices(v)
    size = float(np.ptp(v))
    zmin = float(hull[:, 2].min())
    support = np.nonzero(hull[:, 2] <= zmin + 1e-9 * max(1.0, size))[0]
    b_right, h_g = uplift_lever(v, com, d)
    b_left, _ = uplift_lever(v, com, -d)
    lever = max(min(b_left, b_right), 1e-12)
    alpha = min(scene.alpha)
    barrier = float(scene.rock.mass) * float(scene.gravity) * h_g * (1.0 / math.cos(alpha) - 1.0)
    out = SceneScales(
        hull=hull - com,
        support=support,
        base_z=zmin,
        com=com.copy(),
        lever=float(lever),
        width=float(max(b_left + b_right, lever)),
        barrier=float(barrier),
        mass=float(scene.rock.mass),
        inertia=np.asarray(scene.rock.inertia, dtype=np.float64).copy(),
        gravity=float(scene.gravity),
    )
    if len(_SCALES_CACHE) > 256:
        _SCALES_CACHE.clear()
    _SCALES_CACHE[key] = out
    return out


# ------------------------------------------------------------------ kinematics
def com_velocity(t: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Velocity (n, 3) m/s of sampled positions ``x`` (n, 3) m at times ``t`` (n,) s.

    Second-order differences on the smoothest of the (up to) three three-point stencils that
    contain each sample (smallest second divided difference: an ENO choice), so that a jump
    of the velocity between two samples (an impact) is not averaged into the samples on
    either side. Exact for uniformly accelerated motion; non-uniform ``t`` is allowed.
    """
    t = np.asarray(t, dtype=float)
    x = np.asarray(x, dtype=float).reshape(t.size, -1)
    n = t.size
    if n < 2:
        return np.zeros_like(x)
    if n == 2:
        v = (x[1] - x[0]) / (t[1] - t[0])
        return np.vstack([v, v])
    dt = np.diff(t)
    d1 = np.diff(x, axis=0) / dt[:, None]  # (n-1,) first divided differences
    d2 = np.diff(d1, axis=0) / (t[2:] - t[:-2])[:, None]  # (n-2,) centred at k = 1..n-2
    s = np.linalg.norm(d2, axis=1)
    idx = np.arange(n)
    # candidate stencil centres c ∈ {i-1, i, i+1} ∩ [1, n-2]; pick the smallest s
    best = np.clip(idx, 1, n - 2)
    best_s = s[best - 1]
    for off in (-1, 1):
        c = idx + off
        ok = (c >= 1) & (c <= n - 2)
        cand = np.where(ok, s[np.clip(c, 1, n - 2) - 1], np.inf)
        better = cand < best_s
        best = np.where(better, np.clip(c, 1, n - 2), best)
        best_s = np.where(better, cand, best_s)
    a = best - 1  # stencil (a, a+1, a+2)
    ta, tb = t[a], t[a + 1]
    return d1[a] + d2[best - 1] * ((t - ta) + (t - tb))[:, None]


def energy_series(traj: Trajectory, scene: Scene, velocity: np.ndarray | None = None) -> np.ndarray:
    """Total energy E(t) (n,) J in the pedestal frame, including the work of the inertial load.

    E = ½ m|v|² + ½ ωᵀ R I Rᵀ ω + m g (z_G − z_G,rest) + ∫₀ᵗ m a_g·v dt, with R the rotation
    from rest, I the inertia at rest and a_g the pedestal acceleration (trapezoidal rule on the
    samples). Constant in smooth rigid motion; falls at impacts and in friction.
    """
    t = traj.t
    v = com_velocity(t, traj.com) if velocity is None else velocity
    return _energy(traj, scene, v, traj.rotation_matrices())[0]


def _energy(traj: Trajectory, scene: Scene, v: np.ndarray, rot: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(E(t), kinetic energy) (n,) J each, from the samples' COM velocity ``v`` (n, 3) m/s and
    rotations ``rot`` (n, 3, 3); see :func:`energy_series`."""
    sc = scene_scales(scene)
    t, com, w = traj.t, traj.com, traj.omega
    ke = _kinetic(sc, rot, v, w)
    pe = sc.mass * sc.gravity * (com[:, 2] - sc.com[2])
    ag = np.asarray(scene.excitation.acceleration(t), dtype=float).reshape(t.size, 3)
    power = sc.mass * np.einsum("ni,ni->n", ag, v)
    work = np.concatenate([[0.0], np.cumsum(0.5 * (power[1:] + power[:-1]) * np.diff(t))])
    return ke + pe + work, ke


def impact_times(t: np.ndarray, theta: np.ndarray, tol: float) -> np.ndarray:
    """Landing times (s) of a rocking angle history: the module's impact definition.

    Parameters
    ----------
    t : (n,) s.
    theta : (n,) rad, rocking angle about the rest pose.
    tol : rad, θ_h — an excursion starts when |θ| > tol; it ends (one impact) when |θ| ≤ tol/2
        or θ is beyond −tol on the other side.

    Returns
    -------
    (m,) float, s — for each landing, the θ = 0 crossing (linear interpolation) between the
    landing sample and the one before it, or after it while |θ| stays within tol; the landing
    sample's time when the rock came back without crossing.
    """
    import bisect

    t = np.asarray(t, dtype=float)
    th = np.asarray(theta, dtype=float)
    n = th.size
    out: list[float] = []
    # the rule below jumps between the samples where something can happen (index lists searched
    # with bisect) instead of visiting every sample; NaN compares False exactly as element-wise
    with np.errstate(invalid="ignore"):
        big = np.abs(th) > tol
        prev = np.concatenate(([0.0], th[:-1]))
        lands = {
            1: np.flatnonzero(~(th > 0.5 * tol)).tolist(),
            -1: np.flatnonzero(~(-th > 0.5 * tol)).tolist(),
        }
        cross = {1: (prev > 0) & (0 >= th), -1: (-prev > 0) & (0 >= -th)}
        cross[1][0] = cross[-1][0] = False
    stops = {s: np.flatnonzero(cross[s] | big).tolist() for s in (1, -1)}
    bigs = np.flatnonzero(big).tolist()
    side = 0
    i = 0
    while i < n:
        if side == 0:  # at rest in the band: the next sample beyond tol starts an excursion
            k = bisect.bisect_left(bigs, i)
            if k == len(bigs):
                break
            i = bigs[k]
            side = 1 if th[i] > 0 else -1
            i += 1
            continue
        k = bisect.bisect_left(lands[side], i)  # the next sample back within tol/2 (or beyond)
        if k == len(lands[side]):
            break
        i = lands[side][k]
        x = th[i]
        # landed at sample i: the θ = 0 crossing between samples i − 1 and i, or later while
        # |θ| stays within tol (else the rock came back to the band without crossing: t[i])
        t_hit = float(t[i])
        st = stops[side]
        k = bisect.bisect_left(st, max(i, 1))
        if k < len(st) and cross[side][st[k]]:
            j = st[k]
            a, b = th[j - 1], th[j]
            t_hit = float(t[j - 1] + (a / (a - b)) * (t[j] - t[j - 1]))
        out.append(t_hit)
        side = -side if side * x < -tol else 0
        i += 1
    return np.asarray(out, dtype=float)


def _points_z_and_xy(
    sc: SceneScales, com: np.ndarray, rot: np.ndarray, tol: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per sample: the lowest hull point's height (n,) m; the horizontal displacement (n−1, 2) m
    to the next sample of the contact — the centroid of the hull points within ``tol`` (m) of the
    lowest, as a material point; and the spread of the support points' heights (n,) m."""
    n = com.shape[0]
    k = sc.hull.shape[0]
    # a sample whose pose repeats the previous one exactly (a rock held at rest, recorded at every
    # output sample) has the same points: computed once per run of equal poses
    new_pose = np.ones(n, dtype=bool)
    if n > 1:
        new_pose[1:] = np.any(com[1:] != com[:-1], axis=1) | np.any(
            rot[1:].reshape(n - 1, 9) != rot[:-1].reshape(n - 1, 9), axis=1
        )
    first = np.flatnonzero(new_pose)
    u = first.size
    com_u, rot_u = com[first], rot[first]
    low = np.empty(u)
    contact = np.empty((u, 3))
    spread = np.zeros(u)
    step = max(1, _CHUNK // max(k, 1))
    hull_t = np.ascontiguousarray(sc.hull.T)
    for a in range(0, u, step):
        b = min(u, a + step)
        z = rot_u[a:b, 2, :] @ hull_t + com_u[a:b, 2:3]  # (m, k)
        zmin = z.min(axis=1)
        low[a:b] = zmin
        near = z <= zmin[:, None] + tol
        contact[a:b] = (near.astype(float) @ sc.hull) / np.count_nonzero(near, axis=1)[:, None]
        if sc.support.size >= 2:
            zs = z[:, sc.support]
            spread[a:b] = zs.max(axis=1) - zs.min(axis=1)
    if u < n:
        pose = np.cumsum(new_pose) - 1  # each sample's row among the distinct poses
        low, contact, spread = low[pose], contact[pose], spread[pose]
    r = contact[:-1]
    here = np.einsum("nij,nj->ni", rot[:-1, :2, :], r) + com[:-1, :2]
    there = np.einsum("nij,nj->ni", rot[1:, :2, :], r) + com[1:, :2]
    return low, there - here, spread


# ------------------------------------------------------------------ the figures
def standard_diagnostics(traj: Trajectory, scene: Scene) -> dict[str, Any]:
    """The standard diagnostics of ``traj`` (keys :data:`KEYS`), see the module docstring.

    Parameters
    ----------
    traj : the run; its ``diagnostics["max_penetration_m"]`` (m), when present, is the
        engine's contact figure.
    scene : the compiled scene it ran.

    Returns
    -------
    dict of JSON-able scalars and small lists (SI units, named in the keys).
    """
    sc = scene_scales(scene)
    out: dict[str, Any] = {"diagnostics_definition": DEFINITION, "energy_barrier_J": sc.barrier}
    t = np.asarray(traj.t, dtype=float)
    finite = (
        np.isfinite(t)
        & np.all(np.isfinite(traj.com), axis=1)
        & np.all(np.isfinite(traj.quat), axis=1)
        & np.all(np.isfinite(traj.omega), axis=1)
        if t.size
        else np.zeros(0, dtype=bool)
    )
    n_ok = int(np.argmin(finite)) if t.size and not finite.all() else t.size
    pen_engine = (traj.diagnostics or {}).get("max_penetration_m")
    p_max = float(pen_engine) if isinstance(pen_engine, int | float) and math.isfinite(pen_engine) else 0.0
    tol = max(p_max, UPLIFT_REL * sc.lever)
    tol_slip = SLIP_REL * sc.lever
    theta_h = tol / sc.width
    out.update(
        tolerance_contact_m=tol,
        tolerance_slip_m=tol_slip,
        tolerance_theta_rad=theta_h,
    )
    if n_ok == 0:
        out.update(
            regime="unknown",
            rocked=None,
            slid=None,
            jumped=None,
            impacts=0,
            impact_times_s=[],
            max_penetration_m=pen_engine if pen_engine is not None else None,
            penetration_source="engine contacts" if pen_engine is not None else "none",
            settled=None,
            at_rest_end=None,
            at_rest_from_s=None,
            evaluated_until_s=None,
        )
        return out
    t = t[:n_ok]
    com = np.asarray(traj.com, dtype=float)[:n_ok]
    rot = traj.rotation_matrices()[:n_ok]
    top = traj.toppled_at
    n_ev = int(np.searchsorted(t, top, side="right")) if top is not None else n_ok
    n_ev = max(1, min(n_ev, n_ok))

    low, slip, spread = _points_z_and_xy(sc, com, rot, tol)
    gap = low - sc.base_z
    flights = _flights(t[:n_ev], gap[:n_ev], tol, AIR_FLOOR_REL * sc.lever)
    air = np.zeros(n_ev, dtype=bool)
    for a, b, _, _ in flights:
        air[a:b] = True
    durations = [t1 - t0 for _, _, t0, t1 in flights]
    touching = ~air
    uplift_max = float(np.max(spread[:n_ev][touching])) if touching.any() else 0.0
    # slip: the contact's own displacement, accumulated (in flight: the base's displacement)
    inc = slip[: n_ev - 1]
    acc = np.hypot(*np.cumsum(inc, axis=0).T) if inc.size else np.zeros(1)
    slip_max = float(np.max(acc, initial=0.0))
    slip_end = float(acc[-1]) if acc.size else 0.0
    rocked = uplift_max > tol
    slid = slip_max > tol_slip
    jumped = bool(flights)

    # impacts from the rocking angle
    d = np.asarray(traj.excitation_axis, dtype=float)
    tops = rot[:, :, 2]
    theta = np.arctan2(tops @ d, tops[:, 2])
    imp = impact_times(t[:n_ev], theta[:n_ev], theta_h)

    # energy and rest
    traj_ok = traj if n_ok == traj.t.size else _prefix(traj, n_ok)
    omega = np.asarray(traj.omega, dtype=float)[:n_ok]
    vel = com_velocity(t, com)
    e, ke = _energy(traj_ok, scene, vel, rot)
    e0 = float(e[0])
    change = float(np.max(np.abs(e - e0)))
    gain = float(np.max(e - np.minimum.accumulate(e)))
    rest_ke = REST_ENERGY_REL * sc.barrier
    rest = ke < rest_ke
    ke_start = float(ke[0]) if t[0] <= 0.0 or n_ok < 3 else float(_kinetic_at(sc, t, com, rot, omega, 0.0))
    tilt0 = math.acos(max(-1.0, min(1.0, float(rot[0, 2, 2]))))
    rest_from = None
    if rest[-1]:
        moving = np.nonzero(~rest)[0]
        rest_from = float(t[moving[-1] + 1]) if moving.size else float(t[0])

    if pen_engine is not None:
        pen, pen_src = float(pen_engine), "engine contacts"
    else:
        pen, pen_src = float(max(0.0, -float(np.min(gap)))), "sampled pose"
    out.update(
        regime=_code(rocked, slid, jumped),
        rocked=bool(rocked),
        slid=bool(slid),
        jumped=jumped,
        uplift_max_m=uplift_max,
        slip_max_m=slip_max,
        slip_end_m=slip_end,
        flights=len(flights),
        airborne_s=float(sum(durations)),
        airborne_max_s=float(max(durations, default=0.0)),
        impacts=int(imp.size),
        impact_times_s=[float(x) for x in imp],
        max_penetration_m=pen,
        penetration_source=pen_src,
        energy_start_J=e0,
        energy_end_J=float(e[-1]),
        energy_max_rel_change=change / sc.barrier,
        energy_gain_rel=gain / sc.barrier,
        settled=bool(ke_start < rest_ke and tilt0 <= theta_h),
        at_rest_end=bool(rest[-1]),
        at_rest_from_s=rest_from,
        evaluated_until_s=float(t[n_ev - 1]),
    )
    return out


def _kinetic(sc: SceneScales, rot: np.ndarray, vel: np.ndarray, omega: np.ndarray) -> np.ndarray:
    """Kinetic energy (n,) J from COM velocity (n, 3) m/s and ω (n, 3) rad/s (pedestal frame)."""
    wb = np.einsum("nji,nj->ni", rot, omega)
    return 0.5 * sc.mass * np.einsum("ni,ni->n", vel, vel) + 0.5 * np.einsum(
        "ni,ij,nj->n", wb, sc.inertia, wb
    )


def _kinetic_at(
    sc: SceneScales, t: np.ndarray, com: np.ndarray, rot: np.ndarray, omega: np.ndarray, s: float
) -> float:
    """Kinetic energy (J) at time ``s`` before the first sample: the quadratic through the first
    three COM samples and the line through the first two ω samples, evaluated at ``s``."""
    t0, t1, t2 = t[:3]
    d01 = (com[1] - com[0]) / (t1 - t0)
    d12 = (com[2] - com[1]) / (t2 - t1)
    d012 = (d12 - d01) / (t2 - t0)
    v = d01 + d012 * ((s - t0) + (s - t1))
    w = omega[0] + (omega[1] - omega[0]) * (s - t0) / (t1 - t0)
    return float(_kinetic(sc, rot[:1], v[None, :], w[None, :])[0])


def _flights(t: np.ndarray, gap: np.ndarray, tol: float, floor: float) -> list[tuple[int, int, float, float]]:
    """Flights: maximal runs of samples [a, b) with ``gap`` > ``floor`` (m) that reach ``gap`` >
    ``tol``, with their start and end times (s), linearly interpolated at gap = ``floor``."""
    gap = gap - floor
    pos = gap > 0.0
    if not pos.any():
        return []
    edges = np.diff(np.concatenate([[0], pos.astype(np.int8), [0]]))
    out = []
    for a, b in zip(np.nonzero(edges == 1)[0], np.nonzero(edges == -1)[0], strict=True):
        if not np.any(gap[a:b] > tol - floor):
            continue
        t0 = float(t[a])
        if a > 0:
            g0, g1 = gap[a - 1], gap[a]
            t0 = float(t[a - 1] + (-g0 / (g1 - g0)) * (t[a] - t[a - 1]))
        t1 = float(t[b - 1])
        if b < t.size:
            g0, g1 = gap[b - 1], gap[b]
            t1 = float(t[b - 1] + (g0 / (g0 - g1)) * (t[b] - t[b - 1]))
        out.append((int(a), int(b), t0, t1))
    return out


def _prefix(traj: Trajectory, n: int) -> Trajectory:
    import dataclasses

    return dataclasses.replace(traj, t=traj.t[:n], com=traj.com[:n], quat=traj.quat[:n], omega=traj.omega[:n])


def _code(rocked: bool, slid: bool, jumped: bool) -> str:
    parts = [p for p, on in (("rock", rocked), ("slide", slid), ("jump", jumped)) if on]
    return "+".join(parts) if parts else "rest"


def regime_label(diag: dict[str, Any]) -> str:
    """Human sentence for the regime in ``diag`` (a Trajectory's diagnostics).

    E.g. ``"at rest"``, ``"rocked"``, ``"slid 0.123 m"``, ``"rocked and slid 0.012 m"``,
    ``"rocked, jumped (0.031 s airborne)"``; ``"unknown"`` without the standard diagnostics.
    """
    code = diag.get("regime")
    if not code or code == "unknown":
        return "unknown"
    if code == "rest":
        return "at rest"
    rocked, slid, jumped = diag.get("rocked"), diag.get("slid"), diag.get("jumped")
    words = []
    if rocked and slid:
        words.append(f"rocked and slid {diag.get('slip_max_m', float('nan')):.3g} m")
    elif rocked:
        words.append("rocked")
    elif slid:
        words.append(f"slid {diag.get('slip_max_m', float('nan')):.3g} m")
    if jumped:
        words.append(f"jumped ({diag.get('airborne_s', float('nan')):.3g} s airborne)")
    return ", ".join(words)


def apply_standard_diagnostics(traj: Trajectory, scene: Scene) -> Trajectory:
    """Write :func:`standard_diagnostics` into ``traj.diagnostics`` (in place) and return ``traj``.

    The engine's own ``max_penetration_m`` is kept; every other standard key is replaced.
    """
    traj.diagnostics = {**(traj.diagnostics or {}), **standard_diagnostics(traj, scene)}
    return traj


def ensure_standard_diagnostics(traj: Trajectory, scene: Scene) -> Trajectory:
    """:func:`apply_standard_diagnostics` unless ``traj`` already carries them (e.g. from the
    engines' recorder); for engines that build their Trajectory themselves (the analytical
    ones, plugins). Returns ``traj``."""
    if (traj.diagnostics or {}).get("diagnostics_definition") != DEFINITION:
        apply_standard_diagnostics(traj, scene)
    return traj
