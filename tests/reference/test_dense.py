"""The reference solver without BLAS or LAPACK (pbr_xval.reference.dense), and the same run bit
for bit under every OpenBLAS kernel family of a CPU with AVX2.

OpenBLAS picks its kernels by CPU (``OPENBLAS_CORETYPE`` forces one: Haswell / Zen on AVX2,
SkylakeX on AVX-512), so one machine computes what another does. Before ``dense`` (and the
reference's use of ``linalg3``) the reference solver's inertia inverse, its Python paths' matrix
products and least-squares solves went through BLAS and LAPACK, and the same SP1 shake-table test
followed another trajectory under the Haswell than under the SkylakeX kernels (SP1 632 and 601;
docs/validation.md, "Machine dependence").
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from pbr_xval.machine import blas_kernel_env, cpu_has
from pbr_xval.reference import dense


def _rank_deficient(rng: np.random.Generator, m: int, n: int, r: int) -> np.ndarray:
    return rng.normal(size=(m, r)) @ rng.normal(size=(r, n))


def test_products_and_norm_match_numpy() -> None:
    rng = np.random.default_rng(1)
    for m, p, n in [(1, 1, 1), (3, 3, 3), (9, 9, 1), (7, 12, 5), (30, 30, 30)]:
        a, b, x = rng.normal(size=(m, p)), rng.normal(size=(p, n)), rng.normal(size=p)
        np.testing.assert_allclose(dense.matmul(a, b), a @ b, rtol=1e-13, atol=1e-13)
        np.testing.assert_allclose(dense.matvec(a, x), a @ x, rtol=1e-13, atol=1e-13)
        assert dense.norm2(x) == pytest.approx(float(np.linalg.norm(x)), rel=1e-15)
    # the fixed order: component i is ((a_i0 x_0 + a_i1 x_1) + a_i2 x_2)
    a, x = rng.normal(size=(2, 3)), rng.normal(size=3)
    assert dense.matvec(a, x)[1] == ((0.0 + a[1, 0] * x[0]) + a[1, 1] * x[1]) + a[1, 2] * x[2]


@pytest.mark.parametrize(("m", "n", "r"), [(6, 6, 6), (9, 9, 6), (8, 5, 5), (5, 8, 5), (12, 9, 4), (4, 4, 0)])
def test_lstsq_is_numpys_minimum_norm_solution(m: int, n: int, r: int) -> None:
    rng = np.random.default_rng(100 * m + 10 * n + r)
    for _ in range(20):
        a = _rank_deficient(rng, m, n, r) if r else np.zeros((m, n))
        b = rng.normal(size=m)
        x = dense.lstsq(a, b, 1e-12)
        ref = np.linalg.lstsq(a, b, rcond=1e-12)[0]
        scale = max(float(np.abs(ref).max()), 1.0)
        np.testing.assert_allclose(x, ref, rtol=0, atol=1e-9 * scale)


def test_null_space_spans_what_numpys_svd_gives() -> None:
    rng = np.random.default_rng(7)
    for m, n, r in [(9, 6, 6), (9, 6, 3), (6, 9, 6), (9, 9, 5), (3, 3, 0)]:
        a = _rank_deficient(rng, m, n, r) if r else np.zeros((m, n))
        nb = dense.null_space(a, 1e-10)
        _, sv, vt = np.linalg.svd(a, full_matrices=True)
        rank = int(np.sum(sv > 1e-10 * sv[0])) if sv.size and sv[0] > 0 else 0
        ref = vt[rank:].T
        assert nb.shape == ref.shape == (n, n - r)
        np.testing.assert_allclose(nb.T @ nb, np.eye(n - r), atol=1e-13)
        np.testing.assert_allclose(nb @ nb.T, ref @ ref.T, atol=1e-10)  # the same subspace
        np.testing.assert_allclose(a @ nb, 0.0, atol=1e-10 * max(float(np.abs(a).max()), 1.0))


# The reference's Python-path solvers on fixed problems, and (with the shared data) SP1 test 632
# — a robust stand whose reference trajectory differed between the Haswell and SkylakeX kernels
# before this module — printed as hashes.
PROBE = r"""
import hashlib, json, sys, tempfile
from pathlib import Path
import numpy as np
from pbr_xval.reference import cone, dense, pivoting, selection

