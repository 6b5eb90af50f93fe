"""The compiled kernel of the reference solver (``pbr_xval.reference.kernel``).

References: scipy's Qhull for the support hull; statics of a rigid box (Newton–Euler, worked
by hand) for the active-set resting solve; the NumPy stepping path for the compiled step; the
unreduced contact set for the support-hull reduction.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import ConvexHull

from pbr_xval import conformance as conf
from pbr_xval.reference import kernel
from pbr_xval.runner import run_scene
from pbr_xval.scene import compile_scene

from .conftest import assert_same_run

G = 9.81
MASS = 460.8  # 2400 kg/m³ · 0.4 · 0.4 · 1.2 m³
HALF = np.array([0.2, 0.2, 0.6])
INERTIA = (
    MASS
    / 3.0
    * np.diag([HALF[1] ** 2 + HALF[2] ** 2, HALF[0] ** 2 + HALF[2] ** 2, HALF[0] ** 2 + HALF[1] ** 2])
)
CORNERS = np.array([[sx * HALF[0], sy * HALF[1], -HALF[2]] for sx in (1, -1) for sy in (1, -1)])


# ----------------------------------------------------------------------------- support hull
def _frame(rng: np.random.Generator) -> np.ndarray:
    q, _ = np.linalg.qr(rng.standard_normal((3, 3)))
    return q


@pytest.mark.parametrize("seed", range(20))
def test_support_hull_matches_qhull_on_planar_sets(seed: int) -> None:
    """Coplanar contact sets in a random plane: the kept nodes are Qhull's hull vertices
    (interior nodes and nodes inside hull edges dropped)."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(4, 60))
    uv = rng.uniform(-0.3, 0.3, (n, 2))
    if seed % 2:  # points on the edges of a square: collinear with its corners
        t = rng.uniform(-0.3, 0.3, 6)
        uv = np.vstack(
            [uv, [[0.4, 0.4], [-0.4, 0.4], [-0.4, -0.4], [0.4, -0.4]], np.column_stack([t, np.full(6, 0.4)])]
        )
    q = _frame(rng)
    nodes = np.column_stack([uv, np.zeros(len(uv))]) @ q.T + rng.uniform(-1, 1, 3)
    idx = rng.permutation(len(nodes))[: len(nodes)]
    kept = kernel.support_hull(nodes, np.sort(idx), 1e-9)
    ref = np.sort(ConvexHull(uv).vertices)
    np.testing.assert_array_equal(kept, ref)


def test_support_hull_keeps_nonplanar_and_small_sets() -> None:
    rng = np.random.default_rng(1)
    nodes = rng.uniform(-1, 1, (12, 3))
    idx = np.arange(12)
    np.testing.assert_array_equal(kernel.support_hull(nodes, idx, 1e-9), idx)  # 3-D: every node
    np.testing.assert_array_equal(kernel.support_hull(nodes, idx[:3], 1e-9), idx[:3])
    line = np.outer(rng.uniform(-1, 1, 7), [1.0, 2.0, -0.5])  # collinear: the two extremes
    t = line[:, 0]
    np.testing.assert_array_equal(
        kernel.support_hull(line, np.arange(7), 1e-9), np.sort([t.argmin(), t.argmax()])
    )


# ----------------------------------------------------------------------------- active-set solve
def _box_problem(push: float, spin: float = 0.0) -> tuple[np.ndarray, ...]:
    """Resting box on its four corners, gravity and a horizontal push P (N) at the COM, the
    box spinning at ``spin`` rad/s about the vertical: (A, b, Jacobian (12, 6), inverse mass
    (6, 6), external wrench (6,))."""
    lm = INERTIA @ np.array([0.0, 0.0, spin])
    k = len(CORNERS)
    a_rel = np.array([push / MASS, 0.0, -G])
    A, b, gf, cons = kernel.contact_problem(
        np.eye(3),
        lm,
        np.linalg.inv(INERTIA),
        MASS,
        CORNERS.copy(),
        np.zeros(k, dtype=np.bool_),
        np.zeros((k, 3)),
        np.zeros(3 * k),
        a_rel,
        0.4,
    )
    W = np.zeros((6, 6))
    W[:3, :3] = np.eye(3) / MASS
    W[3:, 3:] = np.linalg.inv(INERTIA)
    wrench = np.array([push, 0.0, -MASS * G, 0.0, 0.0, 0.0])
    return A, b, gf, W, wrench, cons


def test_active_set_resting_box_statics() -> None:
    """At rest under gravity: f_n = m g / 4 per corner (symmetry), no friction, no motion."""
    A, b, gf, W, wrench, _ = _box_problem(0.0)
    ok, f, _, _ = kernel.active_set_solve(
        A, b, np.ones(4, dtype=np.int64), np.full(4, 0.5), 0.0, 5, np.zeros((4, 2)), np.zeros(4, bool)
    )
    assert ok
    F = f.reshape(4, 3)
    np.testing.assert_allclose(F[:, 0], MASS * G / 4, rtol=1e-9)
    np.testing.assert_allclose(F[:, 1:], 0.0, atol=1e-9 * MASS * G)
    np.testing.assert_allclose(W @ (gf.T @ f + wrench), 0.0, atol=1e-9 * G)


