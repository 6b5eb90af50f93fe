"""Static stability of a rigid rock on a flat pedestal: uplift and critical tilt angles.

Two quantities field workers estimate with tilt tests:

* the **critical tilt angle** α(φ): tilt the rock toward the horizontal direction φ, letting
  it pivot or roll on its convex hull without slip; α(φ) is the tilt at which the centre of
  mass passes over the contact point (the restoring moment vanishes). For a block it is
  atan(b/h) toward each face; for a curved base it exceeds the uplift angle;
* the **uplift acceleration** g·b(φ)/h_G: the quasi-static horizontal acceleration at which the
  rock starts to rock about the edge of its support polygon, b(φ) being the distance from the
  COM's vertical to that edge along φ and h_G the COM height.

Two levers b(φ) appear, and they differ away from the normals of the support polygon's edges:

* the **support lever** b_s(φ) = max over the support of (p − c)·d — the contact that is lowest
  when the rock is turned about the horizontal axis ⟂ φ; it sets the critical tilt α(φ) of that
  rotation (the toppling criterion's α);
* the **ray lever** ρ(φ) — the distance from the COM's vertical to the edge of the support
  polygon along φ. Under a constant horizontal pedestal acceleration a toward −φ the effective
  gravity line through the COM meets the base at c + h_G·(a/g)·d; the contact forces can hold
  the rock on its base only while that point is inside the polygon, so the rock uplifts at
  a = g·ρ(φ)/h_G = g·tan α_u(φ). α_u is the tilt-table angle of a flat-based rock, and since no
  rock topples without uplifting, g·tan α_u(φ) (with φ and φ + π for shaking along ±φ) is a hard
  lower bound on the peak ground acceleration of any horizontal motion that topples it.

A pose is **at rest** when the COM's vertical passes strictly inside the support polygon
(:func:`rest_margin` > 0). Outside it neither angle exists: α and α_u are NaN (never 0).
"""

from __future__ import annotations

import hashlib
from functools import cached_property

import numpy as np
from scipy.optimize import brentq
from scipy.spatial import ConvexHull

__all__ = [
    "StabilityTable",
    "critical_tilt",
    "hull_vertices",
    "ray_lever",
    "rest_margin",
    "support_lever",
    "support_points",
    "support_polygon",
    "uplift_lever",
]


def _rot_about(axis: np.ndarray, angle: float) -> np.ndarray:
    axis = axis / np.linalg.norm(axis)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * (k @ k)


#: hull vertex indices by point-set content (ensemble members and campaign tests re-use one mesh)
_HULL_INDEX: dict[bytes, np.ndarray] = {}


def hull_vertices(vertices: np.ndarray) -> np.ndarray:
    """Convex-hull vertices (k, 3) of a point set (n, 3).

    The hull's vertex indices are memoised on the points' bytes (a run computes the hull of one
    mesh some twenty times: scene, stability, diagnostics); above 16 points, a new array each call.
    """
    v = np.ascontiguousarray(vertices, dtype=float)
    if len(v) > 16:
        key = hashlib.sha256(v.tobytes()).digest() + repr(v.shape).encode()
        idx = _HULL_INDEX.get(key)
        if idx is None:
            if len(_HULL_INDEX) > 64:
                _HULL_INDEX.clear()
            idx = _HULL_INDEX[key] = ConvexHull(v).vertices
        v = v[idx]
    return v


def support_points(vertices: np.ndarray, tol: float | None = None) -> np.ndarray:
    """Points (k, 3) of the convex hull within ``tol`` (m) of the lowest z: the support set."""
    v = np.asarray(vertices, dtype=float)
    zmin = v[:, 2].min()
    if tol is None:
        tol = 1e-9 * max(1.0, float(np.ptp(v)))
    return v[v[:, 2] <= zmin + tol]


