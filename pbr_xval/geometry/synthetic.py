"""Deterministic synthetic precariously balanced rocks and simulated TLS scans of them.

:func:`synthetic_rock` builds a rough ellipsoidal body (subdivided icosphere, radii a, b, c,
smooth random radial perturbation from low-order polynomial terms of the unit direction — the
span of spherical harmonics of degree ≤ 3), flattens its bottom onto a slightly uneven plane so
it rests on a small basal patch, and returns a closed mesh in the scene frame (base at z = 0,
COM on the z axis). The slenderness is set by the radii, or by ``target_alpha_deg`` (the
smallest critical tilt angle), which is met by adjusting the cut height.

:func:`simulate_scan` samples the surface like a terrestrial laser scanner: density varying
with the direction to the scanner, Gaussian noise, and an occluded base (no points below a
height). :func:`write_point_cloud` writes PLY or XYZ. Same seed → identical bytes.
"""

from __future__ import annotations

from itertools import product
from pathlib import Path
from typing import Any

import numpy as np
import trimesh

from pbr_xval.atomic import write_bytes_atomic
from pbr_xval.geometry.stability import hull_vertices, support_lever

__all__ = ["SYNTHETIC_ROCK_KEYS", "simulate_scan", "synthetic_rock", "write_point_cloud"]

#: the shape parameters of :func:`synthetic_rock` (study files and catalogs pass them through)
SYNTHETIC_ROCK_KEYS = (
    "seed",
    "radii",
    "roughness",
    "base_fraction",
    "unevenness",
    "subdivisions",
    "target_alpha_deg",
)

_MONOMIALS = [(i, j, k) for i, j, k in product(range(4), repeat=3) if 1 <= i + j + k <= 3]


def _body(
    radii: tuple[float, float, float], roughness: float, seed: int, subdivisions: int
) -> trimesh.Trimesh:
    rng = np.random.default_rng(seed)
    sphere = trimesh.creation.icosphere(subdivisions=subdivisions)
    u = np.asarray(sphere.vertices, float)
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    coef = rng.normal(size=len(_MONOMIALS))
    deg = np.array([i + j + k for i, j, k in _MONOMIALS])
    coef /= deg  # damp the higher orders: a smooth, low-order perturbation
    pert = sum(
        c * u[:, 0] ** i * u[:, 1] ** j * u[:, 2] ** k for c, (i, j, k) in zip(coef, _MONOMIALS, strict=True)
    )
    pert = pert - pert.mean()
    pert /= max(np.abs(pert).max(), 1e-12)
    taper = (0.5 * (1.0 + u[:, 2])) ** 2  # no perturbation at the bottom pole: the base stays under the body
    r = 1.0 + roughness * pert * taper
    v = u * r[:, None] * np.asarray(radii, float)
    return trimesh.Trimesh(vertices=v, faces=sphere.faces, process=False)


def _flatten(body: trimesh.Trimesh, base_fraction: float, unevenness: float, seed: int) -> trimesh.Trimesh:
    rng = np.random.default_rng(seed + 7919)
    v = body.vertices.copy()
    zmin, zmax = v[:, 2].min(), v[:, 2].max()
    zc = zmin + base_fraction * (zmax - zmin)
    low = v[:, 2] < zc
    if low.any():
        size = float(np.ptp(v[:, :2], axis=0).max())
        k = rng.uniform(2.0, 4.0, size=2) * np.pi / size
        ph = rng.uniform(0, 2 * np.pi, size=2)
        x, y = v[low, 0], v[low, 1]
        bump = 0.25 * (2 + np.sin(k[0] * x + ph[0]) + np.sin(k[1] * y + ph[1]))  # in [0, 1]
        v[low, 2] = zc + unevenness * bump
    m = trimesh.Trimesh(vertices=v, faces=body.faces, process=False)
    from pbr_xval.geometry.interface import settle_pose

    m.apply_transform(settle_pose(m.vertices, m.center_mass)[0])  # rest on the base's hull face
    com = m.center_mass
    m.apply_translation([-com[0], -com[1], -m.vertices[:, 2].min()])
    return m


def _min_alpha(mesh: trimesh.Trimesh, n: int = 36) -> float:
    """Smallest uplift angle atan(b(φ)/h_G) over n directions (deg): α_min of a flat-based rock."""
    com = mesh.center_mass
    hv = hull_vertices(mesh.vertices)
    ang = []
    for phi in np.linspace(0, 2 * np.pi, n, endpoint=False):
        b, h = support_lever(hv, com, np.array([np.cos(phi), np.sin(phi), 0.0]))
        ang.append(np.arctan2(b, h))
    return float(np.degrees(min(ang)))


