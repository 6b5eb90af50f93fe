"""Impact dissipation in each engine against the rebound the rock's geometry implies (issue 22, item 5).

A rock rocking in the shaking plane (x' along the shaking direction d, z up, rotation about
e = ez × d) loses energy only at impacts in the rigid-body picture. When the contact jumps from
a pivot P1 to a pivot P2 in a perfectly inelastic impact, the angular momentum about P2 is
conserved (Housner 1963, generalised to an asymmetric section):

    ω⁺/ω⁻ = (I_G + m r₁·r₂) / (I_G + m |r₂|²),   r_i = G − P_i (in-plane vectors, m),

and the kinetic energy is multiplied by (I_G + m r₁·r₂)² / (I_O1 I_O2), I_Oi = I_G + m |r_i|²
(the same in both directions). For a symmetric block r₁·r₂ = h² − b² and the ratio is
1 − 2 m b²/I_O (Housner's 1 − 1.5 sin²α for a uniform rectangle).

A scanned base is not two edges: seen along e, the rock's convex hull is a polygon, and as the
rock tilts its contact rolls from vertex to vertex; each landing of a polygon edge is an
impact with the same formula (a *polygon rocker*). :class:`Section` holds that planar section
and predicts the energy at each turning point from the previous one (back-roll landings,
the face impact at θ = 0, out-roll landings).

The measurement (``python -m pbr_xval.validation.rebound``): each engine runs the committed
scenario (its mesh, mass, azimuth, contact; engine settings as ``validate`` runs them: the
engine's default profile, the committed ``timestep`` 1e-3 s, and 1e-4 s to separate the
time-step dissipation from the contact model) with no excitation and a free-rocking start:
the rock leaves its rest pose on one side's face pivot at the angular rate that would carry a
lossless polygon rocker to ``fraction`` × α of that side. (A tilted start, ``theta_over_alpha``,
rotated the rock about the face pivot, which on a scanned hull pushed the next hull vertices
below the pedestal — MuJoCo then launched the rock — until commit 0d28830 lifted such a start
onto the vertex; the start here stays a rate at θ = 0, which needs no pose at all.) From the
trajectory: the mechanical energy E(t) = ½ ω·I ω + ½ m v² + m g Δz (v by central differences
of the COM), the rocking angle θ, and per face impact (θ crossing 0) the energy just before and
just after it while the rock is on its face pivots, converted to ω⁺/ω⁻ with each side's I_O;
per half-cycle the energy at the turning point. Also reported: peak out-of-plane rotation (roll
about d, yaw about z), the peak COM displacement along e and the engine's standard slip and
flight diagnostics. Planar formulas assume the rock stays in the plane: where it does not, the
printed ratios are what the engine did, not a test of the formula.

``--specimens prism`` runs the control: a two-edge asymmetric prism (:data:`PRISM_SECTION`), on
which the planar formula is exact, so an engine's departure from it there is its contact model
and time step, not the geometry.

Printed per engine × rock × dt × side: ``rebound`` (the first two face impacts' ω⁺/ω⁻, measured,
the two-pivot value and their ratio), ``energy`` (start, first turning point against the
polygon rocker, energy kept per half-cycle against the polygon rocker started from the measured
turning point), ``landing`` (kinetic energy kept at the first edge landing, measured and for the
three kinematics of :func:`first_landing_3d`), ``cycle`` (geometric mean of the first four
half-cycles and the energy lost per cycle of two half-cycles), ``barrier`` (the energy barrier
along the shaking, both ways, and the weakest direction's: :func:`barrier`) and ``motion``.

Usage (developer tool; 40–50 s wall for the command below on 2 shared cores)::

    python -m pbr_xval.validation.rebound --specimens prism,SP1,SP2 --sides weak,strong \
        --fraction 0.5 --out runs/rebound/f050.json
"""

from __future__ import annotations

import argparse
import itertools
import math
import subprocess
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from pbr_xval.analytical.rocking import two_pivot_rebound

__all__ = [
    "ImpactMeasurement",
    "RockingMeasurement",
    "Section",
    "main",
    "measure_rocking",
    "two_pivot_energy_ratio",
    "two_pivot_rebound",
]

