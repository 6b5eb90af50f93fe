"""Parametric rocks as closed meshes with their mass properties.

Every builder returns a :class:`trimesh.Trimesh` in the *scene frame*: z up, the base resting
on the pedestal surface z = 0, the centre of mass on the vertical through the origin.
Mass properties are exact integrals over the closed mesh (trimesh), so for a box or a notched
block they equal the closed forms to round-off.
"""

from __future__ import annotations

import numpy as np
import trimesh

__all__ = [
    "box_mesh",
    "curved_base_mesh",
    "curved_base_outline",
    "extrude_profile",
    "notched_block_boxes",
    "notched_block_mesh",
]


def box_mesh(half_extents: np.ndarray) -> trimesh.Trimesh:
    """Box with half sizes (3,) m, base on z = 0, centred on the z axis."""
    hx, hy, hz = (float(v) for v in half_extents)
    m = trimesh.creation.box(extents=(2 * hx, 2 * hy, 2 * hz))
    m.apply_translation((0.0, 0.0, hz))
    return m


def notched_block_boxes(
    half_extents: np.ndarray, notch_width: float, notch_height: float
) -> list[tuple[np.ndarray, np.ndarray]]:
    """The notched block as three disjoint boxes: two feet and the slab above the notch.

    Returns
    -------
    list of (centre (3,), half_extents (3,)) in the scene frame (base on z = 0), m.
    """
    bx, by, bz = (float(v) for v in half_extents)
    foot_w = bx - notch_width / 2
    feet_x = notch_width / 2 + foot_w / 2
    parts = [
        (np.array([-feet_x, 0.0, notch_height / 2]), np.array([foot_w / 2, by, notch_height / 2])),
        (np.array([feet_x, 0.0, notch_height / 2]), np.array([foot_w / 2, by, notch_height / 2])),
        (
            np.array([0.0, 0.0, notch_height + (2 * bz - notch_height) / 2]),
            np.array([bx, by, (2 * bz - notch_height) / 2]),
        ),
    ]
    return parts


def extrude_profile(profile_xz: np.ndarray, depth: float) -> trimesh.Trimesh:
    """Extrude a simple closed polygon in the x–z plane along y, centred on y = 0.

    Parameters
    ----------
    profile_xz : (k, 2) float, m — counter-clockwise or clockwise, not repeated at the end.
    depth : float, m.
    """
    poly = np.asarray(profile_xz, dtype=float)
    from shapely.geometry import Polygon  # trimesh dependency for triangulation

    shp = Polygon(poly)
    if not shp.is_valid or shp.area <= 0:
        raise ValueError("profile polygon is not a valid simple polygon")
    m = trimesh.creation.extrude_polygon(shp, height=depth)
    # extrude_polygon builds in x–y and extrudes along +z; map (x, y, z) -> (x, z - depth/2, y)
    v = m.vertices.copy()
    m = trimesh.Trimesh(
        vertices=np.column_stack([v[:, 0], v[:, 2] - depth / 2, v[:, 1]]), faces=m.faces, process=True
    )
    if m.volume < 0:
        m.invert()
    return m


def notched_block_mesh(half_extents: np.ndarray, notch_width: float, notch_height: float) -> trimesh.Trimesh:
    """Box with a notch through its whole depth at the base centre (a Π profile), base on z = 0."""
    bx, by, bz = (float(v) for v in half_extents)
    w2 = notch_width / 2
    profile = np.array(
        [
            [-bx, 0.0],
            [-w2, 0.0],
            [-w2, notch_height],
            [w2, notch_height],
            [w2, 0.0],
            [bx, 0.0],
            [bx, 2 * bz],
            [-bx, 2 * bz],
        ]
    )
    return extrude_profile(profile, 2 * by)


def curved_base_outline(H: float, r: float, h: float, arc_segments: int = 32) -> np.ndarray:
    """Profile (k, 2) in x–z of the seed's curved-base block (science.md §8).

    A rectangle of height H and width W = h + 2r whose bottom corners are quarter circles of
    radius r; the flat part of the base has length h and is centred on x = 0 at z = 0.
    """
    pts: list[tuple[float, float]] = []
    # right arc: centre (h/2, r), from the bottom (angle -90°) to the right side (0°)
    if r > 0:
        for a in np.linspace(-np.pi / 2, 0.0, arc_segments + 1):
            pts.append((h / 2 + r * np.cos(a), r + r * np.sin(a)))
    else:
        pts.append((h / 2, 0.0))
    pts.append((h / 2 + r, H))
    pts.append((-h / 2 - r, H))
    if r > 0:
        for a in np.linspace(np.pi, 1.5 * np.pi, arc_segments + 1):
            pts.append((-h / 2 + r * np.cos(a), r + r * np.sin(a)))
    else:
        pts.append((-h / 2, 0.0))
    out = np.array(pts)
    # drop consecutive duplicates (h = 0 makes the two arc ends coincide)
    keep = np.ones(len(out), bool)
    keep[1:] = np.any(np.abs(np.diff(out, axis=0)) > 1e-12, axis=1)
    if np.allclose(out[0], out[-1]):
        keep[-1] = False
    return out[keep]


def curved_base_mesh(H: float, r: float, h: float, depth: float, arc_segments: int = 32) -> trimesh.Trimesh:
    """The curved-base block extruded along y by ``depth``; arcs faceted with ``arc_segments``."""
    return extrude_profile(curved_base_outline(H, r, h, arc_segments), depth)