def synthetic_rock(
    seed: int = 0,
    radii: tuple[float, float, float] = (0.35, 0.25, 0.55),
    roughness: float = 0.12,
    base_fraction: float = 0.04,
    unevenness: float = 0.004,
    subdivisions: int = 4,
    target_alpha_deg: float | None = None,
) -> tuple[trimesh.Trimesh, dict[str, Any]]:
    """A closed PBR-like rock in the scene frame (base at z = 0, COM on the z axis).

    Parameters
    ----------
    seed : random seed (same seed → identical mesh).
    radii : semi-axes (a, b, c) in m of the ellipsoidal body; c/a sets the slenderness.
    roughness : relative amplitude of the smooth radial perturbation.
    base_fraction : the bottom is flattened below this fraction of the height.
    unevenness : height (m) of the smooth bumps on the flattened base.
    subdivisions : icosphere subdivisions (4 → 2,562 vertices).
    target_alpha_deg : if given, ``base_fraction`` is found by bisection so that the smallest
        uplift angle atan(b/h_G) (= critical tilt of a flat base) is this value (within 0.1°).

    Returns
    -------
    (mesh, info) — info holds the parameters, the resulting base fraction and min α (deg).
    """
    body = _body(radii, roughness, seed, subdivisions)
    if target_alpha_deg is not None:
        lo, hi = 0.0, 0.45
        for _ in range(30):
            mid = 0.5 * (lo + hi)
            a = _min_alpha(_flatten(body, mid, unevenness, seed))
            if abs(a - target_alpha_deg) < 0.1:
                break
            if a < target_alpha_deg:
                lo = mid
            else:
                hi = mid
        base_fraction = mid
    mesh = _flatten(body, base_fraction, unevenness, seed)
    if not (mesh.is_watertight and mesh.volume > 0):  # pragma: no cover - construction guarantees it
        raise RuntimeError("synthetic rock is not a closed solid")
    info = {
        "seed": seed,
        "radii_m": list(radii),
        "roughness": roughness,
        "base_fraction": base_fraction,
        "unevenness_m": unevenness,
        "min_uplift_angle_deg": _min_alpha(mesh),
        "volume_m3": float(mesh.volume),
    }
    return mesh, info


def simulate_scan(
    mesh: trimesh.Trimesh,
    n_points: int = 8000,
    seed: int = 0,
    noise: float = 0.001,
    occlusion_height: float = 0.01,
    scanner_direction: tuple[float, float, float] = (1.0, 0.3, 0.5),
    min_density: float = 0.3,
) -> np.ndarray:
    """Points (n, 3) sampled from ``mesh`` like a TLS scan (deterministic for a seed).

    The sampling density falls from 1 on faces facing the scanner to ``min_density`` on faces
    turned away; Gaussian noise of σ = ``noise`` m is added; points below
    ``occlusion_height`` (m, scene frame) are dropped (the base cannot be seen).
    """
    rng = np.random.default_rng([seed, 2])  # independent of the surface sampler's stream
    s = np.asarray(scanner_direction, float)
    s /= np.linalg.norm(s)
    pts, fid = trimesh.sample.sample_surface(
        mesh, int(3 * n_points / min_density) + 100, seed=np.random.default_rng([seed, 1])
    )
    w = min_density + (1 - min_density) * np.clip(mesh.face_normals[fid] @ s, 0, 1)
    keep = rng.uniform(size=len(pts)) < w
    pts = pts[keep]
    pts = pts[rng.permutation(len(pts))[:n_points]]
    pts = pts + rng.normal(scale=noise, size=pts.shape)
    return pts[pts[:, 2] >= occlusion_height]


def write_point_cloud(points: np.ndarray, path: str | Path) -> Path:
    """Write points (n, 3) as binary PLY (``.ply``) or text XYZ (``.xyz``/``.txt``/``.csv``), atomically."""
    path = Path(path)
    p = np.asarray(points, dtype="<f8")
    ext = path.suffix.lower()
    if ext == ".ply":
        header = (
            "ply\nformat binary_little_endian 1.0\ncomment pbr-xval simulated scan\n"
            f"element vertex {len(p)}\nproperty double x\nproperty double y\nproperty double z\nend_header\n"
        ).encode("ascii")
        data = header + p.tobytes()
    elif ext in {".xyz", ".txt", ".csv"}:
        sep = "," if ext == ".csv" else " "
        lines = ["# x y z (m), pbr-xval simulated scan"] + [sep.join(f"{c:.9f}" for c in row) for row in p]
        data = ("\n".join(lines) + "\n").encode("ascii")
    else:
        raise ValueError(f"{path}: unsupported point-cloud format {ext!r}; expected .ply, .xyz, .txt or .csv")
    return write_bytes_atomic(path, data)
