"""Issue 23, fifth pass: the per-run and per-step costs cut outside the kernel give the same
answers as the code they replace — the critical-tilt test with α(φ)'s table built once against a
freshly built table, the memoised hull of the side nodes against a fresh convex hull, and a
block's one-pass statistics against the per-segment accounting; and (seventh pass) the memoised
culling bounds."""

from __future__ import annotations

import numpy as np
from scipy.spatial import ConvexHull
from scipy.spatial.transform import Rotation

from pbr_xval import conformance as conf
from pbr_xval.reference import adapter, dynamics, kernel
from pbr_xval.reference.dynamics import Body, Pedestal, RigidBodySolver
from pbr_xval.scene import compile_scene


def test_past_critical_with_the_cached_alpha_table_equals_the_fresh_one() -> None:
    """Scene.past_critical (the recorder's critical-tilt test) reads α(φ) through the table
    StabilityTable builds once; it answers as the interpolation on a freshly built table."""
    import math

    scene = compile_scene(conf.housner_scenario(duration=0.1))
    stab = scene.rock.stability
    xp, fp = np.append(stab.phi, 2 * np.pi), np.append(stab.alpha, stab.alpha[0])

    def fresh(r: np.ndarray) -> bool:
        top = r[:, 2]
        tilt = math.acos(max(-1.0, min(1.0, float(top[2]))))
        if tilt < 1e-9:
            return False
        phi = math.atan2(top[1], top[0]) % (2 * np.pi)
        return tilt >= float(np.interp(phi, xp, fp))

    rng = np.random.default_rng(5)
    # tilts around the critical tilt (~0.2 rad for this block) in every direction, plus none
    rots = [np.eye(3)]
    for _ in range(3000):
        axis = np.array([*rng.normal(size=2), 0.0])
        axis /= np.linalg.norm(axis)
        tilt = rng.uniform(0.0, 0.6)
        spin = Rotation.from_rotvec([0.0, 0.0, rng.uniform(-np.pi, np.pi)])
        rots.append((Rotation.from_rotvec(tilt * axis) * spin).as_matrix())
    answers = [scene.past_critical(r) for r in rots]
    assert answers == [fresh(r) for r in rots]
    assert 500 < sum(answers) < 2500  # both sides of the critical tilt were tried


def test_hull_above_memo_equals_fresh_hull() -> None:
    rng = np.random.default_rng(7)
    v = rng.normal(size=(400, 3))
    hull = v[ConvexHull(v).vertices]
    want = hull[hull[:, 2] > 0.2]
    first = adapter._hull_above(v, 0.2)
    first[:] = 0.0  # a copy: the memo is not changed through it
    again = adapter._hull_above(v, 0.2)
    np.testing.assert_array_equal(again, want)
    assert adapter._hull_above(v, 0.5).shape[0] < want.shape[0]  # the height is in the key
    for _ in range(2 * adapter._HULL_ABOVE_MAX):  # bounded
        adapter._hull_above(rng.normal(size=(30, 3)), 0.0)
    assert len(adapter._HULL_ABOVE) <= adapter._HULL_ABOVE_MAX


def test_cull_tilts_memo_equals_the_computed_bounds() -> None:
    """Issue 23, seventh pass: ``dynamics.cull_tilts`` memoised on the nodes' values — the same
    bounds as the computation (``_cull_tilts``), checked against the closed form on a pair of
    nodes; ε and ``n_ref`` in the key; a copy returned; the memo bounded."""
    rng = np.random.default_rng(11)
    v = rng.uniform(-0.5, 0.5, (300, 3))
    want = dynamics._cull_tilts(v.copy(), 1e-5, 64)
    first = dynamics.cull_tilts(v, 1e-5)
    np.testing.assert_array_equal(first, want)
    first[:] = 0.0  # a copy: the memo is not changed through it
    np.testing.assert_array_equal(dynamics.cull_tilts(v, 1e-5), want)
    assert not np.array_equal(dynamics.cull_tilts(v, 1e-2), want)  # ε is in the key
    assert not np.array_equal(dynamics.cull_tilts(v, 1e-5, n_ref=4), want)  # so is n_ref
    # two nodes 0.1 m apart, the upper one straight above: arccos(3ε/|Δ|) − 0 for it
    pair = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.1]])
    np.testing.assert_allclose(dynamics.cull_tilts(pair, 1e-3)[1], np.arccos(0.03), rtol=1e-12)
    for _ in range(2 * dynamics._CULL_TILTS_MAX):  # bounded
        dynamics.cull_tilts(rng.normal(size=(20, 3)), 1e-5)
    assert len(dynamics._CULL_TILTS) <= dynamics._CULL_TILTS_MAX


