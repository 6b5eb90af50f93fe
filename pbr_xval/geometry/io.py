"""Reading scans: triangle meshes and point clouds, units, float64 re-centring, safe repairs.

Every reader works in float64 and **re-centres before anything else**: the returned geometry is
relative to ``info["offset_m"]`` (the mean of the input coordinates in metres), so a scan
sitting 300 km from its survey origin keeps its precision and poses can still be reported in
scan coordinates (``scan = offset + local``).

Repairs that are safe are made and listed in ``info["repairs"]``: duplicate vertices merged,
degenerate and duplicate faces removed, small planar holes capped, face winding made consistent
and outward. Everything else is refused with a :class:`GeometryError` naming the file, what was
found and what was expected (open surface, zero volume, NaN coordinates, too few points).

Formats: meshes OBJ/PLY/STL/OFF (trimesh); point clouds PLY without faces, XYZ/CSV/TXT
(three or more numeric columns, comments and a header skipped), LAS/LAZ (``laspy``) and E57
(``pye57``) — the last two are the optional ``tls`` extra: ``pip install 'pbr-xval[tls]'``.
"""

from __future__ import annotations

import re
from collections import deque
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import trimesh

from pbr_xval.geometry.mesh import MeshError, merge_and_clean
from pbr_xval.hashing import file_sha256
from pbr_xval.units import UNIT_SCALE

__all__ = [
    "CLOUD_FORMATS",
    "MESH_FORMATS",
    "GeometryError",
    "Scan",
    "check_points",
    "close_and_orient",
    "fill_small_holes",
    "fix_winding",
    "load_scan",
    "read_points",
    "read_raw",
]

MESH_FORMATS = {".obj", ".ply", ".stl", ".off"}
CLOUD_FORMATS = {".ply", ".xyz", ".csv", ".txt", ".pts", ".las", ".laz", ".e57"}
TLS_HINT = "install the optional TLS readers with: pip install 'pbr-xval[tls]'"


class GeometryError(MeshError):
    """Geometry that cannot be modelled; the message names the file, what was found and what was expected."""


@dataclass
class Scan:
    """A loaded scan in local (re-centred) metres.

    Attributes
    ----------
    kind : ``"mesh"`` (closed triangle surface) or ``"points"`` (point cloud).
    points : (n, 3) float64 — mesh vertices or cloud points, local frame (m).
    mesh : the closed, outward-wound mesh when ``kind == "mesh"``.
    offset : (3,) float64 — scan coordinates of the local origin (m).
    info : path, sha256, units, offset_m, repairs, warnings.
    """

    kind: str
    points: np.ndarray
    offset: np.ndarray
    mesh: trimesh.Trimesh | None = None
    info: dict[str, Any] = field(default_factory=dict)

    @property
    def name(self) -> str:
        """The scan's name: the stem of its file (``"scan"`` when read from memory)."""
        return Path(self.info.get("path", "scan")).stem


# ----------------------------------------------------------------------------------- raw reading
def _units(units: str, path: Path) -> float:
    if units not in UNIT_SCALE:
        raise GeometryError(f"{path}: unknown units {units!r}; expected one of {sorted(UNIT_SCALE)}")
    return UNIT_SCALE[units]


_SPLIT = re.compile(r"[,;\s]+")


def _read_table(path: Path) -> np.ndarray:
    """Numeric table with >= 3 columns; '#', '//', '%', ';' comments and non-numeric headers skipped."""
    rows: list[list[float]] = []
    with open(path, encoding="utf-8", errors="replace") as fh:
        for lineno, line in enumerate(fh, 1):
            s = line.strip()
            if not s or s[0] in "#%;" or s.startswith("//"):
                continue
            toks = [t for t in _SPLIT.split(s) if t]
            try:
                vals = [float(t) for t in toks[:3]]
            except ValueError:
                if not rows:  # a header line before the data
                    continue
                raise GeometryError(
                    f"{path}: line {lineno} is not numeric ({s[:60]!r}); expected x y z [more columns]"
                ) from None
            if len(vals) < 3:
                raise GeometryError(
                    f"{path}: line {lineno} has {len(vals)} columns; expected at least 3 (x y z)"
                )
            rows.append(vals)
    return np.asarray(rows, dtype=np.float64).reshape(-1, 3)


