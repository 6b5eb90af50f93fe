"""The shared adapter machinery: quaternions, the recorder's toppling and failure detection."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from pbr_xval.conformance import housner_scenario
from pbr_xval.engines._common import Recorder, initial_pose, matrices_to_quats, matrix_to_quat, rotation_about
from pbr_xval.scene import compile_scene


def test_quaternions_match_scipy() -> None:
    r = Rotation.random(500, random_state=3)
    q = matrices_to_quats(r.as_matrix())
    ref = r.as_quat(scalar_first=True)
    ref[ref[:, 0] < 0] *= -1
    assert np.allclose(q, ref, atol=1e-12)
    assert np.allclose(matrix_to_quat(r.as_matrix()[7]), ref[7], atol=1e-12)


def _rec(**kw):
    scene = compile_scene(housner_scenario(**kw))
    rec = Recorder(scene, 1e-3)
    rec.start(scene.rock.com, np.eye(3))
    return scene, rec


def test_recorder_topples_at_alpha() -> None:
    scene, rec = _rec()
    alpha = math.atan(1 / 3)
    e = scene.rocking_axis
    for k, th in enumerate(np.linspace(0, -1.2 * alpha, 200)):
        stop = rec.record(k * 1e-3, scene.rock.com, rotation_about(e, th), np.zeros(3))
        if stop:
            break
    tr = rec.trajectory("x", {}, {})
    assert tr.toppled and abs(tr.rocking_angle()[-1]) == pytest.approx(alpha, abs=0.01 * alpha)
    assert abs(tr.rocking_angle()[-2]) < alpha


def test_recorder_flags_nan_and_explosion() -> None:
    _, rec = _rec()
    assert rec.record(0.0, np.array([np.nan, 0, 0.6]), np.eye(3), np.zeros(3))
    tr = rec.trajectory("x", {}, {})
    assert tr.status == "failed" and "NaN" in tr.message
    _, rec = _rec()
    assert rec.record(0.0, np.array([100.0, 0, 0.6]), np.eye(3), np.zeros(3))
    assert "explosion" in rec.trajectory("x", {}, {}).message


def test_initial_pose_pivots_about_the_edge() -> None:
    scene = compile_scene(housner_scenario(excitation={"type": "none"}, initial={"theta_over_alpha": 0.5}))
    com, rot, vel, om = initial_pose(scene)
    # the right bottom edge (x = +0.2, z = 0) stays put
    corner = np.array([0.2, 0.0, 0.0])
    assert np.allclose(com + rot @ (corner - scene.rock.com), corner, atol=1e-12)
    assert np.allclose(vel, 0) and np.allclose(om, 0)
