"""3 × 3 linear algebra without BLAS or LAPACK (pbr_xval.linalg3), and the engines' inputs it
makes the same bits on every x86-64 CPU.

OpenBLAS picks its kernels by CPU (``OPENBLAS_CORETYPE`` forces one: SkylakeX on AVX-512,
Haswell / Zen on AVX2, Sandybridge on AVX, Prescott on SSE3) and NumPy its SIMD loops
(``NPY_DISABLE_CPU_FEATURES`` switches the AVX-512 ones off), so one machine can compute what
another does. Before ``linalg3`` the MuJoCo and PyBullet adapters took the rock's principal axes
from ``numpy.linalg.eigh``, and the same SP1 shake-table test followed another trajectory under
the Haswell than under the SkylakeX kernels (PyBullet's test 601 toppled under one and stood
under the other; docs/validation.md, "Machine dependence").
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from pbr_xval import linalg3
from pbr_xval.machine import blas_kernel_env, cpu_has


def _random_symmetric(rng: np.random.Generator, kind: int) -> np.ndarray:
    a = rng.normal(size=(3, 3))
    a = a + a.T
    if kind == 1:  # nearly diagonal (a principal frame close to the scene axes)
        return np.diag(rng.uniform(1.0, 2.0, 3)) + 1e-9 * a
    if kind == 2:  # two equal moments (an axisymmetric rock)
        q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        return q @ np.diag([3.0, 3.0, 5.0]) @ q.T
    if kind == 3:  # widely spread moments
        q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        return q @ np.diag([1e-6, 1.0, 1e6]) @ q.T
    return a


@pytest.mark.parametrize("kind", [0, 1, 2, 3])
def test_eigh3_is_an_eigendecomposition(kind: int) -> None:
    rng = np.random.default_rng(11 + kind)
    for _ in range(300):
        a = _random_symmetric(rng, kind)
        w, v = linalg3.eigh3(a)
        scale = float(np.abs(a).max())
        assert np.all(np.diff(w) >= 0.0)
        np.testing.assert_allclose(w, np.linalg.eigvalsh(a), rtol=0, atol=1e-13 * scale)
        np.testing.assert_allclose(v.T @ v, np.eye(3), rtol=0, atol=1e-14)
        np.testing.assert_allclose(v @ np.diag(w) @ v.T, a, rtol=0, atol=1e-13 * scale)


def test_eigh3_edge_cases() -> None:
    w, v = linalg3.eigh3(np.diag([3.0, 1.0, 2.0]))  # already diagonal: no rotation, sorted
    assert w.tolist() == [1.0, 2.0, 3.0]
    assert v.tolist() == [[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
    w, _ = linalg3.eigh3(np.eye(3) * 5.0)
    assert w.tolist() == [5.0, 5.0, 5.0]
    a = np.array([[2.0, 1e-300, 0.0], [1e-300, 1.0, 0.0], [0.0, 0.0, 3.0]])  # θ overflows
    w, v = linalg3.eigh3(a)
    np.testing.assert_allclose(w, [1.0, 2.0, 3.0])
    np.testing.assert_allclose(np.abs(v.T @ v), np.eye(3), atol=1e-15)
    with pytest.raises(ValueError, match=r"expected a 3 × 3 matrix, got shape \(2, 2\)"):
        linalg3.eigh3(np.eye(2))


def test_principal_axes_right_handed_and_products() -> None:
    rng = np.random.default_rng(5)
    for _ in range(200):
        a = _random_symmetric(rng, 0)
        w, r = linalg3.principal_axes(a)
        assert linalg3.det3(r) > 0.0
        np.testing.assert_allclose(linalg3.det3(r), 1.0, atol=1e-14)
        np.testing.assert_allclose(r @ np.diag(w) @ r.T, a, atol=1e-13 * float(np.abs(a).max()))
        b, x, p = rng.normal(size=(3, 3)), rng.normal(size=3), rng.normal(size=(7, 3))
        np.testing.assert_allclose(linalg3.mat3_mul(a, b), a @ b, rtol=1e-14, atol=1e-14)
        np.testing.assert_allclose(linalg3.mat3_vec(a, x), a @ x, rtol=1e-14, atol=1e-14)
        np.testing.assert_allclose(linalg3.rows_mul(p, a), p @ a, rtol=1e-14, atol=1e-14)
        np.testing.assert_allclose(linalg3.rows_dot(p, x), p @ x, rtol=1e-14, atol=1e-14)
        np.testing.assert_allclose(linalg3.det3(a), np.linalg.det(a), rtol=1e-12, atol=1e-12)
        assert linalg3.norm3(x) == pytest.approx(float(np.linalg.norm(x)), rel=1e-15)
    # the fixed order of the sums: element (i, j) is (a_i0 b_0j + a_i1 b_1j) + a_i2 b_2j
    a, b = rng.normal(size=(3, 3)), rng.normal(size=(3, 3))
    assert linalg3.mat3_mul(a, b)[1, 2] == (a[1, 0] * b[0, 2] + a[1, 1] * b[1, 2]) + a[1, 2] * b[2, 2]
    with pytest.raises(ValueError, match=r"expected points of shape \(n, 3\), got \(3,\)"):
        linalg3.rows_mul(np.ones(3), np.eye(3))


def test_inv3_is_the_inverse_and_refuses_a_singular_matrix() -> None:
    rng = np.random.default_rng(9)
    for kind in (0, 1, 3):
        for _ in range(100):
            a = _random_symmetric(rng, kind) if kind else rng.normal(size=(3, 3))
            inv = linalg3.inv3(a)
            np.testing.assert_allclose(inv, np.linalg.inv(a), rtol=1e-9 * np.linalg.cond(a), atol=0)
    # a rock's inertia tensor (kg m²), off-diagonal products of inertia: I⁻¹ I = 1 to round-off
    inertia = np.array([[30.1, -0.4, 1.2], [-0.4, 28.7, 0.3], [1.2, 0.3, 21.9]])
    np.testing.assert_allclose(linalg3.mat3_mul(linalg3.inv3(inertia), inertia), np.eye(3), atol=1e-15)
    with pytest.raises(ValueError, match=r"matrix is singular \(determinant 0.0\)"):
        linalg3.inv3(np.array([[1.0, 2.0, 3.0], [2.0, 4.0, 6.0], [0.0, 0.0, 1.0]]))


# The engines' inputs and a short MuJoCo and PyBullet run on a scanned-like rock (a synthetic mesh,
# so the test needs no shared data), printed as hashes. The rock starts tilted (the ensembles'
# seating tilt) and is shaken along 20° by a half-sine that rocks it.
PROBE = r"""
import hashlib, json, sys, importlib.util
from pathlib import Path
import numpy as np
from pbr_xval import linalg3, stepping
from pbr_xval.conformance import housner_scenario
from pbr_xval.geometry.synthetic import synthetic_rock
from pbr_xval.runner import run_scene
from pbr_xval.scene import compile_scene