def _read_las(path: Path) -> np.ndarray:
    try:
        import laspy
    except ImportError:
        raise GeometryError(f"{path}: reading LAS/LAZ needs laspy; {TLS_HINT}") from None
    las = laspy.read(str(path))
    return np.column_stack([np.asarray(las.x, float), np.asarray(las.y, float), np.asarray(las.z, float)])


def _read_e57(path: Path) -> np.ndarray:
    try:
        import pye57
    except ImportError:
        raise GeometryError(f"{path}: reading E57 needs pye57; {TLS_HINT}") from None
    e57 = pye57.E57(str(path))
    parts = []
    for i in range(e57.scan_count):
        d = e57.read_scan(i, ignore_missing_fields=True, transform=True)
        parts.append(np.column_stack([d["cartesianX"], d["cartesianY"], d["cartesianZ"]]).astype(np.float64))
    return np.concatenate(parts) if parts else np.zeros((0, 3))


def read_raw(path: str | Path) -> tuple[np.ndarray, np.ndarray | None]:
    """(vertices (n, 3) float64 in file units, faces (m, 3) or None for a point cloud)."""
    path = Path(path)
    ext = path.suffix.lower()
    if ext not in MESH_FORMATS | CLOUD_FORMATS:
        raise GeometryError(
            f"{path}: unsupported format {ext!r}; expected a mesh {sorted(MESH_FORMATS)} "
            f"or a point cloud {sorted(CLOUD_FORMATS)}"
        )
    if not path.is_file():
        raise GeometryError(f"{path}: file not found")
    if ext in {".xyz", ".csv", ".txt", ".pts"}:
        return _read_table(path), None
    if ext in {".las", ".laz"}:
        return _read_las(path), None
    if ext == ".e57":
        return _read_e57(path), None
    try:
        loaded: Any = trimesh.load(path, process=False)  # Trimesh, PointCloud or Scene
    except Exception as exc:
        raise GeometryError(f"{path}: could not be read ({exc})") from None
    if isinstance(loaded, trimesh.Scene):
        geoms: list[Any] = list(loaded.dump()) if hasattr(loaded, "dump") else list(loaded.geometry.values())
        meshes = [g for g in geoms if isinstance(g, trimesh.Trimesh) and len(g.faces)]
        if meshes:
            loaded = trimesh.util.concatenate(meshes)
        elif geoms:
            loaded = trimesh.PointCloud(np.concatenate([np.asarray(g.vertices) for g in geoms]))
        else:
            raise GeometryError(f"{path}: contains no geometry; expected a mesh or a point cloud")
    v = np.asarray(loaded.vertices, dtype=np.float64)
    f = np.asarray(getattr(loaded, "faces", None) if hasattr(loaded, "faces") else np.zeros((0, 3)))
    if f is None or f.size == 0:
        return v, None
    return v, np.asarray(f, dtype=np.int64).reshape(-1, 3)


def check_points(points: np.ndarray, path: str | Path) -> None:
    """Refuse NaN/inf coordinates and sets without four non-coplanar points."""
    p = np.asarray(points, dtype=np.float64)
    bad = ~np.all(np.isfinite(p), axis=1)
    if bad.any():
        raise GeometryError(
            f"{path}: {int(bad.sum())} of {len(p)} points have NaN or infinite coordinates "
            f"(first at index {int(np.argmax(bad))}); expected finite x y z"
        )
    if len(p) < 4:
        raise GeometryError(f"{path}: only {len(p)} points; expected at least four non-coplanar points")
    c = p - p.mean(axis=0)
    s = np.linalg.svd(c, compute_uv=False)
    if s[0] == 0 or s[2] <= 1e-9 * s[0]:
        raise GeometryError(
            f"{path}: the {len(p)} points are coplanar or collinear (singular values {s.tolist()}); "
            "expected at least four non-coplanar points"
        )


# ------------------------------------------------------------------------------------- repairs
def fix_winding(mesh: trimesh.Trimesh) -> int:
    """Make face winding consistent on each connected piece (BFS over shared edges). Returns flips."""
    faces = mesh.faces.copy()
    adj = mesh.face_adjacency
    if len(adj) == 0:
        return 0
    nbrs: list[list[int]] = [[] for _ in range(len(faces))]
    for a, b in adj:
        nbrs[a].append(int(b))
        nbrs[b].append(int(a))
    done = np.zeros(len(faces), bool)
    flips = 0

    def directed(f: np.ndarray) -> set[tuple[int, int]]:
        return {(int(f[0]), int(f[1])), (int(f[1]), int(f[2])), (int(f[2]), int(f[0]))}

    for start in range(len(faces)):
        if done[start]:
            continue
        done[start] = True
        q = deque([start])
        while q:
            i = q.popleft()
            ei = directed(faces[i])
            for j in nbrs[i]:
                if done[j]:
                    continue
                if ei & directed(faces[j]):  # same directed edge -> opposite orientation
                    faces[j] = faces[j][::-1]
                    flips += 1
                done[j] = True
                q.append(j)
    if flips:
        mesh.faces = faces
    return flips