#: committed scanned-rock scenarios: label → path relative to the repository root
SPECIMENS = {"SP1": "examples/validation/sp1.toml", "SP2": "examples/validation/sp2.toml"}
#: energy barriers per rock label (:func:`barrier`), computed once per process
_BARRIERS: dict[str, dict[str, float]] = {}
#: the control rock ``prism``: a two-edge asymmetric section (x, z), m, extruded over y ∈ [−0.2, 0.2] m
PRISM_SECTION = ((-0.12, 0.0), (0.28, 0.0), (0.12, 1.0), (-0.12, 1.0))
#: a half-cycle whose peak |θ| stays below this (rad) is contact chatter, not rocking
MIN_HALF_CYCLE_RAD = 2e-3
#: samples closer than this (s) to a θ = 0 crossing are left out of the energy before/after it
IMPACT_GUARD_S = 0.01


# ------------------------------------------------------------------- closed forms
def two_pivot_energy_ratio(inertia: float, mass: float, r_old: Any, r_new: Any) -> float:
    """Kinetic energy after / before the impact of :func:`two_pivot_rebound` (-, symmetric in P1, P2).

    (I_G + m r₁·r₂)² / (I_O1 I_O2) with I_Oi = I_G + m |r_i|²; arguments as there.
    """
    r1, r2 = np.asarray(r_old, dtype=float), np.asarray(r_new, dtype=float)
    i1, i2 = inertia + mass * (r1 @ r1), inertia + mass * (r2 @ r2)
    return float((inertia + mass * (r1 @ r2)) ** 2 / (i1 * i2))


# ------------------------------------------------------------ the planar section
def _rotate(p: np.ndarray, theta: float) -> np.ndarray:
    """(k, 2) in-plane points (x', z) rotated by θ (rad, positive: the top toward +x')."""
    c, s = math.cos(theta), math.sin(theta)
    return np.c_[p[:, 0] * c + p[:, 1] * s, -p[:, 0] * s + p[:, 1] * c]