def _solver() -> RigidBodySolver:
    scene = compile_scene(conf.housner_scenario(duration=0.1))
    nodes = np.asarray(scene.basal_nodes, dtype=float) - np.asarray(scene.rock.com, dtype=float)
    body = Body(float(scene.rock.mass), np.asarray(scene.rock.inertia, dtype=float), nodes)
    settings = adapter.ReferenceEngine().resolve_settings(None)
    return RigidBodySolver(
        body, Pedestal("plane"), lambda t: np.array([0.0, 0.0, -9.81]), 0.6, 0.6, 0.0, settings
    )


def test_account_block_impacts_equals_segments() -> None:
    """One pass over a block with impacts at rows 0, 4 and 9 gives the lists and counts of
    account_block on the segments between them with each impact's statistics in between."""
    rng = np.random.default_rng(3)
    m = 12
    info = np.zeros((m, kernel.N_INFO))
    info[:, kernel.I_ITS] = rng.integers(1, 6, m)
    info[:, kernel.I_SOLVES] = rng.integers(1, 5, m)
    info[:, kernel.I_FAST] = info[:, kernel.I_SOLVES]
    info[:, kernel.I_CONV] = rng.integers(0, 2, m)
    info[:, kernel.I_NRES] = rng.integers(0, 2, m)
    for col in (kernel.I_SIG_F, kernel.I_SIG_A, kernel.I_COMPL, kernel.I_CONE, kernel.I_GMIN):
        info[:, col] = rng.normal(size=m)
    imps = np.zeros((m, kernel.N_IMP))
    for j in (0, 4, 9):
        imps[j] = rng.normal(size=kernel.N_IMP)
        imps[j, kernel.J_FLAG] = 1.0
        imps[j, kernel.J_REVERTED] = 1.0 if j == 4 else 0.0
    one, seg = _solver(), _solver()
    got = one.account_block_impacts(info, imps)
    want = []
    a = 0
    for j in (0, 4, 9):
        if j > a:
            seg.account_block(info[a:j])
        want.append(seg._block_impact_info(imps[j]))
        a = j
    seg.account_block(info[a:])
    assert got == want
    for name in ("signorini_f", "signorini_a", "complementarity", "cone"):
        assert getattr(one.stats, name) == getattr(seg.stats, name)
    for name in ("kernel_steps", "lcp_solves", "lcp_fast_path", "iterations_total", "iterations_max"):
        assert getattr(one.stats, name) == getattr(seg.stats, name)
    assert one.stats.iteration_nonconverged == seg.stats.iteration_nonconverged
    assert one.stats.selection_reverted == seg.stats.selection_reverted == 1
    assert one.last_gmin == seg.last_gmin


def test_compiled_load_equals_direct_scalar_calls() -> None:
    """The load of the steps outside the blocks (adapter._compiled_load) is the engine's
    g − a(t) for a scalar t bit for bit (signed zeros included), as load_direct gave it."""
    from pbr_xval.motion.base import Excitation3D, ScaledMotion
    from pbr_xval.motion.pulses import OneSine
    from pbr_xval.motion.records import Record

    rng = np.random.default_rng(11)
    rec = Record(3.0 * np.sin(np.linspace(0.0, 12.0, 300)) + 0.5 * rng.standard_normal(300), 0.01, 0.1)
    g = 9.81
    for exc in (
        Excitation3D(rec, azimuth=0.7),
        Excitation3D(OneSine(1.3, 1.0), azimuth=0.0, vertical=ScaledMotion(OneSine(2.0, 3.0), -0.5)),
    ):
        spec = adapter.compiled_excitation(exc, g)
        assert spec is not None
        ts = np.concatenate([rng.uniform(-0.1, exc.duration + 0.3, 2000), [0.0, 0.1, exc.duration]])
        for t in ts.tolist():
            want = np.array([0.0, 0.0, -g]) - np.asarray(exc.acceleration(t), dtype=float)
            assert adapter._compiled_load(spec, t).tobytes() == want.tobytes()
