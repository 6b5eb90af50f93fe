"""Reading rock and pedestal meshes: units, re-centring in float64, safe repairs, clear refusals.

A rock mesh put at rest (closed, oriented, posed) is
:func:`pbr_xval.geometry.interface.load_rock_mesh`, which builds on this module.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import trimesh

from pbr_xval.hashing import file_sha256
from pbr_xval.units import UNIT_SCALE

__all__ = ["MeshError", "load_mesh"]

MESH_FORMATS = {".obj", ".ply", ".stl", ".off"}


class MeshError(ValueError):
    """A mesh cannot be simulated; the message names the file, what was found and what was expected."""


def merge_and_clean(mesh: trimesh.Trimesh, repairs: list[str]) -> None:
    """Safe repairs in place: merge duplicate vertices, drop degenerate and duplicate faces.

    Appends a line to ``repairs`` for each repair that changed something.
    """
    n_v = len(mesh.vertices)
    mesh.merge_vertices()
    if len(mesh.vertices) != n_v:
        repairs.append(f"merged {n_v - len(mesh.vertices)} duplicate vertices")
    n_f = len(mesh.faces)
    mesh.update_faces(mesh.nondegenerate_faces())
    mesh.update_faces(mesh.unique_faces())
    if len(mesh.faces) != n_f:
        repairs.append(f"removed {n_f - len(mesh.faces)} degenerate or duplicate faces")


def load_mesh(path: str | Path, *, units: str = "m") -> tuple[trimesh.Trimesh, dict[str, Any]]:
    """Load a triangle mesh, convert to metres and re-centre it in float64.

    Returns the mesh (vertices relative to ``info["offset_m"]``) and an info dict with the
    file's SHA-256, the offset (so poses can be reported in scan coordinates) and the repairs.
    """
    path = Path(path)
    if path.suffix.lower() not in MESH_FORMATS:
        raise MeshError(
            f"{path}: unsupported mesh format {path.suffix!r}; expected one of {sorted(MESH_FORMATS)}"
        )
    if not path.is_file():
        raise MeshError(f"{path}: file not found")
    try:
        loaded: Any = trimesh.load(path, force="mesh", process=False)  # a Trimesh (force="mesh")
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
    merge_and_clean(mesh, repairs)
    info = {
        "path": str(path),
        "sha256": file_sha256(path),
        "units": units,
        "offset_m": offset.tolist(),
        "repairs": repairs,
    }
    return mesh, info