def support_polygon(vertices: np.ndarray, tol: float | None = None) -> np.ndarray:
    """Support polygon (q, 2): counter-clockwise x–y vertices of the 2-D hull of :func:`support_points`.

    Fewer than three vertices (q = 1: a point, q = 2: a segment) when the rock touches the
    plane at a vertex or along an edge only.
    """
    sp = support_points(hull_vertices(vertices), tol)[:, :2]
    uniq = np.unique(np.round(sp, 12), axis=0)
    if len(uniq) < 3:
        return uniq
    try:
        h = ConvexHull(uniq)
    except Exception:  # collinear points: the two ends of the segment
        d = uniq - uniq.mean(axis=0)
        ax = np.linalg.svd(d, full_matrices=False)[2][0]
        t = d @ ax
        return uniq[[int(np.argmin(t)), int(np.argmax(t))]]
    return uniq[h.vertices]  # scipy returns 2-D hulls counter-clockwise


def rest_margin(polygon: np.ndarray, point: np.ndarray) -> float:
    """Signed distance (m) of the x–y ``point`` inside the support ``polygon`` (q, 2), ccw.

    > 0: inside (the rock rests; the value is the smallest distance to an edge);
    ≤ 0: on or outside the polygon, or the polygon is a point or a segment (the rock is not at
    rest; the value is minus the distance to the polygon).
    """
    poly = np.asarray(polygon, float)
    p = np.asarray(point, float)[:2]
    if len(poly) == 1:
        return -float(np.linalg.norm(p - poly[0]))
    if len(poly) == 2:
        a, b = poly
        t = np.clip((p - a) @ (b - a) / max((b - a) @ (b - a), 1e-300), 0.0, 1.0)
        return -float(np.linalg.norm(p - (a + t * (b - a))))
    e = np.roll(poly, -1, axis=0) - poly
    n = np.column_stack([e[:, 1], -e[:, 0]]) / np.linalg.norm(e, axis=1)[:, None]  # outward (ccw)
    s = np.einsum("ij,ij->i", n, poly - p)  # distance of p inside each edge's line
    if np.all(s > 0):
        return float(s.min())
    # outside: distance to the nearest edge segment
    best = np.inf
    for a, ei in zip(poly, e, strict=True):
        t = np.clip((p - a) @ ei / (ei @ ei), 0.0, 1.0)
        best = min(best, float(np.linalg.norm(p - (a + t * ei))))
    return -best


def ray_lever(polygon: np.ndarray, point: np.ndarray, direction: np.ndarray) -> float:
    """Distance (m) from the x–y ``point`` to the edge of the ccw ``polygon`` along ``direction``.

    NaN when the point is not strictly inside the polygon (the rock is not at rest).
    """
    poly = np.asarray(polygon, float)
    p = np.asarray(point, float)[:2]
    d = np.asarray(direction, float)[:2]
    d = d / np.linalg.norm(d)
    if rest_margin(poly, p) <= 0:
        return float("nan")
    e = np.roll(poly, -1, axis=0) - poly
    n = np.column_stack([e[:, 1], -e[:, 0]]) / np.linalg.norm(e, axis=1)[:, None]
    s = np.einsum("ij,ij->i", n, poly - p)
    nd = n @ d
    ahead = nd > 1e-15
    return float(np.min(s[ahead] / nd[ahead]))


def support_lever(vertices: np.ndarray, com: np.ndarray, direction: np.ndarray) -> tuple[float, float]:
    """(b_s, h): support lever max over the support of (p − c)·d, and the COM height, m.

    The lowest contact when the rock is turned about the horizontal axis ⟂ ``direction``; equal
    to the ray lever along the normals of the support polygon's edges, larger in between.
    """
    d = np.asarray(direction, dtype=float)
    d = d / np.linalg.norm(d)
    sp = support_points(hull_vertices(vertices))
    b = float(np.max((sp - com) @ d))
    h = float(com[2] - sp[:, 2].min())
    return b, h