@dataclass(frozen=True)
class Section:
    """The rock seen along its rocking axis e: a convex polygon rocker.

    Attributes
    ----------
    mass : kg.
    inertia : I_G about e through the COM, kg·m².
    polygon : (k, 2) m, counter-clockwise vertices (x' along d, z up) relative to the COM at rest.
    gravity : m/s².
    """

    mass: float
    inertia: float
    polygon: np.ndarray
    gravity: float = 9.81
    _chains: dict[int, list[tuple[float, int, int]]] = field(default_factory=dict, repr=False, compare=False)

    @classmethod
    def from_vertices(
        cls, vertices: np.ndarray, com: np.ndarray, inertia: np.ndarray, mass: float,
        direction: np.ndarray, gravity: float = 9.81,
    ) -> Section:  # fmt: skip
        """Section of a rock (vertices (n, 3) m at rest, COM (3,) m, inertia (3, 3) kg·m² about the
        COM) rocking in the vertical plane of the horizontal unit ``direction`` (3,)."""
        from scipy.spatial import ConvexHull

        d = np.asarray(direction, dtype=float)
        e = np.cross([0.0, 0.0, 1.0], d)
        p = np.asarray(vertices, dtype=float) - np.asarray(com, dtype=float)
        q = np.c_[p @ d, p[:, 2]]
        hull = ConvexHull(q)
        return cls(
            mass=float(mass), inertia=float(e @ inertia @ e), polygon=q[hull.vertices], gravity=gravity
        )

    @classmethod
    def from_scene(cls, scene: Any) -> Section:
        """Section of a compiled :class:`~pbr_xval.scene.Scene`'s rock in its shaking plane."""
        from pbr_xval.geometry.stability import hull_vertices

        return cls.from_vertices(
            hull_vertices(scene.rock.mesh.vertices), scene.rock.com, scene.rock.inertia, scene.rock.mass,
            scene.direction, scene.gravity,
        )  # fmt: skip

    # -------------------------------------------------------------- geometry
    @property
    def rest_height(self) -> float:
        """Height of the COM above the pedestal at rest, m."""
        return float(-self.polygon[:, 1].min())

    def height(self, theta: float) -> float:
        """COM height above the pedestal (m) when the rock rests on its hull tilted by θ (rad)."""
        return float(-_rotate(self.polygon, theta)[:, 1].min())

    def potential(self, theta: float) -> float:
        """Potential energy above rest (J) at tilt θ (rad)."""
        return self.mass * self.gravity * (self.height(theta) - self.rest_height)

    def face(self, side: int) -> int:
        """Index of the resting face's extreme vertex toward ``side`` (+1: +x', −1: −x')."""
        z = self.polygon[:, 1]
        tol = 1e-9 * float(np.ptp(self.polygon))
        low = np.nonzero(z <= z.min() + tol)[0]
        x = self.polygon[low, 0]
        return int(low[np.argmax(x)] if side > 0 else low[np.argmin(x)])

    def chain(self, side: int) -> list[tuple[float, int, int]]:
        """Edge landings when the rock rolls out toward ``side``: (|θ| at landing rad, old vertex,
        new vertex), in order, up to 90°."""
        if side in self._chains:
            return self._chains[side]
        k = len(self.polygon)
        out = []
        i = self.face(side)
        step = 1 if side > 0 else -1  # counter-clockwise from the bottom-right goes up the right side
        for _ in range(k):
            j = (i + step) % k
            dx, dz = self.polygon[j] - self.polygon[i]
            phi = math.atan2(dz, side * dx)  # side·dx: the edge's outward run
            if phi >= math.pi / 2 or dz <= 0:
                break
            out.append((phi, i, j))
            i = j
        self._chains[side] = out
        return out

    def alpha(self, side: int) -> float:
        """Critical tilt toward ``side`` (rad): the COM passes over the contact."""
        chain = self.chain(side)
        last = chain[-1][2] if chain else self.face(side)
        lo = 0.0
        for phi, a, _ in [*chain, (math.pi / 2, last, -1)]:
            v = self.polygon[a]
            crit = math.atan2(abs(v[0]), -v[1])
            if lo <= crit <= phi:
                return crit
            lo = phi
        return math.nan

    def r(self, vertex: int) -> np.ndarray:
        """(2,) m, G − P for a vertex of the polygon."""
        return np.asarray(-self.polygon[vertex], dtype=float)

    def face_rebound(self, side_from: int) -> float:
        """ω⁺/ω⁻ at the face impact θ = 0 when the rock comes back from ``side_from``."""
        return two_pivot_rebound(
            self.inertia, self.mass, self.r(self.face(side_from)), self.r(self.face(-side_from))
        )

    def face_energy_ratio(self) -> float:
        """Kinetic energy kept at the face impact (either direction), -."""
        return two_pivot_energy_ratio(self.inertia, self.mass, self.r(self.face(1)), self.r(self.face(-1)))

    def pivot_inertia(self, vertex: int) -> float:
        """I_O about the vertex, kg·m²."""
        r = self.r(vertex)
        return float(self.inertia + self.mass * (r @ r))

    # ----------------------------------------------------------- the polygon rocker
    def roll_out(self, energy: float, side: int) -> tuple[float, bool, int]:
        """Leave θ = 0 on the ``side`` face pivot with mechanical energy ``energy`` (J above rest).

        Returns (energy at the turning point J, toppled, edge landings passed).
        """
        e = float(energy)
        crossed = 0
        prev = 0.0
        chain = self.chain(side)
        last = chain[-1][2] if chain else self.face(side)
        for phi, a, b in [*chain, (math.pi / 2, last, -1)]:
            v = self.polygon[a]
            crit = math.atan2(abs(v[0]), -v[1])
            if crit <= phi:  # the COM passes over vertex a on its arc: turn back before it, or topple
                return e, crit < prev or e > self.potential(side * crit), crossed
            if b < 0:  # no landing below 90° and the COM never passes over the last vertex
                return e, True, crossed
            pe = self.potential(side * phi)
            if e <= pe:
                return e, False, crossed
            e = pe + two_pivot_energy_ratio(self.inertia, self.mass, self.r(a), self.r(b)) * (e - pe)
            crossed += 1
            prev = phi
        return e, True, crossed

    def roll_back(self, energy: float, side: int) -> float:
        """From a turning point on ``side`` with energy ``energy`` (J) back to θ = 0 (J, just before
        the face impact)."""
        e = float(energy)
        passed = []
        for phi, a, b in self.chain(side):  # the landings below the turning point
            v = self.polygon[a]
            if math.atan2(abs(v[0]), -v[1]) <= phi or self.potential(side * phi) >= e:
                break
            passed.append((phi, a, b))
        for phi, a, b in reversed(passed):
            pe = self.potential(side * phi)
            e = pe + two_pivot_energy_ratio(self.inertia, self.mass, self.r(a), self.r(b)) * (e - pe)
        return e

    def next_peak(self, energy: float, side: int) -> tuple[float, bool]:
        """Energy (J) at the next turning point (on −side) after one on ``side``; and toppled."""
        e0 = self.roll_back(energy, side) * self.face_energy_ratio()
        e1, toppled, _ = self.roll_out(e0, -side)
        return e1, toppled

    def start_rate(self, fraction: float, side: int) -> float:
        """Rate (rad/s, signed) at θ = 0 on the face pivot of ``side`` that would carry a
        lossless rocker to ``fraction`` × α(side)."""
        th = fraction * self.alpha(side)
        return side * math.sqrt(2 * self.potential(side * th) / self.pivot_inertia(self.face(side)))


