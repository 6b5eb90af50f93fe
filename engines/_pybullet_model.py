"""PyBullet collision shapes and bodies for the rock and the pedestal (the adapter's model builder).

Used by :mod:`pbr_xval.engines.pybullet_`; ``pybullet`` is passed in (imported lazily there).
"""

from __future__ import annotations

import threading
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from pbr_xval.engine import NotApplicable
from pbr_xval.linalg3 import mat3_mul, mat3_vec, principal_axes, rows_mul
from pbr_xval.quaternions import matrix_to_quat

from ._common import collision_parts, write_obj

if TYPE_CHECKING:
    from pbr_xval.scene import Scene

__all__ = ["pedestal", "principal_frame", "rock_shape", "xyzw"]


def xyzw(r: np.ndarray) -> list[float]:
    """PyBullet quaternion (x, y, z, w) from a rotation matrix (3, 3)."""
    w, x, y, z = matrix_to_quat(r)
    return [float(x), float(y), float(z), float(w)]


_CLIENTS = threading.local()


def physics_client(p: Any) -> int:
    """This thread's DIRECT physics client, emptied by ``resetSimulation`` (0.5 ms) for a new run.

    Connecting costs 11–16 ms, as much as 1–2 s of simulated rocking; a run sets every engine
    parameter it uses itself, so a reset client and a new one give the same trajectory bit for
    bit (checked in tests/engines/test_common.py).
    """
    cid = getattr(_CLIENTS, "cid", None)
    if cid is None or not p.isConnected(physicsClientId=cid):
        cid = _CLIENTS.cid = p.connect(p.DIRECT)
    else:
        p.resetSimulation(physicsClientId=cid)
    return int(cid)


def xyzw_to_mats(q: Any) -> np.ndarray:
    """Quaternions (n, 4) x, y, z, w → row-major rotations (n, 9), vectorised.

    The arithmetic of Bullet's ``btMatrix3x3::setRotation`` (what ``getMatrixFromQuaternion``
    calls), so the matrices are PyBullet's own bit for bit (checked in tests/engines).
    """
    x, y, z, w = np.asarray(q, dtype=float).reshape(-1, 4).T
    s = 2.0 / (((x * x + y * y) + z * z) + w * w)
    xs, ys, zs = x * s, y * s, z * s
    wx, wy, wz, xx, xy, xz = w * xs, w * ys, w * zs, x * xs, x * ys, x * zs
    yy, yz, zz = y * ys, y * zs, z * zs
    return np.stack(
        [
            1.0 - (yy + zz),
            xy - wz,
            xz + wy,
            xy + wz,
            1.0 - (xx + zz),
            yz - wx,
            xz - wy,
            yz + wx,
            1.0 - (xx + yy),
        ],
        axis=1,
    )