h = lambda *a: hashlib.sha256(b"".join(np.ascontiguousarray(x, dtype=np.float64).tobytes() for x in a)).hexdigest()
rng = np.random.default_rng(3)
m = rng.normal(size=(3, 3))
inertia = linalg3.mat3_mul(m, m.T) + np.eye(3)  # the input itself without BLAS
out = {"principal_axes": h(*linalg3.principal_axes(inertia)), "numpy_eigh": h(*np.linalg.eigh(inertia))}
pts = rng.normal(size=(500, 3))
out["rows_mul"] = h(linalg3.rows_mul(pts, m), linalg3.mat3_mul(m, inertia), linalg3.mat3_vec(m, pts[0]))
out["numpy_matmul"] = h(pts @ m)
mesh, _ = synthetic_rock(seed=7, subdivisions=2)
path = Path(sys.argv[1]) / "rock.obj"
mesh.export(path)
exc = {"type": "half_sine", "amplitude": 4.0, "frequency": 2.0, "phase": 0.0}
scn = housner_scenario(duration=1.5, excitation=exc, rock={"shape": "mesh", "path": str(path), "density": 2600.0})
scn = scn.with_value("excitation.azimuth_deg", 20.0).with_value("initial.theta", -0.003)
scene = compile_scene(scn)
out["scene"] = h(scene.rock.mesh.vertices, scene.rock.inertia, scene.rock.com)
out["initial_pose"] = h(*stepping.initial_pose(scene))
for eng in ("mujoco", "pybullet"):
    if importlib.util.find_spec(eng) is None:
        continue
    tr = run_scene(scene, eng)
    out[eng] = h(tr.t, tr.com, tr.quat, tr.omega) + f" ok={tr.ok} peak={float(np.max(np.abs(tr.rocking_angle()))):.4f}"
print(json.dumps(out))
"""

#: the AVX-512 loops NumPy 2 dispatches to; switched off, it runs what an AVX2 machine runs
NPY_AVX512 = "X86_V4 AVX512_ICL AVX512_SPR"


def _probe(tmp: Path, coretype: str | None, npy_off: str | None = None) -> dict[str, str]:
    env = blas_kernel_env(coretype, npy_off)
    res = subprocess.run(
        [sys.executable, "-c", PROBE, str(tmp)], env=env, capture_output=True, text=True, timeout=300
    )
    assert res.returncode == 0, res.stderr[-3000:]
    return dict(json.loads(res.stdout.strip().splitlines()[-1]))


@pytest.mark.slow
def test_engine_inputs_and_runs_are_the_same_under_every_blas_kernel(tmp_path: Path) -> None:
    """The linalg3 results under every OpenBLAS core type and with NumPy's AVX-512 loops off;
    the compiled scene, the tilted start and the MuJoCo and PyBullet runs under every core type
    of a CPU with AVX2 (under the Sandybridge and Prescott kernels a scanned rock's settle pose —
    BLAS products in ``geometry.interface.settle_pose`` — and all that follows differ in their last
    bits: docs/validation.md, "The engines' inputs without BLAS")."""
    here = _probe(tmp_path, None)
    variants = {
        "Haswell": _probe(tmp_path, "Haswell"),
        "no AVX-512 in NumPy": _probe(tmp_path, None, NPY_AVX512),
    }
    if cpu_has("avx512f"):
        variants["SkylakeX"] = _probe(tmp_path, "SkylakeX")
    old_cpus = {c: _probe(tmp_path, c) for c in ("Sandybridge", "Prescott")}
    # the probe can tell kernels apart: LAPACK's eigenvectors or BLAS's products differ
    lapack = {r["numpy_eigh"] for r in [here, *variants.values(), *old_cpus.values()]}
    blas = {r["numpy_matmul"] for r in [here, *variants.values(), *old_cpus.values()]}
    assert len(lapack) + len(blas) > 2, (lapack, blas)
    for name, r in {**variants, **old_cpus}.items():
        assert r["principal_axes"] == here["principal_axes"], name
        assert r["rows_mul"] == here["rows_mul"], name
    for name, r in variants.items():
        for key in ("scene", "initial_pose", "mujoco", "pybullet"):
            assert r.get(key) == here.get(key), (name, key, r.get(key), here.get(key))
    assert "ok=True" in here.get("mujoco", "ok=True") and "ok=True" in here.get("pybullet", "ok=True")