def first_landing_3d(scene: Any, section: Section, side: int) -> dict[str, float]:
    """Kinetic energy kept (-) at the first edge landing after leaving the rest face toward
    ``side``, rotating about e through the face pivot A, for three post-impact kinematics of
    a perfectly inelastic impact at the landing hull vertex D (angular momentum about D kept):

    ``planar``: rotation about e through D (the section's two-pivot value); ``point``: free
    rotation about D; ``edge``: rotation about the line AD (both A and D stay on the pedestal).
    Also ``theta_deg``: the landing tilt, and ``edge_azimuth_deg``: AD's direction from +x.
    """
    from pbr_xval.geometry.stability import hull_vertices
    from pbr_xval.quaternions import rotation_about

    chain = section.chain(side)
    if not chain:
        return {}
    phi = chain[0][0]
    hv = hull_vertices(scene.rock.mesh.vertices) - scene.rock.com
    e, m = scene.rocking_axis, scene.rock.mass
    rot = rotation_about(e, side * phi)
    p = hv @ rot.T
    tol = 1e-9 * float(np.ptp(hv))
    base = hv[:, 2] <= hv[:, 2].min() + tol
    xd = hv @ scene.direction
    a_pt = p[np.nonzero(base)[0][np.argmax(side * xd[base])]]
    low = np.nonzero(p[:, 2] <= p[:, 2].min() + 1e-6 * float(np.ptp(hv)))[0]
    d_pt = p[low[np.argmax(np.linalg.norm(p[low] - a_pt, axis=1))]]
    i_g = rot @ scene.rock.inertia @ rot.T

    def i_about(r: np.ndarray) -> np.ndarray:
        return np.asarray(i_g + m * ((r @ r) * np.eye(3) - np.outer(r, r)))

    r_a, r_d = -a_pt, -d_pt
    w = e * float(side)
    l_d = i_g @ w + m * np.cross(r_d, np.cross(w, r_a))
    ke0 = 0.5 * w @ i_about(r_a) @ w
    i_d = i_about(r_d)
    w_pt = np.linalg.solve(i_d, l_d)
    u = (d_pt - a_pt) / np.linalg.norm(d_pt - a_pt)
    w_edge = u * (u @ l_d) / (u @ i_d @ u)
    w_pl = e * (e @ l_d) / (e @ i_d @ e)
    return {
        "theta_deg": math.degrees(phi),
        "edge_azimuth_deg": math.degrees(math.atan2(u[1], u[0])),
        "planar": float(0.5 * w_pl @ i_d @ w_pl / ke0),
        "point": float(0.5 * w_pt @ i_d @ w_pt / ke0),
        "edge": float(0.5 * w_edge @ i_d @ w_edge / ke0),
    }


def barrier(scene: Any, azimuth_deg: float) -> tuple[float, float]:
    """(critical tilt rad, energy barrier J) of the rock tipped toward the horizontal direction at
    ``azimuth_deg`` (° from +x): the COM's rise from rest to where it passes over its contact."""
    from pbr_xval.geometry.stability import critical_tilt, hull_vertices
    from pbr_xval.quaternions import rotation_about

    hv = hull_vertices(scene.rock.mesh.vertices)
    c = scene.rock.com
    az = math.radians(azimuth_deg)
    d = np.array([math.cos(az), math.sin(az), 0.0])
    a = critical_tilt(hv, c, d)
    if not math.isfinite(a):
        return math.nan, math.nan
    p = (hv - c) @ rotation_about(np.cross([0.0, 0.0, 1.0], d), a).T
    rise = -float(p[:, 2].min()) - float(c[2] - hv[:, 2].min())
    return a, scene.rock.mass * scene.gravity * rise