def _boundary_loops(mesh: trimesh.Trimesh) -> list[list[int]]:
    """Closed loops of boundary edges (edges used by one face), following face direction."""
    e = mesh.edges_sorted
    _, inv, counts = np.unique(e, axis=0, return_inverse=True, return_counts=True)
    once = counts[inv.ravel()] == 1
    directed = mesh.edges[once]
    nxt: dict[int, list[int]] = {}
    for a, b in directed:
        nxt.setdefault(int(a), []).append(int(b))
    loops: list[list[int]] = []
    used: set[tuple[int, int]] = set()
    for a, b in directed:
        a, b = int(a), int(b)
        if (a, b) in used:
            continue
        loop = [a]
        used.add((a, b))
        cur = b
        ok = True
        while cur != a:
            loop.append(cur)
            cand = [c for c in nxt.get(cur, []) if (cur, c) not in used]
            if not cand or len(loop) > len(directed):
                ok = False
                break
            used.add((cur, cand[0]))
            cur = cand[0]
        if ok:
            loops.append(loop)
        else:
            return []  # tangled boundary: not a set of simple holes
    return loops


def fill_small_holes(mesh: trimesh.Trimesh, max_area_fraction: float = 0.25, planarity: float = 0.05) -> int:
    """Cap boundary loops that are nearly planar and small with a fan around their centroid.

    A loop is capped when its vertices lie within ``planarity`` × loop size of their best-fit
    plane and its area is at most ``max_area_fraction`` of the mesh's surface area. Returns the
    number of holes capped (0 when any loop is not simple; the mesh then stays open).
    """
    loops = _boundary_loops(mesh)
    if not loops:
        return 0
    area = float(mesh.area)
    verts: list[np.ndarray] = [mesh.vertices]
    new_faces: list[np.ndarray] = [mesh.faces]
    nv = len(mesh.vertices)
    for loop in loops:
        p = mesh.vertices[loop]
        c = p.mean(axis=0)
        s = np.linalg.svd(p - c, compute_uv=False)
        size = float(np.ptp(p, axis=0).max())
        if len(loop) < 3 or size == 0 or (len(s) > 2 and s[2] / np.sqrt(len(p)) > planarity * size):
            return 0
        # boundary edges run a->b in their face; the cap uses b->a
        ring = np.array(loop[::-1])
        cap = np.column_stack([np.full(len(ring), nv), ring, np.roll(ring, -1)])
        a, b = mesh.vertices[ring] - c, mesh.vertices[np.roll(ring, -1)] - c
        cap_area = 0.5 * float(np.linalg.norm(np.cross(a, b), axis=1).sum())
        if cap_area > max_area_fraction * area:
            return 0
        verts.append(c[None])
        new_faces.append(cap)
        nv += 1
    mesh.vertices = np.vstack(verts)
    mesh.faces = np.vstack(new_faces)
    return len(loops)