def test_active_set_shares_friction_by_cone_radius() -> None:
    """Push P = 0.3 m g at the COM, μ = 0.5. Statics by hand: the corner pairs carry
    m g/2 ± 3P/2 (moment of P at h = 0.6 m over the lever 2b = 0.4 m), i.e. 0.05 m g on the
    unloaded pair, whose cones (0.025 m g) cannot take the plain equal share of friction
    P/4 = 0.075 m g; the friction must be split by load. The box stays at rest."""
    P = 0.3 * MASS * G
    A, b, gf, W, wrench, _ = _box_problem(P)
    ok, f, _, _ = kernel.active_set_solve(
        A, b, np.ones(4, dtype=np.int64), np.full(4, 0.5), 0.0, 5, np.zeros((4, 2)), np.zeros(4, bool)
    )
    assert ok
    F = f.reshape(4, 3)
    np.testing.assert_allclose(W @ (gf.T @ f + wrench), 0.0, atol=1e-9 * G)  # at rest
    assert F[:, 0].sum() == pytest.approx(MASS * G, rel=1e-9)
    assert F[:, 1].sum() == pytest.approx(-P, rel=1e-9)
    pairs = sorted([F[CORNERS[:, 0] > 0, 0].sum(), F[CORNERS[:, 0] < 0, 0].sum()])
    np.testing.assert_allclose(pairs, [MASS * G / 2 - 1.5 * P, MASS * G / 2 + 1.5 * P], rtol=1e-9)
    assert np.all(F[:, 0] >= 0)
    assert np.all(np.hypot(F[:, 1], F[:, 2]) <= 0.5 * F[:, 0] * (1 + 1e-12))


def test_active_set_sticking_with_spin_is_least_squares() -> None:
    """Four sticking corners of a box spinning at 0.01 rad/s: the centripetal accelerations
    of the corners cannot be cancelled by contact forces (not a rigid-body acceleration
    field). The solve must still succeed: forces in the cones, the box's acceleration zero
    up to that centripetal part (|ω|² b√2 = 2.8e-5 m/s²), the corners' left-over tangential
    acceleration that centripetal part."""
    spin = 0.01
    A, b, gf, W, wrench, cons = _box_problem(0.0, spin)
    assert cons == pytest.approx(spin**2 * np.linalg.norm(CORNERS[0]), rel=1e-12)
    ok, f, a, _ = kernel.active_set_solve(
        A, b, np.ones(4, dtype=np.int64), np.full(4, 0.5), 2 * cons, 5, np.zeros((4, 2)), np.zeros(4, bool)
    )
    assert ok
    F = f.reshape(4, 3)
    assert np.all(F[:, 0] > 0)
    assert np.all(np.hypot(F[:, 1], F[:, 2]) <= 1e-6 * F[:, 0])
    cent = spin**2 * np.hypot(HALF[0], HALF[1])
    assert np.abs(W @ (gf.T @ f + wrench)).max() <= 2 * cent
    np.testing.assert_allclose(np.hypot(a[1::3], a[2::3]), cent, rtol=1e-6)


# ----------------------------------------------------------------------------- whole runs
def _housner(amplitude: float, duration: float, azimuth_deg: float = 0.0):
    return compile_scene(
        conf.housner_scenario(
            duration=duration,
            excitation={
                "type": "half_sine",
                "amplitude": amplitude,
                "frequency": 1.0,
                "phase": "housner_uplift",
                "azimuth_deg": azimuth_deg,
            },
        )
    )


def test_compiled_step_equals_numpy_step() -> None:
    """The compiled kernel and the NumPy stepping give the same rocking history (2 s,
    a = 5.6 m/s², impacts included): measured max |Δθ| 2e-14 rad."""
    scene = _housner(5.6, 2.0)
    fast = run_scene(scene, "reference")
    slow = run_scene(scene, "reference", {"compiled": False})
    assert fast.ok and slow.ok
    assert fast.diagnostics["kernel_steps"] > 0.99 * fast.diagnostics["steps"]
    assert slow.diagnostics["kernel_steps"] == 0
    np.testing.assert_array_equal(fast.t, slow.t)
    assert np.abs(fast.rocking_angle() - slow.rocking_angle()).max() <= 1e-10


def test_support_hull_reduction_is_exact() -> None:
    """A 64-node grid base: solving on the support hull of the contact set (4 corners when
    flat, 2 when on an edge) gives the motion of solving on all nodes (measured 3e-12 rad)."""
    scene = _housner(5.6, 2.0)
    grid = {"nodes": "grid", "max_nodes": 64}
    red = run_scene(scene, "reference", grid)
    full = run_scene(scene, "reference", grid | {"support_hull": False})
    assert red.ok and full.ok
    assert red.diagnostics["contacts_max"] == 64
    assert np.abs(red.rocking_angle() - full.rocking_angle()).max() <= 1e-9


