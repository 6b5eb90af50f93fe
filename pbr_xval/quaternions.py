"""Rotations as scalar-first unit quaternions (w, x, y, z) and matrices: the one quaternion module.

Every orientation in pbr-xval is a scalar-first unit quaternion relative to the rock's resting
pose (``Trajectory.quat``). The converters here are shared by the trajectory (quaternions to
matrices for tilt and rocking angle), the analytical engines (planar rotations about an axis),
the stepping core (the adapters' rotation matrices to quaternions, Shepperd's method) and the
MuJoCo adapter (quaternions to matrices in MuJoCo's own summation order, bit for bit).
"""

from __future__ import annotations

import math

import numpy as np

from pbr_xval.linalg3 import mat3_mul, norm3

__all__ = [
    "axis_angle_quat",
    "matrices_to_quats",
    "matrix_to_quat",
    "quat_to_matrix",
    "quats_to_mats",
    "rotation_about",
]


def quat_to_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrices from unit quaternions.

    Parameters
    ----------
    q : (n, 4) float, scalar-first (w, x, y, z).

    Returns
    -------
    (n, 3, 3) float
    """
    q = np.asarray(q, dtype=float)
    w, x, y, z = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    r = np.empty((q.shape[0], 3, 3))
    r[:, 0, 0] = 1 - 2 * (y * y + z * z)
    r[:, 0, 1] = 2 * (x * y - w * z)
    r[:, 0, 2] = 2 * (x * z + w * y)
    r[:, 1, 0] = 2 * (x * y + w * z)
    r[:, 1, 1] = 1 - 2 * (x * x + z * z)
    r[:, 1, 2] = 2 * (y * z - w * x)
    r[:, 2, 0] = 2 * (x * z - w * y)
    r[:, 2, 1] = 2 * (y * z + w * x)
    r[:, 2, 2] = 1 - 2 * (x * x + y * y)
    return r


def axis_angle_quat(axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Quaternions (n, 4), scalar first, for rotations by ``angle`` (n,) rad about a unit ``axis`` (3,)."""
    angle = np.asarray(angle, dtype=float)
    axis = np.asarray(axis, dtype=float) / norm3(axis)
    half = 0.5 * angle
    q = np.empty((angle.size, 4))
    q[:, 0] = np.cos(half)
    q[:, 1:] = np.sin(half)[:, None] * axis[None, :]
    return q


