"""pbr_xval.quaternions' rotation → quaternion conversions against scipy, branch by branch.

Every adapter's orientation output goes through them (Shepperd's method: four branches, the one
with the largest diagonal term). Mutation testing found branches that only one sample reached.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from pbr_xval.quaternions import matrices_to_quats, matrix_to_quat


def _ref(r: Rotation) -> np.ndarray:
    q = np.atleast_2d(r.as_quat(scalar_first=True))
    q[q[:, 0] < 0] *= -1.0
    return q


def _one_branch_each() -> list[Rotation]:
    """Rotations whose largest term is the trace, m00, m11 and m22 respectively."""
    return [
        Rotation.from_rotvec([0.1, -0.2, 0.3]),
        Rotation.from_rotvec(np.radians(170.0) * np.array([1.0, 0.1, -0.05])),
        Rotation.from_rotvec(np.radians(175.0) * np.array([0.1, 1.0, 0.05])),
        Rotation.from_rotvec(np.radians(165.0) * np.array([-0.05, 0.1, 1.0])),
    ]


def test_matrix_to_quat_every_branch_and_sample() -> None:
    rots = [*_one_branch_each(), *Rotation.random(200, random_state=5)]
    for r in rots:
        np.testing.assert_allclose(matrix_to_quat(r.as_matrix()), _ref(r)[0], atol=1e-12)


def test_matrices_to_quats_batches_missing_branches() -> None:
    # a batch need not hold every branch: each one alone, then pairs without the trace branch
    rots = _one_branch_each()
    for r in rots:
        np.testing.assert_allclose(matrices_to_quats(r.as_matrix()[None]), _ref(r), atol=1e-12)
    batch = Rotation.concatenate(rots[1:])
    np.testing.assert_allclose(matrices_to_quats(batch.as_matrix()), _ref(batch), atol=1e-12)
    mixed = Rotation.concatenate([rots[3], rots[1], rots[3]])
    np.testing.assert_allclose(matrices_to_quats(mixed.as_matrix()), _ref(mixed), atol=1e-12)