def weakest_barrier(scene: Any, step_deg: float = 1.0) -> tuple[float, float, float]:
    """(azimuth °, critical tilt rad, barrier J) of the smallest barrier on a ``step_deg`` grid."""
    best = (math.nan, math.nan, math.inf)
    for az in np.arange(0.0, 360.0, step_deg):
        a, e = barrier(scene, float(az))
        if e < best[2]:
            best = (float(az), a, e)
    return best


# ------------------------------------------------------------------ measurement
@dataclass
class ImpactMeasurement:
    """One face impact (θ crossing 0) measured on a trajectory: time s, the side it came from
    (±1), mechanical energy J before and after it on the face pivots, ω⁺/ω⁻ from those energies
    and each side's I_O, and the two-pivot value (-)."""

    t: float
    side_from: int
    energy_before: float
    energy_after: float
    rebound: float
    geometry: float


@dataclass
class RockingMeasurement:
    """What one free-rocking run did (energies J, angles rad, lengths m)."""

    energy_start: float
    peaks: list[dict[str, Any]]
    impacts: list[ImpactMeasurement]
    peak_roll: float
    peak_yaw: float
    peak_offplane_com: float
    toppled: bool
    first_landing_kept: float = math.nan  # KE after / before the first edge landing


def mechanical_energy(traj: Any, scene: Any) -> np.ndarray:
    """(n,) J: kinetic + potential energy above rest, pedestal at rest (v by central differences)."""
    r = traj.rotation_matrices()
    i_w = np.einsum("nij,jk,nlk->nil", r, scene.rock.inertia, r)
    v = np.gradient(traj.com, traj.t, axis=0)
    m = scene.rock.mass
    ke = 0.5 * np.einsum("ni,nij,nj->n", traj.omega, i_w, traj.omega) + 0.5 * m * np.sum(v * v, axis=1)
    return np.asarray(ke + m * scene.gravity * (traj.com[:, 2] - scene.rock.com[2]))


def half_cycles(theta: np.ndarray, min_peak: float = MIN_HALF_CYCLE_RAD) -> list[tuple[int, int, int]]:
    """(start, stop, sign) index ranges of θ's same-sign runs whose peak |θ| ≥ ``min_peak`` rad;
    runs below are chatter and merged into the crossing between their neighbours."""
    sgn = np.sign(theta)
    cuts = np.nonzero(np.diff(sgn) != 0)[0] + 1
    edges = np.concatenate([[0], cuts, [theta.size]])
    runs: list[tuple[int, int, int]] = []
    for a, b in itertools.pairwise(edges):
        s = int(np.sign(theta[a:b].sum()))
        if s != 0 and np.max(np.abs(theta[a:b])) >= min_peak:
            if runs and runs[-1][2] == s:
                runs[-1] = (runs[-1][0], int(b), s)
            else:
                runs.append((int(a), int(b), s))
    return runs


