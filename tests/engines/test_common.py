"""The shared adapter machinery: quaternions, the recorder's toppling and failure detection."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from pbr_xval.conformance import housner_scenario
from pbr_xval.scene import compile_scene
from pbr_xval.stepping import Recorder, initial_pose, matrices_to_quats, matrix_to_quat, rotation_about


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


def test_recorder_first_crossing_topples_at_alpha() -> None:
    scene, rec = _rec(toppling={"criterion": "critical_tilt"})
    alpha = math.atan(1 / 3)
    e = scene.rocking_axis
    for k, th in enumerate(np.linspace(0, -1.2 * alpha, 200)):
        stop = rec.record(k * 1e-3, scene.rock.com, rotation_about(e, th), np.zeros(3))
        if stop:
            break
    tr = rec.trajectory("x", {}, {})
    assert tr.toppled and abs(tr.rocking_angle()[-1]) == pytest.approx(alpha, abs=0.01 * alpha)
    assert abs(tr.rocking_angle()[-2]) < alpha


def _drive(rec: Recorder, scene, t: np.ndarray, theta: np.ndarray) -> bool:
    e = scene.rocking_axis
    for tk, th in zip(t, theta, strict=True):
        if rec.record(float(tk), scene.rock.com, rotation_about(e, float(th)), np.zeros(3)):
            return True
    return False


def test_recorder_physical_decision() -> None:
    """Past α while the ground moves is not toppling; past α and tilting outward after it is."""
    alpha = math.atan(1 / 3)
    scene, rec = _rec()  # default criterion: physical; the half-sine pulse ends at (π − ψ)/ω
    t_end = scene.excitation_end
    assert 0.3 < t_end < 0.5
    # 1) crosses α during the pulse and comes back: not toppled, the run goes on
    t = np.linspace(0.0, 0.9 * t_end, 300)
    theta = 1.3 * alpha * np.sin(np.pi * t / (0.9 * t_end))
    assert not _drive(rec, scene, t, theta)
    tr = rec.trajectory("x", {}, {})
    assert not tr.toppled and np.max(np.abs(tr.rocking_angle())) > 1.2 * alpha
    # 2) crosses α before the pulse ends and keeps tilting outward: decided once the pulse is over,
    #    the toppled event dated at the crossing
    scene, rec = _rec()
    t = np.linspace(0.0, 1.5 * t_end, 600)
    theta = 1.5 * alpha * t / t.max()
    assert _drive(rec, scene, t, theta)
    tr = rec.trajectory("x", {}, {})
    ev = next(e for e in tr.events if e.kind == "toppled")
    t_cross = t[np.argmax(theta >= alpha)]
    assert ev.t == pytest.approx(t_cross, abs=2 * (t[1] - t[0]))
    assert ev.data["decided_at"] >= t_end and "after the excitation" in ev.data["rule"]
    assert tr.scene_info["toppling"]["criterion"] == "physical"
    # 3) down (90°) during the pulse: decided at once
    scene, rec = _rec()
    t = np.linspace(0.0, 0.5 * t_end, 300)
    assert _drive(rec, scene, t, 0.5 * np.pi * t / t.max())
    ev = next(e for e in rec.trajectory("x", {}, {}).events if e.kind == "toppled")
    assert ev.data["rule"].startswith("down") and ev.data["decided_at"] < t_end
    # 4) past α at the end of the run and still tilting outward: toppled; tilting back: undecided
    scene, rec = _rec(excitation={"type": "none"})
    t = np.linspace(0.0, 0.2, 50)
    assert not _drive(rec, scene, t, np.linspace(0.0, 0.99 * alpha, 50))
    rec.record(0.21, scene.rock.com, rotation_about(scene.rocking_axis, 1.01 * alpha), np.zeros(3))
    assert rec.trajectory("x", {}, {}).toppled is True


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


def test_initial_pose_rests_on_a_vertex_beyond_the_edge() -> None:
    """A hull vertex just beyond the pivot edge and 0.1 mm above the pedestal (a scanned base):
    tilting about the edge would push it 0.5 mm into the pedestal; the rock rests on it instead,
    tilted by the same θ0, nothing below the pedestal."""
    import dataclasses

    import trimesh

    from pbr_xval.stepping import rotation_about

    scene = compile_scene(housner_scenario(excitation={"type": "none"}, initial={"theta": 0.01}))
    box = scene.rock.mesh.vertices
    extra = np.array([[0.26, 0.0, 1e-4]])  # 0.06 m beyond the +x edge, 0.1 mm up: lands at θ ≈ 1.7e-3
    mesh = trimesh.convex.convex_hull(np.vstack([box, extra]))
    rock = dataclasses.replace(scene.rock, mesh=mesh)
    tilted = dataclasses.replace(scene, rock=rock)
    com, rot, _vel, _om = initial_pose(tilted)
    assert np.allclose(rot, rotation_about(scene.rocking_axis, 0.01), atol=0)
    z = com[2] + (mesh.vertices - scene.rock.com) @ rot[2]
    assert z.min() == pytest.approx(0.0, abs=1e-12)  # on the pedestal, not in it
    lowest = mesh.vertices[np.argmin(z)]
    assert np.allclose(lowest, extra[0])  # the rock rests on the vertex beyond the edge
    # the plain tilt about the edge would have put it 0.06 sin θ − 1e-4 cos θ ≈ 0.5 mm deep
    old = initial_pose(scene)
    z_old = old[0][2] + (extra[0] - scene.rock.com) @ old[1][2]
    assert z_old == pytest.approx(1e-4 * math.cos(0.01) - 0.06 * math.sin(0.01), rel=1e-9)


def test_block_pose_conversion_is_the_engines_own() -> None:
    """The adapters read quaternions per sample and convert them per block: the matrices must be
    the engines' own conversions bit for bit (mju_quat2Mat, getMatrixFromQuaternion)."""
    from pbr_xval.stepping import quats_to_mats

    rng = np.random.default_rng(7)
    q = rng.normal(size=(3000, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    q[0] = (1.0, 0.0, 0.0, 0.0)
    mujoco = pytest.importorskip("mujoco")
    ref = np.zeros((len(q), 9))
    for i in range(len(q)):
        mujoco.mju_quat2Mat(ref[i], q[i])
    assert np.array_equal(quats_to_mats(q), ref)
    p = pytest.importorskip("pybullet")
    from pbr_xval.engines._pybullet_model import xyzw_to_mats

    xyzw = q[:, [1, 2, 3, 0]]
    ref_pb = np.array([p.getMatrixFromQuaternion(x.tolist()) for x in xyzw])
    assert np.array_equal(xyzw_to_mats(xyzw), ref_pb)


def test_dart_pose_conversion_is_dart_own() -> None:
    """The DART adapter reads the free-joint coordinates and converts them per block: the matrices
    must be DART's own (FreeJoint.convertToTransform) bit for bit, both sides of its 1e-3 rad branch."""
    dart = pytest.importorskip("dartpy")
    from pbr_xval.engines._dart_model import expmap_to_mats

    rng = np.random.default_rng(5)
    w = np.concatenate(
        [
            rng.normal(size=(600, 3)) * rng.uniform(0, 3, (600, 1)),
            rng.normal(size=(200, 3)) * 1e-4,
            np.zeros((1, 3)),
        ]
    )
    ref = np.array(
        [dart.dynamics.FreeJoint.convertToTransform(np.r_[v, 0.0, 0.0, 0.0]).rotation() for v in w]
    )
    assert np.array_equal(expmap_to_mats(w), ref.reshape(-1, 9))


def test_pybullet_reused_client_gives_fresh_client_results() -> None:
    """PyBullet runs reuse one DIRECT client per thread (reset between runs): the results must be a
    new client's bit for bit, whatever ran before (other scenes, other solver settings)."""
    pytest.importorskip("pybullet")
    from concurrent.futures import ThreadPoolExecutor

    from pbr_xval.runner import run_scene

    exc = {"type": "half_sine", "amplitude": 6.0, "frequency": 1.0, "phase": "housner_uplift"}
    a = compile_scene(housner_scenario(duration=1.0, excitation=exc))
    b = compile_scene(housner_scenario(duration=0.5, initial={"theta_over_alpha": 0.5}))
    others = {"solver_type": "dantzig", "enable_sat": True, "num_solver_iterations": 7, "timestep": 5e-4}

    def fresh(scene, settings=None):  # a new thread: a new client
        with ThreadPoolExecutor(1) as ex:
            return ex.submit(run_scene, scene, "pybullet", settings).result().fingerprint()

    first = run_scene(a, "pybullet").fingerprint()
    run_scene(b, "pybullet", others)
    run_scene(b, "pybullet", {"ground_motion": "moving_pedestal"})
    assert run_scene(a, "pybullet").fingerprint() == first == fresh(a)
    assert run_scene(b, "pybullet", others).fingerprint() == fresh(b, others)


def test_dart_pose_paths_agree() -> None:
    """DART's two pose reads (free-joint coordinates converted per block, or getTransform per sample)
    give the same run bit for bit, at dt = output_dt and with native steps between samples."""
    pytest.importorskip("dartpy")
    import pbr_xval.engines.dart_ as dart_mod
    from pbr_xval.runner import run_scene

    exc = {"type": "half_sine", "amplitude": 6.0, "frequency": 1.0, "phase": "housner_uplift"}
    scene = compile_scene(housner_scenario(duration=1.0, excitation=exc))
    begin = dart_mod._DartStepper.begin

    def slow_begin(self, n):
        begin(self, n)
        assert self.fast_pose  # the check passes for a free rock body
        self.fast_pose = False

    for dt in (1e-3, 2.5e-4):
        fast = run_scene(scene, "dart", {"timestep": dt})
        dart_mod._DartStepper.begin = slow_begin
        try:
            slow = run_scene(scene, "dart", {"timestep": dt})
        finally:
            dart_mod._DartStepper.begin = begin
        assert fast.fingerprint() == slow.fingerprint() and fast.toppled