def uplift_lever(vertices: np.ndarray, com: np.ndarray, direction: np.ndarray) -> tuple[float, float]:
    """(b, h): uplift lever toward ``direction`` and COM height, m.

    The rock tips toward ``direction`` when the pedestal accelerates the other way with
    |a| > g·b/h. ``b`` is the ray lever ρ (the distance from the COM's vertical to the edge of
    the support polygon along ``direction``; module docstring); when the support is a point or
    a segment (no polygon: e.g. an extruded curved base on its line of contact) it falls back
    to the support lever.
    """
    b_s, h = support_lever(vertices, com, direction)
    hv = hull_vertices(vertices)
    c = np.asarray(com, dtype=float)
    rho = ray_lever(support_polygon(hv), c[:2], np.asarray(direction, dtype=float))
    return (rho if np.isfinite(rho) else b_s), h


def critical_tilt(vertices: np.ndarray, com: np.ndarray, direction: np.ndarray) -> float:
    """Critical tilt angle (rad) toward the horizontal unit ``direction``.

    The rock (convex hull of ``vertices``, (n, 3) m, resting on z = min z) is rotated about the
    horizontal axis ⟂ to ``direction`` so that its top moves toward ``direction``; the contact is
    the lowest hull point (ties broken toward ``direction``). Returns the smallest angle at which
    the COM passes over the contact, found by bracketing (steps of 0.125°) and Brent's method
    (1e-12 rad). The search runs up to π: a rock lying on a broad face rolls onto neighbouring
    hull faces as it turns and can pass over its contact only beyond 90°.

    NaN when the COM is not inside its support toward ``direction`` at θ = 0 (the pose is not at
    rest: no critical tilt exists) and when no crossing is found below π.
    """
    d = np.asarray(direction, dtype=float)
    d = np.array([d[0], d[1], 0.0]) / np.hypot(d[0], d[1])
    axis = np.cross([0.0, 0.0, 1.0], d)
    hv = hull_vertices(vertices) - np.asarray(com, dtype=float)
    scale = float(np.ptp(hv))

    def margin(theta: float) -> float:
        p = hv @ _rot_about(axis, theta).T
        z = p[:, 2]
        low = p[z <= z.min() + 1e-9 * scale]
        return float(np.max(low @ d))  # contact ahead of the COM (> 0) = stable

    if margin(0.0) <= 0:
        return float("nan")
    grid = np.linspace(0.0, np.pi, 1441)
    prev = grid[0]
    for th in grid[1:]:
        if margin(th) <= 0:
            return float(brentq(margin, prev, th, xtol=1e-13))
        prev = th
    return float("nan")


def _rolling_tilt(rel: np.ndarray, direction: np.ndarray, tol: float) -> float:
    """First angle (rad) at which the COM passes over its contact, tilting toward the horizontal unit
    ``direction`` the hull vertices ``rel`` (k, 3), m, relative to the COM, found by following the
    contact. A lower bound on :func:`critical_tilt`, equal to it unless a neighbouring point catches
    the rock within one of that function's 0.125° steps after the COM passed over the contact.

    Only the coordinates along ``direction`` (s) and z matter: turned by θ, a point is at
    s' = s cos θ + z sin θ and z' = z cos θ − s sin θ. The COM passes over a contact c at
    θ_c = atan2(s_c, −z_c). Start from the lowest point farthest along ``direction``; at θ_c
    take the lowest points (within ``tol``, m) — if c is still the one farthest along, θ_c is
    the critical tilt; otherwise the contact has rolled forward to a point q (the contact only
    moves forward as the hull turns, so the COM cannot pass over any contact before θ_q) and the
    step repeats from q. NaN when the COM is not inside its support toward ``direction`` or no
    crossing exists below π.
    """
    s = rel @ direction
    z = rel[:, 2]
    low = z <= z.min() + tol
    c = int(np.argmax(np.where(low, s, -np.inf)))
    if s[c] <= 0:
        return float("nan")
    for _ in range(len(rel)):
        theta = float(np.arctan2(s[c], -z[c]))
        if theta >= np.pi:
            return float("nan")
        cs, sn = np.cos(theta), np.sin(theta)
        zr = z * cs - s * sn
        sr = s * cs + z * sn
        low = zr <= zr.min() + tol
        q = int(np.argmax(np.where(low, sr, -np.inf)))
        if q == c or sr[q] <= sr[c] + tol:
            return theta
        c = q
    return float("nan")  # pragma: no cover - the contact cannot visit more points than the hull has