def measure_rocking(traj: Any, scene: Any, section: Section) -> RockingMeasurement:
    """Face-impact rebounds and turning-point energies of a free-rocking run (see the module notes)."""
    from scipy.spatial.transform import Rotation

    t = traj.t
    theta = traj.rocking_angle()
    energy = mechanical_energy(traj, scene)
    runs = half_cycles(theta)
    peaks = []
    for a, b, s in runs:
        k = a + int(np.argmax(np.abs(theta[a:b])))
        lo, hi = max(a, k - 3), min(b, k + 4)
        peaks.append(
            {"t": float(t[k]), "side": s, "theta": float(theta[k]), "energy": float(np.median(energy[lo:hi]))}
        )
    impacts = []
    for (a0, b0, s0), (a1, b1, s1) in itertools.pairwise(runs):
        tc = 0.5 * (t[b0 - 1] + t[a1])
        win0, win1 = section.chain(s0), section.chain(s1)
        lim0 = win0[0][0] if win0 else math.pi / 2
        lim1 = win1[0][0] if win1 else math.pi / 2
        i0 = np.arange(a0, b0)
        i0 = i0[(np.abs(theta[i0]) < lim0) & (t[i0] <= tc - IMPACT_GUARD_S)]
        i1 = np.arange(a1, b1)
        i1 = i1[(np.abs(theta[i1]) < lim1) & (t[i1] >= tc + IMPACT_GUARD_S)]
        e0 = float(np.median(energy[i0])) if i0.size >= 3 else math.nan
        e1 = float(np.median(energy[i1])) if i1.size >= 3 else math.nan
        io0, io1 = section.pivot_inertia(section.face(s0)), section.pivot_inertia(section.face(s1))
        reb = math.sqrt(e1 / e0 * io0 / io1) if e0 > 0 and e1 >= 0 else math.nan
        impacts.append(ImpactMeasurement(float(tc), s0, e0, e1, reb, section.face_rebound(s0)))
    kept = math.nan
    if runs and section.chain(runs[0][2]):
        s0 = runs[0][2]
        phi = section.chain(s0)[0][0]
        hit = np.nonzero(s0 * theta >= phi)[0]
        if hit.size:
            tl = t[hit[0]]
            after = (t >= tl + IMPACT_GUARD_S) & (t <= tl + IMPACT_GUARD_S + 0.03)
            pe = section.potential(s0 * phi)
            e0 = float(np.median(energy[: min(5, energy.size)]))
            if np.count_nonzero(after) >= 3 and e0 > pe:
                kept = (float(np.median(energy[after])) - pe) / (e0 - pe)
    rv = Rotation.from_matrix(traj.rotation_matrices()).as_rotvec()
    d = scene.direction
    e = scene.rocking_axis
    return RockingMeasurement(
        energy_start=float(np.median(energy[: min(5, energy.size)])),
        peaks=peaks,
        impacts=impacts,
        peak_roll=float(np.max(np.abs(rv @ d))),
        peak_yaw=float(np.max(np.abs(rv[:, 2]))),
        peak_offplane_com=float(np.max(np.abs((traj.com - traj.com[0]) @ e))),
        toppled=bool(traj.toppled),
        first_landing_kept=kept,
    )


# --------------------------------------------------------------------- the tool
def prism_scenario(folder: Path) -> Any:
    """The control rock: :data:`PRISM_SECTION` extruded along y (a mesh written to ``folder``),
    granite density 2400 kg/m³, the scanned rocks' friction 0.6, shaken along x."""
    import trimesh

    from pbr_xval.scenario import scenario_from_dict

    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "prism.obj"
    v = [(x, y, z) for x, z in PRISM_SECTION for y in (-0.2, 0.2)]
    trimesh.Trimesh(vertices=v).convex_hull.export(path)
    return scenario_from_dict(
        {
            "name": "prism",
            "duration": 3.0,
            "rock": {"shape": "mesh", "path": str(path), "density": 2400.0},
            "contact": {"friction_static": 0.6},
            "excitation": {"type": "none", "azimuth_deg": 0.0},
        }
    )


def free_rocking_scene(scn: Any, fraction: float, side: int, duration: float) -> tuple[Any, Section, float]:
    """(compiled scene, section, start rate rad/s) of a scenario released from θ = 0 on ``side``."""
    from pbr_xval.scene import compile_scene

    sec = Section.from_scene(compile_scene(scn))
    rate = sec.start_rate(fraction, side)
    data = scn.model_dump(mode="json", exclude_unset=True)
    data.pop("uncertainty", None)
    exc = {"type": "none", "azimuth_deg": float(scn.excitation.azimuth_deg)}
    data.update(excitation=exc, initial={"omega": rate}, duration=duration, output_dt=1e-3)
    data["name"] = f"{scn.name}_free_rocking"
    return compile_scene(scn.from_tables(data)), sec, rate


def _gmean(xs: list[float]) -> float:
    ok = [x for x in xs if math.isfinite(x) and x > 0]
    return math.exp(sum(math.log(x) for x in ok) / len(ok)) if ok else math.nan


def _fmt(xs: list[float]) -> str:
    return ", ".join("nan" if not math.isfinite(x) else f"{x:.3f}" for x in xs) or "-"


def _git() -> dict[str, Any]:
    """HEAD and the tracked files modified in the working tree (they were run, not HEAD's)."""
    try:
        head = subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True, check=True)
        st = subprocess.run(
            ["git", "status", "--porcelain", "-uno"], capture_output=True, text=True, check=True
        )
    except (OSError, subprocess.CalledProcessError):
        return {}
    return {"commit": head.stdout.strip(), "modified": [ln[3:] for ln in st.stdout.splitlines()]}


