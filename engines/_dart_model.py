"""DART model helpers for :mod:`pbr_xval.engines.dart_`: mesh shapes, shape nodes, free-joint probes.

``dartpy`` is passed in (never imported here), so importing this module loads no engine.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from pbr_xval.engines import _common as common

__all__ = ["expmap_to_mats", "freejoint_velocity_is_world", "load_mesh_shapes", "shape_node"]


def load_mesh_shapes(dart: Any, paths: list[Path]) -> list[Any]:
    """MeshShapes for OBJ files, through a URDF string (dartpy has no array → mesh constructor)."""
    cols = "".join(
        f'<collision><geometry><mesh filename="file://{p.resolve()}"/></geometry></collision>' for p in paths
    )
    urdf = f'<robot name="pbr_xval_mesh"><link name="l">{cols}</link></robot>'
    skel = dart.utils.DartLoader().parseSkeletonString(
        urdf, dart.common.Uri.createFromPath(str(common.cache_dir()) + "/")
    )
    if skel is None:
        raise RuntimeError(f"DART could not load the mesh files {[str(p) for p in paths]}")
    bn = skel.getBodyNode(0)
    return [bn.getShapeNode(i).getShape() for i in range(bn.getNumShapeNodes())]


def freejoint_velocity_is_world(dart: Any) -> bool:
    """True if FreeJoint generalised velocities are (ω, v) in world coordinates (dartpy 6.20)."""
    D = dart.dynamics
    skel = D.Skeleton("probe")
    fj, body = skel.createFreeJointAndBodyNodePair()
    c, s = math.cos(0.7), math.sin(0.7)
    fj.setTransform(dart.math.Isometry3(np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]]), np.zeros(3)))
    fj.setAngularVelocity(np.array([1.0, 2.0, 3.0]))
    return bool(np.allclose(skel.getVelocities()[:3], body.getAngularVelocity(), rtol=0, atol=1e-12))


def shape_node(body: Any, shape: Any, rot: np.ndarray, pos: np.ndarray, mu: float, e: float) -> None:
    """Attach ``shape`` to ``body`` at (rotation (3, 3), translation (3,) m), colliding with μ and e."""
    sn = body.createShapeNode(shape)
    sn.setRelativeRotation(rot)
    sn.setRelativeTranslation(pos)
    sn.createCollisionAspect()
    da = sn.createDynamicsAspect()
    da.setFrictionCoeff(mu)
    da.setRestitutionCoeff(e)


def expmap_to_mats(w: np.ndarray) -> np.ndarray:
    """Rotation vectors (n, 3) rad → row-major rotation matrices (n, 9), vectorised.

    DART's ``math::expMapRot`` (what ``FreeJoint::convertToTransform`` and so a free body's
    ``getTransform`` use) term by term, its second-order branch below 10⁻³ rad included, so the
    matrices are DART's own bit for bit (checked in tests/engines/test_common.py): the DART adapter
    reads the 6 free-joint coordinates per sample and converts them once per block.
    """
    x, y, z = np.asarray(w, dtype=float).reshape(-1, 3).T
    n = x.shape[0]
    s = np.zeros((n, 3, 3))
    s[:, 0, 1], s[:, 0, 2], s[:, 1, 0], s[:, 1, 2], s[:, 2, 0], s[:, 2, 1] = -z, y, z, -x, -y, x
    s2 = np.empty((n, 3, 3))
    for i in range(3):  # Eigen's 3 × 3 product: (a₀b₀ + a₁b₁) + a₂b₂
        for j in range(3):
            s2[:, i, j] = (s[:, i, 0] * s[:, 0, j] + s[:, i, 1] * s[:, 1, j]) + s[:, i, 2] * s[:, 2, j]
    th = np.sqrt(x * x + y * y + z * z)
    small = th < 1e-3
    with np.errstate(invalid="ignore", divide="ignore"):
        a = np.where(small, 1.0, np.sin(th) / th)
        b = np.where(small, 0.5, (1.0 - np.cos(th)) / (th * th))
    return ((np.eye(3) + a[:, None, None] * s) + b[:, None, None] * s2).reshape(n, 9)