# ----------------------------------------------------------------------------- impacts (issue 23)
@pytest.mark.parametrize("seed", range(10))
def test_lcp_unique_is_the_pivoting_solution(seed: int) -> None:
    """A positive definite A_nn (the impact LCP of one to three hull contacts): the enumerated
    solution is Dantzig's (the LCP has exactly one), to round-off."""
    from pbr_xval.reference.pivoting import dantzig

    rng = np.random.default_rng(seed)
    for _ in range(50):
        n = int(rng.integers(1, 7))
        g = rng.standard_normal((n, n))
        M = g @ g.T + 0.1 * np.eye(n)
        q = rng.standard_normal(n)
        ok, z = kernel.lcp_unique(M, q)
        ref = dantzig(M, q)
        assert ok and ref.ok
        np.testing.assert_allclose(z, ref.z, rtol=1e-9, atol=1e-12 * max(1.0, np.abs(ref.z).max()))
        w = M @ z + q
        assert z.min() >= 0 and w.min() >= -1e-9 * np.abs(q).max()


def test_lcp_unique_declines_singular_and_large_problems() -> None:
    """Redundant contacts (a singular A_nn: a selection is needed) and more than
    UNIQUE_MAX_N unknowns go to the pivoting solver with its selection."""
    J = np.array([[1.0, 0.0], [1.0, 0.0], [0.0, 1.0]])  # two coincident contacts
    ok, _ = kernel.lcp_unique(J @ J.T, np.array([-1.0, -1.0, -1.0]))
    assert not ok
    n = kernel.UNIQUE_MAX_N + 1
    ok, _ = kernel.lcp_unique(np.eye(n), -np.ones(n))
    assert not ok


def test_friction_residuals_compiled_equal_numpy() -> None:
    """cone.friction_residuals (compiled) gives the NumPy expressions' values bit for bit."""
    from pbr_xval.reference import cone

    rng = np.random.default_rng(3)
    for t in range(500):
        k = int(rng.integers(1, 9))
        f = rng.standard_normal(3 * k) * 10 ** rng.uniform(-5, 5)
        a = rng.standard_normal(3 * k)
        mu = rng.uniform(0, 1, size=k) if t % 2 else np.full(k, 0.6)
        F, Acc = f.reshape(-1, 3), a.reshape(-1, 3)
        fn, ft, an, at = F[:, 0], F[:, 1:], Acc[:, 0], Acc[:, 1:]
        ftn, atn = np.linalg.norm(ft, axis=1), np.linalg.norm(at, axis=1)
        want = [
            float(max(0.0, -fn.min())),
            float(max(0.0, -an.min())),
            float(np.max(np.abs(fn * an))),
            float(max(0.0, np.max(ftn - mu * fn))),
            float(np.max(np.abs(atn * (mu * fn - ftn)))),
            float(max(0.0, np.max(np.sum(ft * at, axis=1) + ftn * atn))),
        ]
        assert list(cone.friction_residuals(f, a, mu).values()) == want


# ----------------------------------------------------------------------------- many-step path


@pytest.mark.parametrize(
    ("amplitude", "duration", "settings", "azimuth"),
    [
        (5.0, 5.0, {}, 0.0),  # rocks, impacts, settles: held at rest
        (7.0, 3.0, {}, 0.0),  # topples: the recorder stops the run inside a block
        (5.6, 2.0, {"nodes": "grid", "max_nodes": 64}, 0.0),  # culled candidate nodes
        (5.0, 5.0, {}, 45.0),  # rocks on a corner: impacts on three corners, resolved in blocks
    ],
)
def test_step_block_equals_step_by_step(monkeypatch, amplitude, duration, settings, azimuth) -> None:
    """kernel.step_block (engine.BLOCK_STEPS > 0) gives the step-by-step loop's run bit for
    bit: samples, events and every diagnostic but the timings — also when the blocks resolve
    impacts themselves (kernel._block_impact; counted)."""
    from pbr_xval.reference import adapter as ref_engine
    from pbr_xval.reference import dynamics

    in_block = []
    info = dynamics.RigidBodySolver._block_impact_info
    monkeypatch.setattr(
        dynamics.RigidBodySolver,
        "_block_impact_info",
        lambda self, row: in_block.append(1) or info(self, row),
    )
    scene = _housner(amplitude, duration, azimuth)
    blocked = run_scene(scene, "reference", settings)
    if azimuth:
        assert len(in_block) >= 4
    monkeypatch.setattr(ref_engine, "BLOCK_STEPS", 0)
    single = run_scene(scene, "reference", settings)
    assert_same_run(blocked, single)