class StabilityTable:
    """Critical tilt α(φ), tilt-table angle α_u(φ) and uplift levers on a grid of directions.

    Parameters
    ----------
    vertices : (n, 3) float, m — rock vertices in the scene frame, at rest.
    com : (3,) float, m.
    n_directions : directions φ = 2πk/n (rad from +x toward +y, i.e. counter-clockwise seen
        from above; φ = 0 along +x).

    Attributes
    ----------
    phi : (n_directions,) rad.
    alpha : (n_directions,) rad — critical tilt of the rotation about the axis ⟂ φ
        (:func:`critical_tilt`; NaN when the pose is not at rest).
    uplift_angle : (n_directions,) rad — α_u(φ) = atan(ρ(φ)/h_G), ρ the ray lever
        (:func:`ray_lever`; NaN when the pose is not at rest).
    lever : (n_directions,) m — support levers b_s(φ) (:func:`support_lever`).
    ray : (n_directions,) m — ray levers ρ(φ).
    polygon : (q, 2) m — the support polygon; margin : m — :func:`rest_margin` of the COM.
    com_height : m.
    """

    def __init__(self, vertices: np.ndarray, com: np.ndarray, n_directions: int = 72) -> None:
        self.phi = np.linspace(0.0, 2 * np.pi, n_directions, endpoint=False)
        hv = hull_vertices(vertices)
        com = np.asarray(com, dtype=float)
        dirs = np.column_stack([np.cos(self.phi), np.sin(self.phi), np.zeros_like(self.phi)])
        self.alpha = np.array([critical_tilt(hv, com, d) for d in dirs])
        levers = np.array([support_lever(hv, com, d) for d in dirs])
        self.lever = levers[:, 0]
        self.com_height = float(levers[0, 1])
        self.polygon = support_polygon(hv)
        self._com_xy = com[:2].copy()
        self.margin = rest_margin(self.polygon, com[:2])
        self.ray = np.array([ray_lever(self.polygon, com[:2], d) for d in dirs])
        self.uplift_angle = np.arctan2(self.ray, self.com_height)
        self._hull = hv
        self._com = com.copy()

    @property
    def at_rest(self) -> bool:
        """True when the COM's vertical passes strictly inside the support polygon."""
        return self.margin > 0

    def minimum(self, step_deg: float = 0.25) -> tuple[float, float]:
        """(α_min, φ_min), rad: the smallest critical tilt over all directions, not only the table's.

        α(φ) of a polyhedral hull is discontinuous in φ: where the rock pivots on a single hull
        vertex until its COM passes over it, α(φ) = atan(b_s(φ)/h) exactly, and next to that
        window a neighbouring base point catches the rock and α jumps up. Such a window can be
        narrower than the table's spacing (SP1: 4.6° over 336–339°, while the 5° table reads
        10.0° at 335°). Branch and bound on a ``step_deg`` grid with the α of
        :func:`critical_tilt` (the table's): :func:`_rolling_tilt`, the first angle at which the
        COM passes over a contact, is a lower bound on it (equal except where a neighbouring point
        catches the rock within a step of the tilt), cheap enough for every direction; directions
        are evaluated in increasing order of that bound until it exceeds the best α found, and the
        best is refined by a bounded scalar search within ± one step. A window narrower than
        ``step_deg`` can still be missed. NaN, NaN when the pose is not at rest.
        """
        from scipy.optimize import minimize_scalar

        ok = np.isfinite(self.alpha)
        if not self.at_rest or not ok.any():
            return float("nan"), float("nan")
        rel = self._hull - self._com
        tol = 1e-9 * float(np.ptp(rel))

        def unit(p: float) -> np.ndarray:
            return np.array([np.cos(p), np.sin(p), 0.0])

        def tilt(p: float) -> float:
            a = critical_tilt(self._hull, self._com, unit(p))
            return float(a) if np.isfinite(a) else float("inf")

        phi = np.radians(np.arange(0.0, 360.0, step_deg))
        bound = np.array([_rolling_tilt(rel, unit(float(p)), tol) for p in phi])
        bound = np.where(np.isfinite(bound), bound, np.inf)
        k0 = int(np.argmin(np.where(ok, self.alpha, np.inf)))
        best, best_phi = float(self.alpha[k0]), float(self.phi[k0])
        for k in np.argsort(bound, kind="stable"):
            if bound[k] >= best:
                break
            a = tilt(float(phi[k]))
            if a < best:
                best, best_phi = a, float(phi[k])
        step = np.radians(step_deg)
        r = minimize_scalar(
            tilt, bounds=(best_phi - step, best_phi + step), method="bounded", options={"xatol": 1e-5}
        )
        if float(r.fun) < best:
            best, best_phi = float(r.fun), float(r.x)
        return best, best_phi % (2 * np.pi)

    @cached_property
    def _alpha_periodic(self) -> tuple[np.ndarray, np.ndarray]:
        """(φ, α) closed over the circle (φ = 2π appended, α(2π) = α(0)): :meth:`alpha_at`'s table,
        built once — the engines' recorder asks for α(φ) at every step past the smallest critical
        tilt (:meth:`pbr_xval.scene.Scene.past_critical`)."""
        return np.append(self.phi, 2 * np.pi), np.append(self.alpha, self.alpha[0])

    def alpha_at(self, phi: np.ndarray | float) -> np.ndarray:
        """Critical tilt (rad) at directions ``phi`` (rad), periodic linear interpolation."""
        p = np.asarray(phi, dtype=float) % (2 * np.pi)
        xp, fp = self._alpha_periodic
        return np.interp(p, xp, fp)

    def toppling_accel(self, g: float = 9.81) -> np.ndarray:
        """Quasi-static toppling acceleration g·tan α_u(φ) = g·ρ(φ)/h_G (m/s²) on the grid ``phi``.

        The constant horizontal pedestal acceleration (toward φ + π) that tips the rock toward
        φ off its base (module docstring); finite wherever the pose is at rest, NaN elsewhere.
        """
        return g * self.ray / self.com_height

    def shaking_bound(self, phi: np.ndarray | float, g: float = 9.81) -> np.ndarray:
        """Lower bound (m/s²) on the PGA of any horizontal motion along ±φ that topples the rock.

        min(g·tan α_u(φ), g·tan α_u(φ + π)), evaluated exactly (not interpolated) at ``phi`` (rad).
        """
        ph = np.atleast_1d(np.asarray(phi, dtype=float))
        out = []
        for p in ph:
            levers = [
                ray_lever(self.polygon, self._com_xy, np.array([np.cos(q), np.sin(q)]))
                for q in (p, p + np.pi)
            ]
            out.append(g * min(levers) / self.com_height)
        res = np.asarray(out)
        return res if np.ndim(phi) else res[0]

    def uplift_accel(self, phi: float, g: float) -> float:
        """Quasi-static acceleration (m/s²) that tips the rock toward direction ``phi``."""
        p = float(phi) % (2 * np.pi)
        xp = np.append(self.phi, 2 * np.pi)
        fp = np.append(self.lever, self.lever[0])
        return float(g * np.interp(p, xp, fp) / self.com_height)
