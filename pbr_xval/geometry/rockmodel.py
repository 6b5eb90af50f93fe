"""Scan → rock model: the whole pipeline in one call (used by ``pbr-xval rock``).

load (mesh or point cloud; optional separate pedestal, or a cut plane z = cut_z splitting one
scan) → closed solid (alpha shape for clouds) → resting pose (pedestal plane fit, the scan pose,
the settled pose or the stable pose) → exact and node-based mass properties → basal contact
patch → critical tilt α(φ) and g·tan α(φ).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import trimesh

from pbr_xval.geometry.cloud import alpha_solid
from pbr_xval.geometry.interface import (
    DEFAULT_POSE,
    ContactPatch,
    contact_patch,
    frame_from_plane,
    pedestal_plane,
    rest_pose,
    split_by_plane,
    stability_table,
)
from pbr_xval.geometry.io import load_scan
from pbr_xval.geometry.mass import MassProperties, exact_mass_properties, node_mass_properties
from pbr_xval.geometry.stability import StabilityTable

__all__ = ["MAX_GRID_NODES", "ScannedRock", "build_rock_model"]

#: largest node grid of the node estimate (cells of the rock's bounding box): ~10 s and 0.4 GB on 2 cores
MAX_GRID_NODES = 5_000_000


@dataclass
class ScannedRock:
    """A rock model built from a scan, in the resting frame (pedestal plane z = 0, z up).

    ``transform`` maps local (re-centred scan) coordinates to the resting frame;
    scan coordinates = ``offset`` + local.
    """

    name: str
    mesh: trimesh.Trimesh
    transform: np.ndarray
    offset: np.ndarray
    exact: MassProperties
    nodes: MassProperties
    node_points: np.ndarray
    contact: ContactPatch
    stability: StabilityTable
    gravity: float
    info: dict[str, Any] = field(default_factory=dict)

    def to_scan(self, p: np.ndarray) -> np.ndarray:
        """Resting-frame points (n, 3) → scan coordinates."""
        inv = np.linalg.inv(self.transform)
        return trimesh.transform_points(np.atleast_2d(p), inv) + self.offset

    def to_dict(self) -> dict[str, Any]:
        """The rock model's figures (mass kg, COM m, critical tilts rad, toppling accelerations m/s²) as JSON."""
        acc = self.stability.toppling_accel(self.gravity)
        a = self.stability.alpha
        au = self.stability.uplift_angle
        ok = np.isfinite(a)

        def nanstat(f: Any, x: np.ndarray) -> float | None:
            return float(f(x[np.isfinite(x)])) if np.isfinite(x).any() else None

        return {
            "name": self.name,
            "mass_kg": self.exact.mass,
            "volume_m3": self.exact.volume,
            "density_kg_m3": self.exact.density,
            "com_rest_m": self.exact.com.tolist(),
            "com_scan_m": self.to_scan(self.exact.com)[0].tolist(),
            "com_height_m": float(self.exact.com[2] - self.mesh.vertices[:, 2].min()),
            "inertia_kg_m2": self.exact.inertia.tolist(),
            "principal_moments_kg_m2": self.exact.principal_moments.tolist(),
            "principal_axes": self.exact.principal_axes.tolist(),
            "node_estimate": {
                "spacing_m": self.nodes.spacing,
                "n_nodes": self.nodes.n_nodes,
                "volume_m3": self.nodes.volume,
                "com_m": self.nodes.com.tolist(),
                "principal_moments_kg_m2": self.nodes.principal_moments.tolist(),
                "rel_volume_vs_exact": (self.nodes.volume - self.exact.volume) / self.exact.volume,
            },
            "transform_local_to_rest": self.transform.tolist(),
            "offset_m": self.offset.tolist(),
            "contact": self.contact.to_dict(),
            "critical_tilt": {
                "phi_convention": "φ = 0 along +x, counter-clockwise seen from above (+x toward +y)",
                "at_rest": bool(self.stability.at_rest),
                "rest_margin_m": float(self.stability.margin),
                "phi_deg": np.degrees(self.stability.phi).tolist(),
                "alpha_deg": [float(x) if np.isfinite(x) else None for x in np.degrees(a)],
                "min_deg": nanstat(np.min, np.degrees(a)),
                "min_at_phi_deg": float(np.degrees(self.stability.phi[np.nanargmin(a)]))
                if ok.any()
                else None,
                "max_deg": nanstat(np.max, np.degrees(a)),
                "uplift_angle_deg": [float(x) if np.isfinite(x) else None for x in np.degrees(au)],
                "toppling_accel_m_s2": [float(x) if np.isfinite(x) else None for x in acc],
                "toppling_accel_min_m_s2": nanstat(np.min, acc),
                "toppling_accel_max_m_s2": nanstat(np.max, acc),
                "gravity_m_s2": self.gravity,
            },
            "info": self.info,
        }


def _as_points(geom: Any) -> np.ndarray:
    return np.asarray(geom.vertices if isinstance(geom, trimesh.Trimesh) else geom, float)