def run_one(
    engine: str, specimen: str, scn: Any, dt: float, fraction: float, side_name: str, duration: float
) -> dict[str, Any]:
    """One free-rocking run of scenario ``scn`` (labelled ``specimen``) and its comparison with
    the section; a JSON-able record."""
    from pbr_xval.runner import run_scene

    _, sec, _ = free_rocking_scene(scn, fraction, 1, duration)
    weak = 1 if sec.alpha(1) <= sec.alpha(-1) else -1
    side = weak if side_name == "weak" else -weak
    scene, sec, rate = free_rocking_scene(scn, fraction, side, duration)
    t0 = time.perf_counter()
    traj = run_scene(scene, engine, {"timestep": dt})
    wall = time.perf_counter() - t0
    rec: dict[str, Any] = {
        "engine": engine, "specimen": specimen, "dt": dt, "side": side_name, "side_sign": side,
        "fraction": fraction, "start_rate_rad_s": rate, "wall_s": wall, "status": str(traj.status),
        "message": traj.message, "settings": traj.settings, "versions": traj.versions,
        "section": {
            "mass_kg": sec.mass, "inertia_kg_m2": sec.inertia, "alpha_deg": {"+": math.degrees(sec.alpha(1)),
            "-": math.degrees(sec.alpha(-1))},
            "face_pivots_m": {"+": sec.polygon[sec.face(1)].tolist(), "-": sec.polygon[sec.face(-1)].tolist()},
            "face_rebound": {"from+": sec.face_rebound(1), "from-": sec.face_rebound(-1)},
            "face_energy_ratio": sec.face_energy_ratio(),
            "landings_deg": {"+": [math.degrees(p) for p, _, _ in sec.chain(1)][:6],
                             "-": [math.degrees(p) for p, _, _ in sec.chain(-1)][:6]},
        },
    }  # fmt: skip
    if not traj.ok or traj.t.size < 10:
        return rec
    meas = measure_rocking(traj, scene, sec)
    e_start = meas.energy_start
    first_geo, first_top, _ = sec.roll_out(e_start, side)
    half = []
    for p0, p1 in zip(meas.peaks[:-1], meas.peaks[1:], strict=True):
        geo, top = sec.next_peak(p0["energy"], p0["side"])
        half.append({"from_t": p0["t"], "measured": p1["energy"] / p0["energy"], "geometry": geo / p0["energy"],
                     "geometry_toppled": top})  # fmt: skip
    diag = traj.diagnostics
    landing = first_landing_3d(scene, sec, side)
    if specimen not in _BARRIERS:  # the rock's, not the run's: once per rock
        az = math.degrees(scene.azimuth)
        waz, wa, we = weakest_barrier(scene)
        _BARRIERS[specimen] = {
            "+d_J": barrier(scene, az)[1], "-d_J": barrier(scene, az + 180.0)[1],
            "weakest_azimuth_deg": waz, "weakest_alpha_deg": math.degrees(wa), "weakest_J": we, "grid_deg": 1.0,
        }  # fmt: skip
    rec["barriers"] = _BARRIERS[specimen]
    rec.update(
        first_landing={"measured": meas.first_landing_kept, **landing},
        energy_start_J=e_start,
        first_peak={"measured_J": meas.peaks[0]["energy"] if meas.peaks else math.nan, "geometry_J": first_geo,
                    "geometry_toppled": first_top},
        peaks=meas.peaks,
        impacts=[vars(i) for i in meas.impacts],
        half_cycles=half,
        toppled=meas.toppled,
        peak_roll_rad=meas.peak_roll, peak_yaw_rad=meas.peak_yaw, peak_offplane_com_m=meas.peak_offplane_com,
        slip_max_m=diag.get("slip_max_m"), flights=diag.get("flights"), uplift_max_m=diag.get("uplift_max_m"),
        max_penetration_m=diag.get("max_penetration_m"), regime=diag.get("regime"),
    )  # fmt: skip
    return rec