def matrix_to_quat(r: np.ndarray) -> np.ndarray:
    """Scalar-first unit quaternion (4,) from a rotation matrix (3, 3) (Shepperd's method)."""
    m = np.asarray(r, dtype=float)
    tr = m[0, 0] + m[1, 1] + m[2, 2]
    if tr > 0:
        s = 2.0 * math.sqrt(tr + 1.0)
        q = [0.25 * s, (m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s]
    elif m[0, 0] > m[1, 1] and m[0, 0] > m[2, 2]:
        s = 2.0 * math.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2])
        q = [(m[2, 1] - m[1, 2]) / s, 0.25 * s, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s]
    elif m[1, 1] > m[2, 2]:
        s = 2.0 * math.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2])
        q = [(m[0, 2] - m[2, 0]) / s, (m[0, 1] + m[1, 0]) / s, 0.25 * s, (m[1, 2] + m[2, 1]) / s]
    else:
        s = 2.0 * math.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1])
        q = [(m[1, 0] - m[0, 1]) / s, (m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, 0.25 * s]
    qa = np.array(q)
    if qa[0] < 0:
        qa = -qa
    return qa / math.sqrt(qa[0] * qa[0] + qa[1] * qa[1] + qa[2] * qa[2] + qa[3] * qa[3])


def matrices_to_quats(r: np.ndarray) -> np.ndarray:
    """Vectorised :func:`matrix_to_quat`: (n, 3, 3) rotations → (n, 4) scalar-first quaternions.

    Each row uses the numerically best of Shepperd's four branches (largest diagonal term).
    """
    m = np.asarray(r, dtype=float).reshape(-1, 3, 3)
    n = m.shape[0]
    tr = m[:, 0, 0] + m[:, 1, 1] + m[:, 2, 2]
    cand = np.stack([tr, m[:, 0, 0], m[:, 1, 1], m[:, 2, 2]], axis=1)
    k = np.argmax(cand, axis=1)
    q = np.empty((n, 4))
    with np.errstate(invalid="ignore", divide="ignore"):
        for b in range(4):  # each row through its own branch only (element-wise: same bits)
            sel = np.flatnonzero(k == b)
            if not sel.size:
                continue
            r = m[sel] if sel.size < n else m
            d21, d02, d10 = r[:, 2, 1] - r[:, 1, 2], r[:, 0, 2] - r[:, 2, 0], r[:, 1, 0] - r[:, 0, 1]
            s01, s02, s12 = r[:, 0, 1] + r[:, 1, 0], r[:, 0, 2] + r[:, 2, 0], r[:, 1, 2] + r[:, 2, 1]
            r00, r11, r22 = r[:, 0, 0], r[:, 1, 1], r[:, 2, 2]
            if b == 0:
                sq = 2.0 * np.sqrt(np.maximum(tr[sel] + 1.0, 0.0))
                q[sel] = np.stack([0.25 * sq, d21 / sq, d02 / sq, d10 / sq], axis=1)
            elif b == 1:
                sq = 2.0 * np.sqrt(np.maximum(1.0 + r00 - r11 - r22, 0.0))
                q[sel] = np.stack([d21 / sq, 0.25 * sq, s01 / sq, s02 / sq], axis=1)
            elif b == 2:
                sq = 2.0 * np.sqrt(np.maximum(1.0 + r11 - r00 - r22, 0.0))
                q[sel] = np.stack([d02 / sq, s01 / sq, 0.25 * sq, s12 / sq], axis=1)
            else:
                sq = 2.0 * np.sqrt(np.maximum(1.0 + r22 - r00 - r11, 0.0))
                q[sel] = np.stack([d10 / sq, s02 / sq, s12 / sq, 0.25 * sq], axis=1)
    q[q[:, 0] < 0] *= -1.0
    # |q| per row summed left to right (element-wise: the same bits whatever the SIMD width)
    return q / np.sqrt(q[:, 0] * q[:, 0] + q[:, 1] * q[:, 1] + q[:, 2] * q[:, 2] + q[:, 3] * q[:, 3])[:, None]


def quats_to_mats(q: np.ndarray) -> np.ndarray:
    """Scalar-first quaternions (n, 4) → row-major rotation matrices (n, 9), vectorised.

    The terms are summed in the order MuJoCo's ``mju_quat2Mat`` uses, so a MuJoCo pose read as a
    quaternion gives the same matrix bit for bit (checked in tests/test_stepping.py); any unit
    quaternion gives its rotation to rounding.
    """
    q0, q1, q2, q3 = np.asarray(q, dtype=float).T
    q00, q01, q02, q03 = q0 * q0, q0 * q1, q0 * q2, q0 * q3
    q11, q12, q13, q22, q23, q33 = q1 * q1, q1 * q2, q1 * q3, q2 * q2, q2 * q3, q3 * q3
    r = np.empty((q0.shape[0], 9))
    r[:, 0] = (q00 - q22) + (q11 - q33)
    r[:, 4] = (q00 + q22) - (q11 + q33)
    r[:, 8] = (q00 - q22) + (q33 - q11)
    r[:, 1], r[:, 2] = 2 * (q12 - q03), 2 * (q13 + q02)
    r[:, 3], r[:, 5] = 2 * (q12 + q03), 2 * (q23 - q01)
    r[:, 6], r[:, 7] = 2 * (q13 - q02), 2 * (q23 + q01)
    return r


def rotation_about(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rotation matrix (3, 3) for ``angle`` rad about the unit ``axis`` (3,) (Rodrigues)."""
    a = np.asarray(axis, dtype=float) / norm3(axis)
    k = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
    return np.eye(3) + math.sin(angle) * k + (1.0 - math.cos(angle)) * mat3_mul(k, k)
