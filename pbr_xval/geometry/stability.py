"""Static stability of a rigid rock on a flat pedestal: uplift and critical tilt angles.

Two quantities field workers estimate with tilt tests:

* the **critical tilt angle** α(φ): tilt the rock toward the horizontal direction φ, letting
  it pivot or roll on its convex hull without slip; α(φ) is the tilt at which the centre of
  mass passes over the contact point (the restoring moment vanishes). For a block it is
  atan(b/h) toward each face; for a curved base it exceeds the uplift angle;
* the **uplift acceleration** g·b(φ)/h_G: the quasi-static horizontal acceleration at which the
  rock starts to rock about the edge of its support polygon, b(φ) being the distance from the
  COM's vertical to that edge along φ and h_G the COM height.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import brentq
from scipy.spatial import ConvexHull

__all__ = ["StabilityTable", "critical_tilt", "hull_vertices", "support_points", "uplift_lever"]


def _rot_about(axis: np.ndarray, angle: float) -> np.ndarray:
    axis = axis / np.linalg.norm(axis)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * (k @ k)


def hull_vertices(vertices: np.ndarray) -> np.ndarray:
    """Convex-hull vertices (k, 3) of a point set (n, 3)."""
    v = np.asarray(vertices, dtype=float)
    if len(v) > 16:
        v = v[ConvexHull(v).vertices]
    return v


def support_points(vertices: np.ndarray, tol: float | None = None) -> np.ndarray:
    """Points (k, 3) of the convex hull within ``tol`` (m) of the lowest z: the support set."""
    v = np.asarray(vertices, dtype=float)
    zmin = v[:, 2].min()
    if tol is None:
        tol = 1e-9 * max(1.0, float(np.ptp(v)))
    return v[v[:, 2] <= zmin + tol]


def uplift_lever(vertices: np.ndarray, com: np.ndarray, direction: np.ndarray) -> tuple[float, float]:
    """(b, h): lever of the support edge toward ``direction`` and COM height, m.

    The rock tips toward ``direction`` when the pedestal accelerates the other way with
    |a| > g·b/h.
    """
    d = np.asarray(direction, dtype=float)
    d = d / np.linalg.norm(d)
    sp = support_points(hull_vertices(vertices))
    b = float(np.max((sp - com) @ d))
    h = float(com[2] - sp[:, 2].min())
    return b, h


def critical_tilt(vertices: np.ndarray, com: np.ndarray, direction: np.ndarray) -> float:
    """Critical tilt angle (rad) toward the horizontal unit ``direction``.

    The rock (convex hull of ``vertices``, (n, 3) m, resting on z = min z) is rotated about the
    horizontal axis ⟂ to ``direction`` so that its top moves toward ``direction``; the contact is
    the lowest hull point (ties broken toward ``direction``). Returns the smallest angle at which
    the COM passes over the contact, found by bracketing and Brent's method (1e-12 rad).
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
        return 0.0
    grid = np.linspace(0.0, np.pi / 2, 721)
    prev = grid[0]
    for th in grid[1:]:
        if margin(th) <= 0:
            return float(brentq(margin, prev, th, xtol=1e-13))
        prev = th
    return float(np.pi / 2)


class StabilityTable:
    """Critical tilt α(φ) and uplift acceleration on a grid of horizontal directions.

    Parameters
    ----------
    vertices : (n, 3) float, m — rock vertices in the scene frame, at rest.
    com : (3,) float, m.
    n_directions : directions φ = 2πk/n (rad from +x toward +y).
    """

    def __init__(self, vertices: np.ndarray, com: np.ndarray, n_directions: int = 72) -> None:
        self.phi = np.linspace(0.0, 2 * np.pi, n_directions, endpoint=False)
        hv = hull_vertices(vertices)
        dirs = np.column_stack([np.cos(self.phi), np.sin(self.phi), np.zeros_like(self.phi)])
        self.alpha = np.array([critical_tilt(hv, com, d) for d in dirs])
        levers = np.array([uplift_lever(hv, com, d) for d in dirs])
        self.lever = levers[:, 0]
        self.com_height = float(levers[0, 1])

    def alpha_at(self, phi: np.ndarray | float) -> np.ndarray:
        """Critical tilt (rad) at directions ``phi`` (rad), periodic linear interpolation."""
        p = np.asarray(phi, dtype=float) % (2 * np.pi)
        xp = np.append(self.phi, 2 * np.pi)
        fp = np.append(self.alpha, self.alpha[0])
        return np.interp(p, xp, fp)

    def toppling_accel(self, g: float = 9.81) -> np.ndarray:
        """Quasi-static toppling acceleration g·tan α(φ) (m/s²) on the grid ``phi``."""
        return g * np.tan(self.alpha)

    def uplift_accel(self, phi: float, g: float) -> float:
        """Quasi-static acceleration (m/s²) that tips the rock toward direction ``phi``."""
        p = float(phi) % (2 * np.pi)
        xp = np.append(self.phi, 2 * np.pi)
        fp = np.append(self.lever, self.lever[0])
        return float(g * np.interp(p, xp, fp) / self.com_height)