h = lambda *a: hashlib.sha256(b"".join(np.ascontiguousarray(x, dtype=np.float64).tobytes() for x in a)).hexdigest()
rng = np.random.default_rng(5)
out = {}
J = rng.normal(size=(6, 9))  # three contacts, rank 6: a rock's impact on its pedestal
A = dense.matmul(dense.matmul(J.T.copy(), np.diag(rng.uniform(0.5, 2.0, 6))), J)  # inputs without BLAS too
A = 0.5 * (A + A.T)
b = rng.normal(size=9)
b[0::3] = -np.abs(b[0::3])  # pressed into the pedestal
res = cone.solve_friction_cone(A, b, 0.6)
out["cone"] = h(res.f, res.a) + f" {res.method} {res.iterations}"
out["polish"] = h(cone._mode_polish(A, b, res.f + 1e-3, np.full(3, 0.6)))
M = A[0::3, 0::3] + 1e-3 * np.eye(3)
for method in ("lemke", "dantzig"):
    r = pivoting.solve_lcp(M, b[0::3], method=method)
    out[method] = h(r.z, r.w)
Jn = rng.normal(size=(3, 5))  # five contacts, rank 3: many solutions
r = selection.solve_lcp_min_norm(dense.matmul(Jn.T.copy(), Jn), -np.abs(rng.normal(size=5)), reference=np.abs(rng.normal(size=5)))
out["min_norm_method"] = r.method
out["min_norm"] = h(r.z, r.w)
out["numpy_lstsq"] = h(np.linalg.lstsq(A, b, rcond=1e-12)[0], np.linalg.inv(A[:3, :3]))
if len(sys.argv) > 1:
    sys.path.insert(0, sys.argv[1])
    import reference_campaign as rc
    from pbr_xval.runner import run_scene
    from pbr_xval.scenario import load_scenario
    from pbr_xval.validation.campaign import Baseline, load_campaign
    from pbr_xval.validation.execution import prepare_motions
    scn = load_scenario(Path(sys.argv[1]).parent / "examples" / "validation" / "sp1.toml")
    camp = load_campaign(Path(sys.argv[2]), specimen=1).select(tests=["632"])
    motions = prepare_motions(camp, Baseline(), Path(tempfile.mkdtemp()))
    tr = run_scene(rc._scene(scn, motions["632"]), "reference")
    d = tr.diagnostics
    out["sp1_632"] = h(tr.t, tr.com, tr.quat, tr.omega) + f" toppled={tr.toppled} impacts={d['impacts']}"
print(json.dumps(out))
"""

#: the AVX-512 loops NumPy 2 dispatches to; switched off, it runs what an AVX2 machine runs
NPY_AVX512 = "X86_V4 AVX512_ICL AVX512_SPR"
ROOT = Path(__file__).resolve().parents[2]
SHARED_DATA = Path(os.environ.get("PBR_XVAL_SHARED_DATA") or ROOT.parent / "shared" / "data")


def _probe(args: list[str], coretype: str | None, npy_off: str | None = None) -> dict[str, str]:
    env = blas_kernel_env(coretype, npy_off)
    res = subprocess.run(
        [sys.executable, "-c", PROBE, *args], env=env, capture_output=True, text=True, timeout=600
    )
    assert res.returncode == 0, res.stderr[-3000:]
    return dict(json.loads(res.stdout.strip().splitlines()[-1]))


@pytest.mark.slow
def test_reference_is_the_same_under_every_avx2_blas_kernel() -> None:
    """The reference's Python-path solvers, and SP1 632's whole run when the shared data is
    there, under OpenBLAS's Haswell kernels, its SkylakeX kernels (on an AVX-512 CPU) and with
    NumPy's AVX-512 loops off: identical bytes. (Under the AVX-only Sandybridge kernels a scanned
    rock's settle pose differs in its last bits for every engine: docs/validation.md, "Machine
    dependence".)"""
    campaign = SHARED_DATA / "shake_table"
    args = [str(ROOT / "benchmarks"), str(campaign)] if (campaign / "experiments.csv").is_file() else []
    here = _probe(args, "Haswell")
    variants = {"no AVX-512 in NumPy": _probe(args, "Haswell", NPY_AVX512)}
    if cpu_has("avx512f"):
        variants["SkylakeX"] = _probe(args, "SkylakeX")
    old = {"Sandybridge": _probe([], "Sandybridge")}  # the solvers alone: no scanned rock
    # the probe can tell the kernels apart: LAPACK's lstsq or inverse differs somewhere
    assert len({r["numpy_lstsq"] for r in [here, *variants.values(), *old.values()]}) > 1
    for name, r in {**variants, **old}.items():
        for key in ("cone", "polish", "lemke", "dantzig", "min_norm"):
            assert r[key] == here[key], (name, key)
    if not args:
        pytest.skip(f"shared shake-table data not found ({campaign}): the solvers checked, SP1 632 not run")
    assert "toppled=False" in here["sp1_632"]
    for name, r in variants.items():
        assert r["sp1_632"] == here["sp1_632"], name
