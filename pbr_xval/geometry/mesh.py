"""Reading rock and pedestal meshes: units, re-centring in float64, safe repairs, clear refusals."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import trimesh

from pbr_xval.scenario import UNIT_SCALE, file_sha256

__all__ = ["MeshError", "load_mesh", "load_rock_mesh"]

MESH_FORMATS = {".obj", ".ply", ".stl", ".off"}


class MeshError(ValueError):
    """A mesh cannot be simulated; the message names the file, what was found and what was expected."""


def load_mesh(path: str | Path, *, units: str = "m") -> tuple[trimesh.Trimesh, dict[str, Any]]:
    """Load a triangle mesh, convert to metres and re-centre it in float64.

    Returns the mesh (vertices relative to ``info["offset_m"]``) and an info dict with the
    file's SHA-256, the offset (so poses can be reported in scan coordinates) and the repairs.
    """
    path = Path(path)
    if path.suffix.lower() not in MESH_FORMATS:
        raise MeshError(f"{path}: unsupported mesh format {path.suffix!r}; expected one of {sorted(MESH_FORMATS)}")
    if not path.is_file():
        raise MeshError(f"{path}: file not found")
    try:
        loaded = trimesh.load(path, force="mesh", process=False)
    except Exception as exc:
        raise MeshError(f"{path}: could not be read as a mesh ({exc})") from None
    v = np.asarray(loaded.vertices, dtype=np.float64) * UNIT_SCALE[units]
    f = np.asarray(getattr(loaded, "faces", np.zeros((0, 3), int)))
    if len(f) == 0:
        raise MeshError(f"{path}: has {len(v)} points and no faces; expected a closed triangle mesh")
    if not np.all(np.isfinite(v)):
        raise MeshError(f"{path}: vertex coordinates contain NaN or infinity")
    offset = v.mean(axis=0)
    mesh = trimesh.Trimesh(vertices=v - offset, faces=f, process=False)
    repairs: list[str] = []
    n_v = len(mesh.vertices)
    mesh.merge_vertices()
    if len(mesh.vertices) != n_v:
        repairs.append(f"merged {n_v - len(mesh.vertices)} duplicate vertices")
    n_f = len(mesh.faces)
    mesh.update_faces(mesh.nondegenerate_faces())
    mesh.update_faces(mesh.unique_faces())
    if len(mesh.faces) != n_f:
        repairs.append(f"removed {n_f - len(mesh.faces)} degenerate or duplicate faces")
    info = {
        "path": str(path),
        "sha256": file_sha256(path),
        "units": units,
        "offset_m": offset.tolist(),
        "repairs": repairs,
    }
    return mesh, info


def load_rock_mesh(
    path: str | Path, *, units: str = "m", orientation: str = "as_scanned"
) -> tuple[trimesh.Trimesh, dict[str, Any]]:
    """Load a closed rock mesh ready for mass properties (positive volume, consistent winding)."""
    mesh, info = load_mesh(path, units=units)
    if not mesh.is_watertight:
        trimesh.repair.fill_holes(mesh)
        if not mesh.is_watertight:
            raise MeshError(
                f"{path}: the surface is open ({len(mesh.faces)} faces, not watertight) and its holes could not "
                "be filled; expected a closed surface"
            )
        info["repairs"].append("filled holes")
    if not mesh.is_winding_consistent:
        trimesh.repair.fix_winding(mesh)
        info["repairs"].append("made face winding consistent")
    if mesh.volume < 0:
        mesh.invert()
        info["repairs"].append("inverted inward-wound faces")
    if not (abs(mesh.volume) > 1e-12 * max(1.0, float(np.ptp(mesh.vertices))) ** 3):
        raise MeshError(f"{path}: the mesh encloses zero volume; expected a solid")
    if orientation == "stable":
        transforms, _probs = trimesh.poses.compute_stable_poses(mesh, n_samples=1)
        # lowest centre of mass among the hull's stable faces
        best = None
        for tf in transforms:
            m2 = mesh.copy()
            m2.apply_transform(tf)
            z = m2.center_mass[2] - m2.bounds[0, 2]
            if best is None or z < best[0]:
                best = (z, tf)
        if best is not None:
            mesh.apply_transform(best[1])
            info["pose_transform"] = np.asarray(best[1]).tolist()
    return mesh, info