def report_lines(rec: dict[str, Any]) -> list[str]:
    """The printed summary of one run record."""
    tag = f"{rec['engine']} {rec['specimen']} dt {rec['dt']:g} {rec['side']}"
    if "impacts" not in rec:
        return [f"rebound {tag}: run failed ({rec['status']}: {rec['message']})"]
    imp = rec["impacts"][:2]
    m = [i["rebound"] for i in imp]
    g = [i["geometry"] for i in imp]
    q = [a / b for a, b in zip(m, g, strict=True)]
    hc = rec["half_cycles"][:4]
    hm, hg = _gmean([h["measured"] for h in hc]), _gmean([h["geometry"] for h in hc])
    lines = [
        f"rebound {tag} measured {_fmt(m)} geometry {_fmt(g)} ratio {_fmt(q)}",
        f"energy {tag} start {rec['energy_start_J']:.3f} J first peak {rec['first_peak']['measured_J']:.3f} J "
        f"(polygon rocker {rec['first_peak']['geometry_J']:.3f}{' toppled' if rec['first_peak']['geometry_toppled'] else ''}); "
        f"kept per half-cycle measured {_fmt([h['measured'] for h in hc])} geometry {_fmt([h['geometry'] for h in hc])}",
        "landing {} at {:.2f} deg KE kept measured {:.3f} geometry planar {:.3f} point {:.3f} edge {:.3f}".format(
            tag, rec["first_landing"].get("theta_deg", math.nan), rec["first_landing"]["measured"],
            *(rec["first_landing"].get(k, math.nan) for k in ("planar", "point", "edge"))),
        f"cycle {tag} energy kept per half-cycle (geometric mean of {len(hc)}) measured {hm:.3f} geometry {hg:.3f}; "
        f"lost per cycle measured {1 - hm * hm:.3f} geometry {1 - hg * hg:.3f}",
        "barrier {} along the shaking +{:.1f} J -{:.1f} J; weakest {:.2f} J at {:.0f} deg (alpha {:.2f} deg; 1 deg grid)".format(
            tag, rec["barriers"]["+d_J"], rec["barriers"]["-d_J"], rec["barriers"]["weakest_J"],
            rec["barriers"]["weakest_azimuth_deg"], rec["barriers"]["weakest_alpha_deg"]),
        f"motion {tag} toppled {rec['toppled']} peak roll {math.degrees(rec['peak_roll_rad']):.2f} deg "
        f"yaw {math.degrees(rec['peak_yaw_rad']):.2f} deg COM off-plane {1e3 * rec['peak_offplane_com_m']:.1f} mm "
        f"slip {1e3 * (rec['slip_max_m'] or 0):.1f} mm flights {rec['flights']} regime {rec['regime']}",
    ]  # fmt: skip
    return lines


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(
        prog="python -m pbr_xval.validation.rebound", description=__doc__.split("\n")[0]
    )
    p.add_argument("--engines", default="mujoco,pybullet,dart,reference")
    p.add_argument("--specimens", default="SP1,SP2", help="SP1, SP2 (committed scenarios), prism (control)")
    p.add_argument("--dt", default="1e-3,1e-4", help="time steps, s")
    p.add_argument("--sides", default="weak", help="weak,strong")
    p.add_argument(
        "--fraction", type=float, default=0.5, help="release energy: a lossless rocker reaches this × α"
    )
    p.add_argument("--duration", type=float, default=3.0, help="s")
    p.add_argument("--out", type=Path, default=None, help="JSON of the runs")
    a = p.parse_args(argv)
    import tempfile

    from pbr_xval.atomic import write_text_atomic
    from pbr_xval.jsonio import dumps
    from pbr_xval.machine import machine_info
    from pbr_xval.scenario import load_scenario

    records = []
    tmp = Path(tempfile.mkdtemp(prefix="pbr_xval_rebound_"))
    for spec in a.specimens.split(","):
        if spec != "prism" and spec not in SPECIMENS:
            p.error(f"--specimens: unknown {spec!r}; expected prism or one of {sorted(SPECIMENS)}")
        scn = prism_scenario(tmp) if spec == "prism" else load_scenario(SPECIMENS[spec])
        for side in a.sides.split(","):
            for dt in [float(x) for x in a.dt.split(",")]:
                for eng in a.engines.split(","):
                    rec = run_one(eng, spec, scn, dt, a.fraction, side, a.duration)
                    records.append(rec)
                    for line in report_lines(rec):
                        print(line, flush=True)
    if a.out is not None:
        doc = {"tool": "pbr_xval.validation.rebound", "git": _git(), "machine": machine_info(),
               "when_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()), "args": vars(a) | {"out": str(a.out)},
               "runs": records}  # fmt: skip
        a.out.parent.mkdir(parents=True, exist_ok=True)
        write_text_atomic(a.out, dumps(doc, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
