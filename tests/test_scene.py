"""Scene compilation: mass properties, stability facts, excitation wiring."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from pbr_xval.conformance import housner_scenario, notched_scenario
from pbr_xval.motion.records import Record, write_at2
from pbr_xval.runner import run_scene
from pbr_xval.scenario import scenario_from_dict
from pbr_xval.scene import compile_scene


def test_box_mass_properties_closed_form() -> None:
    scene = compile_scene(housner_scenario())
    m = 2400.0 * 0.4 * 0.4 * 1.2
    assert scene.rock.mass == pytest.approx(m, rel=1e-12)
    ixx = m * (0.4**2 + 1.2**2) / 12
    izz = m * (0.4**2 + 0.4**2) / 12
    assert np.allclose(np.diag(scene.rock.inertia), [ixx, ixx, izz], rtol=1e-12)
    assert np.allclose(scene.rock.com, [0, 0, 0.6], atol=1e-12)
    assert scene.alpha == pytest.approx((math.atan(1 / 3), math.atan(1 / 3)), abs=1e-12)
    assert scene.uplift_accel() == pytest.approx(9.81 / 3, rel=1e-12)


def test_notched_block_mass_properties_closed_form() -> None:
    scene = compile_scene(notched_scenario())
    # three boxes: feet 0.1 x 0.4 x 0.3 at x = ±0.15, slab 0.4 x 0.4 x 0.9 above
    rho = 2400.0
    parts = [(0.1, 0.4, 0.3, -0.15, 0.15), (0.1, 0.4, 0.3, 0.15, 0.15), (0.4, 0.4, 0.9, 0.0, 0.75)]
    m = sum(rho * a * b * c for a, b, c, _, _ in parts)
    zc = sum(rho * a * b * c * z for a, b, c, _, z in parts) / m
    iyy = sum(rho * a * b * c * ((a * a + c * c) / 12 + x * x + (z - zc) ** 2) for a, b, c, x, z in parts)
    assert scene.rock.mass == pytest.approx(m, rel=1e-9) and m == pytest.approx(403.2)
    assert scene.rock.com[2] == pytest.approx(zc, rel=1e-9) and zc - 0.6 == pytest.approx(0.0643, abs=1e-4)
    assert scene.rock.inertia[1, 1] == pytest.approx(iyy, rel=1e-9)
    pm = scene.planar_model()
    assert pm.right == pytest.approx((0.2, -zc)) and pm.left == pytest.approx((-0.2, -zc))


def test_box_shaken_along_diagonal_is_not_planar() -> None:
    from pbr_xval.engine import NotApplicable

    scn = housner_scenario(excitation={"type": "half_sine", "amplitude": 5.0, "azimuth_deg": 45.0})
    with pytest.raises(NotApplicable, match="corner"):
        compile_scene(scn).planar_model()


def test_yawed_box_rocks_like_unyawed_when_shaken_along_its_axis() -> None:
    a = run_scene(compile_scene(housner_scenario(duration=1.0)), "housner")
    scn = housner_scenario(
        duration=1.0,
        rock={"shape": "box", "half_extents": [0.2, 0.2, 0.6], "density": 2400.0, "yaw_deg": 30.0},
        excitation={"type": "half_sine", "amplitude": 5.0, "phase": "housner_uplift", "azimuth_deg": 30.0},
    )
    b = run_scene(compile_scene(scn), "housner")
    assert np.allclose(a.rocking_angle(), b.rocking_angle(), atol=1e-12)


def test_record_excitation_scaled_to_target_pga(tmp_path: Path) -> None:
    t = np.arange(0, 2.0, 0.005)
    acc = 0.3 * 9.80665 * np.sin(2 * np.pi * 1.5 * t) * np.exp(-t)
    write_at2(Record(acc, 0.005), tmp_path / "rec.AT2")
    scn = scenario_from_dict(
        {
            "name": "rec",
            "duration": 3.0,
            "rock": {"shape": "box", "half_extents": [0.2, 0.2, 0.6], "density": 2400.0},
            "excitation": {"type": "record", "path": "rec.AT2", "target_pga": 4.0},
        },
        source=tmp_path / "s.toml",
    )
    scene = compile_scene(scn)
    a = scene.excitation.horizontal.sample(0.001, 2.0)[1]
    assert np.max(np.abs(a)) == pytest.approx(4.0, rel=1e-9)
    traj = run_scene(scene, "housner")
    assert traj.ok and traj.rocking_angle().min() < 0  # 4.0 > 3.27: it rocks


def test_free_rocking_initial_tilt() -> None:
    scene = compile_scene(housner_scenario(excitation={"type": "none"}, initial={"theta_over_alpha": 0.5}))
    assert scene.theta0 == pytest.approx(0.5 * math.atan(1 / 3))