def principal_frame(inertia: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Principal moments (3,) kg·m² and the rotation (3, 3) principal axes → scene axes.

    A diagonal tensor (relative off-diagonal ≤ 1e-12) keeps the scene axes.
    """
    i = 0.5 * (np.asarray(inertia, dtype=float) + np.asarray(inertia, dtype=float).T)
    off = np.abs(i - np.diag(np.diag(i))).max()
    if off <= 1e-12 * np.trace(i):
        return np.diag(i).copy(), np.eye(3)
    return principal_axes(i)  # without LAPACK: the same bits on every CPU (pbr_xval.linalg3)


def rock_shape(p: Any, cid: int, scene: Scene, s: Mapping[str, Any], rot0: np.ndarray) -> tuple[int, dict]:
    """Collision shape of the rock in the body frame (origin at the COM, axes ``rot0``)."""
    rock = scene.rock
    com = rock.com
    choice, parts = collision_parts(scene, s["collision"], s["coacd_threshold"], s["coacd_seed"])
    rt = rot0.T
    if choice == "primitive":
        if rock.primitive is None or rock.primitive.get("type") != "box":
            raise NotApplicable(f"pybullet: collision 'primitive' needs a box rock, got {rock.shape!r}")
        centre = rock.mesh.bounds.mean(axis=0)
        sid = p.createCollisionShape(
            p.GEOM_BOX,
            halfExtents=[float(x) for x in rock.primitive["half_extents"]],
            collisionFramePosition=mat3_vec(rt, centre - com).tolist(),
            collisionFrameOrientation=xyzw(mat3_mul(rt, rock.rotation)),
            physicsClientId=cid,
        )
        return sid, {"collision": "primitive", "n_parts": 1}
    if choice == "boxes":
        if not rock.box_parts:
            raise NotApplicable(f"pybullet: collision 'boxes' needs a rock made of boxes, got {rock.shape!r}")
        q = xyzw(mat3_mul(rt, rock.rotation))
        n = len(rock.box_parts)
        sid = p.createCollisionShapeArray(
            shapeTypes=[p.GEOM_BOX] * n,
            halfExtents=[[float(x) for x in he] for _, he in rock.box_parts],
            collisionFramePositions=[mat3_vec(rt, np.asarray(c) - com).tolist() for c, _ in rock.box_parts],
            collisionFrameOrientations=[q] * n,
            physicsClientId=cid,
        )
        return sid, {"collision": "boxes", "n_parts": n}
    if choice == "hull":
        verts = rows_mul(parts[0][0] - com, rot0)  # rows: rt @ (v - com), no BLAS
        sid = p.createCollisionShape(p.GEOM_MESH, vertices=verts.tolist(), physicsClientId=cid)
        return sid, {"collision": "hull", "n_parts": 1, "hull_vertices": len(verts)}
    # several (convex) parts: createCollisionShapeArray has no vertex arrays, so OBJ files;
    # each GEOM_MESH collides as its convex hull
    files = [write_obj(v, f, f"pybullet_{choice}") for v, f in parts]
    n = len(files)
    sid = p.createCollisionShapeArray(
        shapeTypes=[p.GEOM_MESH] * n,
        fileNames=[str(f) for f in files],
        meshScales=[[1.0, 1.0, 1.0]] * n,
        collisionFramePositions=[(-mat3_vec(rt, com)).tolist()] * n,
        collisionFrameOrientations=[xyzw(rt)] * n,
        physicsClientId=cid,
    )
    return sid, {"collision": choice, "n_parts": n}


def pedestal(
    p: Any, cid: int, scene: Scene, s: Mapping[str, Any], moving: bool, axes: int
) -> tuple[int, int]:
    """Pedestal body and the link index that carries its collision shape (−1: the base)."""
    ped = scene.pedestal
    kind = ped["kind"]
    frame_pos = [0.0, 0.0, 0.0]
    if kind == "plane" and s["plane_pedestal"] == "plane" and not moving:
        shape = p.createCollisionShape(p.GEOM_PLANE, physicsClientId=cid)
    elif ped["kind"] in ("plane", "box"):
        he = [
            float(x) for x in (ped["half_extents"] if ped["kind"] == "box" else s["plane_box_half_extents"])
        ]
        frame_pos = [0.0, 0.0, -he[2]]
        shape = p.createCollisionShape(
            p.GEOM_BOX, halfExtents=he, collisionFramePosition=frame_pos, physicsClientId=cid
        )
    elif ped["kind"] == "mesh":
        if moving:
            raise NotApplicable("pybullet: a mesh pedestal is a static concave trimesh; it cannot move")
        m = ped["mesh"]
        shape = p.createCollisionShape(
            p.GEOM_MESH,
            vertices=np.asarray(m.vertices, dtype=float).tolist(),
            indices=np.asarray(m.faces, dtype=int).ravel().tolist(),
            flags=p.GEOM_FORCE_CONCAVE_TRIMESH,
            physicsClientId=cid,
        )
    else:
        raise NotApplicable(f"pybullet: unknown pedestal kind {kind!r}")
    if not moving:
        return p.createMultiBody(0.0, shape, basePosition=[0.0, 0.0, 0.0], physicsClientId=cid), -1
    mass = float(s["pedestal_mass"])
    unit = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]][:axes]
    body = p.createMultiBody(
        baseMass=0.0,
        baseCollisionShapeIndex=-1,
        basePosition=[0.0, 0.0, 0.0],
        linkMasses=[mass] * axes,
        linkCollisionShapeIndices=[-1] * (axes - 1) + [shape],
        linkVisualShapeIndices=[-1] * axes,
        linkPositions=[[0.0, 0.0, 0.0]] * axes,
        linkOrientations=[[0.0, 0.0, 0.0, 1.0]] * axes,
        linkInertialFramePositions=[[0.0, 0.0, 0.0]] * axes,
        linkInertialFrameOrientations=[[0.0, 0.0, 0.0, 1.0]] * axes,
        linkParentIndices=list(range(axes)),
        linkJointTypes=[p.JOINT_PRISMATIC] * axes,
        linkJointAxis=unit,
        physicsClientId=cid,
    )
    for j in range(axes):
        p.setJointMotorControl2(body, j, p.VELOCITY_CONTROL, force=0.0, physicsClientId=cid)
        p.changeDynamics(body, j, linearDamping=0.0, angularDamping=0.0, physicsClientId=cid)
    return body, axes - 1