def keep_largest_body(mesh: trimesh.Trimesh, repairs: list[str]) -> int:
    """Keep only the largest of the mesh's disjoint bodies (by enclosed volume); return how many there were.

    A scan holding two rocks, or a rock with loose fragments, is modelled as its largest body; what
    was dropped is appended to ``repairs`` (a warning for the user).
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    n = len(mesh.faces)
    adj = np.asarray(mesh.face_adjacency, dtype=np.int64).reshape(-1, 2)
    if n == 0:
        return 0
    graph = coo_matrix((np.ones(len(adj)), (adj[:, 0], adj[:, 1])), shape=(n, n))
    k, labels = connected_components(graph, directed=False)
    if k <= 1:
        return int(k)
    tri = np.asarray(mesh.triangles)
    six_v = np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2]))
    vols = np.abs(np.bincount(labels, weights=six_v, minlength=k)) / 6.0
    order = np.argsort(-vols, kind="stable")
    keep = int(order[0])
    mesh.update_faces(labels == keep)
    mesh.remove_unreferenced_vertices()
    dropped = ", ".join(f"{v:.3g}" for v in vols[order[1:6]]) + (", …" if k > 6 else "")
    repairs.append(
        f"the scan holds {k} disjoint bodies: modelled the largest ({vols[keep]:.4g} m³), dropped the "
        f"other {k - 1} ({dropped} m³)"
    )
    return int(k)


def close_and_orient(mesh: trimesh.Trimesh, path: str | Path, repairs: list[str]) -> trimesh.Trimesh:
    """Make ``mesh`` a closed, consistently and outward wound solid or raise :class:`GeometryError`.

    Appends what was repaired to ``repairs``; a mesh of several disjoint bodies is reduced to its
    largest (:func:`keep_largest_body`).
    """
    merge_and_clean(mesh, repairs)
    mesh.remove_unreferenced_vertices()
    keep_largest_body(mesh, repairs)
    if len(mesh.faces) < 4:
        raise GeometryError(f"{path}: only {len(mesh.faces)} non-degenerate faces; expected a closed surface")
    if not mesh.is_watertight:
        n_open = int((np.unique(mesh.edges_sorted, axis=0, return_counts=True)[1] == 1).sum())
        capped = fill_small_holes(mesh)
        if capped:
            repairs.append(f"capped {capped} small planar hole(s)")
        if not mesh.is_watertight:
            raise GeometryError(
                f"{path}: the surface is open ({len(mesh.faces)} faces, {n_open} boundary edges) and its holes "
                "are not small planar holes that can be capped safely; expected a closed surface"
            )
    if not mesh.is_winding_consistent:
        flips = fix_winding(mesh)
        repairs.append(f"made face winding consistent ({flips} faces flipped)")
    vol = float(mesh.volume)
    scale = float(np.ptp(mesh.vertices, axis=0).max())
    if not np.isfinite(vol) or abs(vol) <= 1e-9 * scale**3:
        raise GeometryError(
            f"{path}: the closed surface encloses zero volume ({vol:.3g} m³ for a {scale:.3g} m extent); expected a solid"
        )
    if vol < 0:
        mesh.invert()
        repairs.append(f"inverted inward-wound faces (volume was {vol:.6g} m³)")
    return mesh


# ------------------------------------------------------------------------------------- loading
def read_points(path: str | Path, *, units: str = "m") -> tuple[np.ndarray, dict[str, Any]]:
    """Any readable file as points (n, 3) float64, re-centred; mesh vertices for a mesh file."""
    scan = load_scan(path, units=units, close=False)
    return scan.points, scan.info


def load_scan(path: str | Path, *, units: str = "m", close: bool = True) -> Scan:
    """Load a mesh or point-cloud scan, convert to metres, re-centre in float64, repair safely.

    With ``close`` (default) a mesh is made a closed outward-wound solid (or refused).
    """
    path = Path(path)
    scale = _units(units, path)
    raw_v, faces = read_raw(path)
    if len(raw_v) == 0:
        raise GeometryError(f"{path}: contains no points; expected a mesh or a point cloud")
    bad = ~np.all(np.isfinite(raw_v), axis=1)
    if bad.any():
        raise GeometryError(
            f"{path}: {int(bad.sum())} of {len(raw_v)} vertices have NaN or infinite coordinates "
            f"(first at index {int(np.argmax(bad))}); expected finite x y z"
        )
    v = raw_v * scale
    offset = v.mean(axis=0)
    v = v - offset  # float64 re-centring before anything else
    info: dict[str, Any] = {
        "path": str(path),
        "sha256": file_sha256(path),
        "units": units,
        "offset_m": offset.tolist(),
        "repairs": [],
        "warnings": [],
    }
    if faces is None:
        check_points(v, path)
        info.update(kind="points", n_points=len(v))
        return Scan("points", v, offset, None, info)
    if faces.min() < 0 or faces.max() >= len(v):
        raise GeometryError(f"{path}: faces index vertices outside 0..{len(v) - 1}; expected a valid mesh")
    check_points(v, path)
    mesh = trimesh.Trimesh(vertices=v, faces=faces, process=False)
    if close:
        close_and_orient(mesh, path, info["repairs"])
    info.update(kind="mesh", n_vertices=len(mesh.vertices), n_faces=len(mesh.faces))
    return Scan("mesh", np.asarray(mesh.vertices), offset, mesh, info)