def build_rock_model(
    scan: str | Path,
    pedestal: str | Path | None = None,
    *,
    density: float | None = 2700.0,
    mass: float | None = None,
    units: str = "m",
    pose: str = DEFAULT_POSE,
    cut_z: float | None = None,
    alpha_multiple: float | None = None,
    grid_spacing: float | None = None,
    eps: float | None = None,
    n_directions: int = 72,
    gravity: float = 9.81,
) -> ScannedRock:
    """Build the rock model of ``scan`` (see the module docstring).

    Parameters
    ----------
    pedestal : a separate pedestal scan (mesh or cloud) in the same coordinates as ``scan``;
        its top is fitted by a plane near the rock and becomes z = 0.
    pose : without a pedestal, ``"scan"`` (keep the orientation, lowest point on z = 0; refused
        with :class:`~pbr_xval.geometry.interface.NotAtRestError` when the rock is not at rest
        there), ``"settle"`` (settle onto the hull face below the COM; the default) or
        ``"stable"`` (lowest COM over the hull's faces) — :func:`~pbr_xval.geometry.interface.rest_pose`.
    cut_z : split one scan at z = cut_z (scan coordinates, in ``units``): above is the rock,
        below the pedestal.
    alpha_multiple : alpha-shape parameter for point clouds (× median point spacing).
    grid_spacing : node spacing (m) for the node estimate; default 1/40 of the rock size.
    eps : contact tolerance (m); default 0.5 % of the rock size.
    """
    sc = load_scan(scan, units=units)
    info: dict[str, Any] = {"scan": dict(sc.info)}
    if sc.kind == "points":
        sol = alpha_solid(sc.points, alpha_multiple=alpha_multiple, name=str(scan))
        rock_geom: Any = sol.mesh
        info["reconstruction"] = sol.to_dict()
    else:
        rock_geom = sc.mesh
    ped_pts = None
    if cut_z is not None:
        from pbr_xval.units import UNIT_SCALE

        zc = cut_z * UNIT_SCALE[units] - sc.offset[2]
        rock_geom, ped_geom = split_by_plane(rock_geom, np.array([0.0, 0.0, zc]))
        ped_pts = _as_points(ped_geom)
        if isinstance(ped_geom, trimesh.Trimesh):  # a cut mesh: the pedestal's top is the cut itself
            on_cut = np.abs(ped_pts[:, 2] - zc) <= 1e-9 * max(1.0, float(np.abs(ped_pts).max()))
            if on_cut.sum() >= 3:
                ped_pts = ped_pts[on_cut]
        info["cut"] = {"z_scan_m": cut_z * UNIT_SCALE[units]}
    if pedestal is not None:
        ps = load_scan(pedestal, units=units, close=False)
        ped_pts = ps.points + (ps.offset - sc.offset)
        info["pedestal"] = dict(ps.info)
    mesh = rock_geom.copy()
    if ped_pts is not None:
        c, n, pinfo = pedestal_plane(ped_pts, mesh.vertices)
        t = frame_from_plane(c, n)
        info["pedestal_plane"] = {"point_local_m": c.tolist(), "normal": n.tolist(), **pinfo}
        pose = "pedestal plane"
    else:
        com0 = exact_mass_properties(mesh, density=1.0).com
        t, pi = rest_pose(mesh.vertices, com0, pose, hint="use --pose settle")
        info["pose"] = pi
        pose = {
            "scan": "scan: the scan's orientation, lowest point on z = 0",
            "settle": "settle: settled onto the hull face below the COM"
            + (" (already at rest in the scan orientation)" if pi.get("iterations") == 0 else ""),
            "stable": "stable: lowest COM over the hull faces",
        }[pose]
    info["pose_kind"] = pose
    mesh.apply_transform(t)
    ex = exact_mass_properties(mesh, density=density, mass=mass)
    size = float(np.ptp(mesh.vertices, axis=0).max())
    h = grid_spacing if grid_spacing is not None else size / 40
    if not (math.isfinite(h) and h > 0):
        raise ValueError(
            f"grid spacing {h!r} m: expected a node spacing > 0 m (default 1/40 of the rock's size)"
        )
    n_grid = float(np.prod(np.floor(np.ptp(mesh.vertices, axis=0) / h) + 1.0))
    if n_grid > MAX_GRID_NODES:  # estimated before anything is allocated
        h_min = float(np.prod(np.ptp(mesh.vertices, axis=0)) / MAX_GRID_NODES) ** (1 / 3)
        raise ValueError(
            f"grid spacing {h:g} m: {n_grid:.3g} grid nodes for a rock {size:.3g} m across; expected at most "
            f"{MAX_GRID_NODES:.0e} (a spacing of at least {h_min:.2g} m)"
        )
    from pbr_xval.geometry.mass import grid_nodes_in_mesh

    nodes = grid_nodes_in_mesh(mesh, h)
    nd = node_mass_properties(nodes, h, density=ex.density)
    if ped_pts is not None:
        cand = np.vstack([mesh.vertices, nodes])
        patch = contact_patch(cand, np.zeros(3), (0.0, 0.0, 1.0), eps=eps)
    else:
        cand = np.vstack([mesh.vertices, nodes])
        patch = contact_patch(cand, np.array([0.0, 0.0, mesh.vertices[:, 2].min()]), (0.0, 0.0, 1.0), eps=eps)
    table = stability_table(mesh.vertices, ex.com, n_directions=n_directions)
    return ScannedRock(
        name=Path(scan).stem,
        mesh=mesh,
        transform=t,
        offset=sc.offset,
        exact=ex,
        nodes=nd,
        node_points=nodes,
        contact=patch,
        stability=table,
        gravity=gravity,
        info=info,
    )
