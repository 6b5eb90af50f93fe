"""Curved-base (rolling) block, science.md §2 and §8."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from pbr_xval.analytical.curved_base import (
    CurvedBaseLamina,
    curved_base_rhs,
    energy,
    simulate_curved_base,
)
from pbr_xval.analytical.rocking import TwoPivotBody, rocking_rhs, simulate_rocking

G = 9.81
ECHO = CurvedBaseLamina(H=14.73, r=3.62, h=3.38)
SMALL = CurvedBaseLamina(H=1.473, r=0.362, h=0.338)  # Echo-like shape at 1/10 scale: faster rocking


def polygon_props(poly: np.ndarray) -> tuple[float, float, float, float]:
    """Area, centroid (x, z) and polar second moment about the centroid of a closed polygon (shoelace)."""
    x, z = poly[:-1, 0], poly[:-1, 1]
    x1, z1 = poly[1:, 0], poly[1:, 1]
    cr = x * z1 - x1 * z
    area = cr.sum() / 2
    cx = ((x + x1) * cr).sum() / (6 * area)
    cz = ((z + z1) * cr).sum() / (6 * area)
    jxx = ((z * z + z * z1 + z1 * z1) * cr).sum() / 12
    jzz = ((x * x + x * x1 + x1 * x1) * cr).sum() / 12
    return area, cx, cz, jxx + jzz - area * (cx * cx + cz * cz)


@pytest.mark.parametrize(
    "body",
    [
        ECHO,
        CurvedBaseLamina(14.73, 1.81, 3.38),
        CurvedBaseLamina(14.73, 7.24, 3.38),
        CurvedBaseLamina(2.0, 0.0, 1.0),
        CurvedBaseLamina(3.0, 1.0, 0.0),
    ],
)
def test_mass_properties_vs_polygon(body: CurvedBaseLamina) -> None:
    poly = body.outline(4000)
    assert np.allclose(poly[0], poly[-1])
    area, cx, cz, jg = polygon_props(poly)
    assert area > 0  # counter-clockwise
    assert body.area == pytest.approx(area, rel=1e-6)
    assert cx == pytest.approx(0.0, abs=1e-9)
    assert body.y_G0 == pytest.approx(cz, rel=1e-6)
    assert body.polar_moment_area == pytest.approx(jg, rel=1e-6)
    rho = body.density * body.depth
    assert body.mass == pytest.approx(rho * area, rel=1e-6)
    assert body.I_G == pytest.approx(rho * jg, rel=1e-6)


def test_echo_geometry_numbers() -> None:
    b = ECHO
    assert b.W == pytest.approx(10.62)
    # computed: y_G0 = 7.6095 m (corners removed raise it above H/2), θ* = 22.96° (notes: "about 25°")
    assert b.y_G0 == pytest.approx(7.6095, abs=1e-4)
    assert math.degrees(b.critical_angle) == pytest.approx(22.958, abs=1e-3)
    assert math.tan(b.critical_angle) == pytest.approx((b.h / 2) / (b.y_G0 - b.r), rel=1e-14)
    assert b.uplift_accel(G) == pytest.approx(G * (b.h / 2) / b.y_G0, rel=1e-14)
    # COM above the contact point at θ*: x_G − x_C = 0, i.e. z_G is maximal there
    th = b.critical_angle
    x_contact = b.h / 2 + b.r * th
    assert float(b.x_com(th)) == pytest.approx(x_contact, abs=1e-12)
    zs = b.z_com(np.array([th - 1e-4, th, th + 1e-4]))
    assert zs[1] > zs[0] and zs[1] > zs[2]


def test_uplift_under_ramp() -> None:
    b = SMALL
    k = 2.0
    a_up = b.uplift_accel(G)
    sol = simulate_curved_base(b, lambda t: -k * t, a_up / k + 0.05, rtol=1e-8, atol=1e-10)
    up = sol.events[0]
    assert up["kind"] == "uplift" and up["side"] == "right"
    assert k * up["t"] == pytest.approx(a_up, rel=1e-6)
    assert sol.theta[-1] > 0


def test_rectangle_limit_jump_ratio() -> None:
    rect = CurvedBaseLamina(H=1.2, r=0.0, h=0.4)
    alpha = math.atan2(0.2, 0.6)
    assert rect.impact_ratio() == pytest.approx(1 - 1.5 * math.sin(alpha) ** 2, abs=1e-12)
    assert rect.impact_ratio() == pytest.approx(0.85, abs=1e-12)
    for r in (1e-3, 1e-5, 1e-7):  # converges as r → 0 with W = h + 2r fixed
        b = CurvedBaseLamina(H=1.2, r=r, h=0.4 - 2 * r)
        assert abs(b.impact_ratio() - 0.85) < 10 * r
    assert rect.critical_angle == pytest.approx(alpha, rel=1e-14)
    assert rect.uplift_accel(G) == pytest.approx(G * math.tan(alpha), rel=1e-14)


def test_small_angle_rhs_vs_rigid_rectangle() -> None:
    rb = TwoPivotBody.rectangle(0.2, 0.6)
    for r in (1e-5, 1e-9):
        cb = CurvedBaseLamina(H=1.2, r=r, h=0.4 - 2 * r)
        for a in (-4.0, -10.0, 2.0):
            for th, om in ((1e-9, 0.0), (0.05, 0.3), (0.2, -0.7)):
                ref = rocking_rhs(rb, th, "right", a, G)
                got = curved_base_rhs(cb, th, om, a, G)
                assert got == pytest.approx(ref, rel=50 * r + 1e-10, abs=50 * r)
                # mirror symmetry
                assert curved_base_rhs(cb, -th, -om, -a, G) == pytest.approx(-got, rel=1e-12)


def test_r0_curved_base_equals_rocking_block() -> None:
    """With r = 0 the whole hybrid simulation must reproduce the Housner rectangle (same trajectory)."""
    cb = CurvedBaseLamina(H=1.2, r=0.0, h=0.4, depth=0.4, density=2400.0)
    rb = TwoPivotBody.rectangle(0.2, 0.6, mass=cb.mass)
    amp, w = 5.0, 2 * math.pi
    phi = math.asin(G / 3 / amp)
    t_p = (math.pi - phi) / w

    def acc(t: float) -> float:
        return amp * math.sin(w * t + phi) if t <= t_p else 0.0

    s1 = simulate_curved_base(cb, acc, 2.0, breakpoints=[t_p], rtol=1e-10, atol=1e-12)
    s2 = simulate_rocking(rb, acc, 2.0, breakpoints=[t_p], rtol=1e-10, atol=1e-12)
    assert s1.n_impacts == s2.n_impacts > 0
    t_cmp = np.linspace(0.0, 2.0, 401)
    np.testing.assert_allclose(np.interp(t_cmp, s1.t, s1.theta), np.interp(t_cmp, s2.t, s2.theta), atol=1e-8)
    assert s1.peak_theta_ratio == pytest.approx(s2.peak_theta_ratio, rel=1e-8)


@pytest.mark.parametrize("body", [ECHO, SMALL])
def test_free_rolling_energy_conservation(body: CurvedBaseLamina) -> None:
    sol = simulate_curved_base(body, lambda t: 0.0, 5.0, theta0=0.5 * body.critical_angle)
    assert not sol.toppled
    imps = [e for e in sol.events if e["kind"] == "impact"]
    assert len(imps) >= 1
    e = energy(body, sol.theta, sol.omega, G)
    e_rest = body.mass * G * body.y_G0
    edges = [0.0, *[ev["t"] for ev in imps], np.inf]
    drifts = []
    for a, b in itertools.pairwise(edges):
        seg = (sol.t >= a) & (sol.t < b)
        if seg.sum() > 2:
            drifts.append(np.ptp(e[seg]) / abs(e[seg][0]))
            # stricter: relative to the energy above the resting level
            assert np.ptp(e[seg]) <= 1e-8 * (e[seg][0] - e_rest) + 1e-12 * e_rest
    assert max(drifts) < 1e-8
    # impacts: energy drops by the ratio² of the rotational part at θ = 0
    for ev in imps:
        assert ev["omega_plus"] / ev["omega_minus"] == pytest.approx(body.impact_ratio(), rel=1e-12)


def test_constant_acceleration_effective_energy() -> None:
    """Under a constant a the pseudo-force is conservative: ½Iθ̇² + m g z_G + m a x_G is constant while rolling."""
    b = SMALL
    a = -1.5 * b.uplift_accel(G)
    sol = simulate_curved_base(b, lambda t: a, 0.8, rtol=1e-11, atol=1e-13)
    assert sol.events[0]["kind"] == "uplift" and sol.events[0]["side"] == "right"
    moving = sol.t > sol.events[0]["t"]
    if sol.toppled:
        moving &= sol.t <= sol.toppled_at
    assert moving.sum() > 50
    ee = energy(b, sol.theta, sol.omega, G) + b.mass * a * sol.x_com
    ee0 = b.mass * G * b.y_G0  # at uplift: θ = 0, θ̇ = 0, x_G = 0
    assert np.max(np.abs(ee[moving] - ee0)) < 1e-9 * ee0


def test_h0_no_flat() -> None:
    b = CurvedBaseLamina(H=3.0, r=1.0, h=0.0)
    assert b.uplift_accel(G) == 0.0
    assert b.impact_ratio() == pytest.approx(1.0, abs=1e-14)
    assert b.critical_angle == 0.0  # COM above the arc centre: unstable equilibrium
    sol = simulate_curved_base(
        b, lambda t: -0.01 if t > 0.1 else 0.0, 0.3, breakpoints=[0.1], rtol=1e-8, atol=1e-10
    )
    assert sol.events[0]["kind"] == "uplift" and sol.events[0]["t"] == pytest.approx(0.1, abs=1e-9)
    assert sol.toppled and sol.peak_com_disp == 5.0
    sol2 = simulate_curved_base(
        b,
        lambda t: -0.01 if t > 0.1 else 0.0,
        0.5,
        breakpoints=[0.1],
        topple_angle=0.5 * math.pi,
        rtol=1e-8,
        atol=1e-10,
    )
    assert not sol2.toppled and sol2.theta[-1] > 0


def sawtooth(pgv: float, period: float):
    """Ground velocity 0 → PGV over T/2 and back to 0 at T (s = 0.5): a = +2PGV/T then −2PGV/T."""
    a = 2 * pgv / period

    def acc(t: float) -> float:
        return a if t < period / 2 else (-a if t < period else 0.0)

    return acc, [period / 2, period]


def test_sawtooth_topples_large_not_small() -> None:
    period = 2.0
    acc, bps = sawtooth(5.0, period)
    big = simulate_curved_base(ECHO, acc, 10.0, breakpoints=bps, rtol=1e-8, atol=1e-10, dense_dt=1e-2)
    assert big.toppled and big.peak_com_disp == 5.0
    assert big.events[0]["side"] == "left"  # ground accelerates to +x first → rolls to θ < 0
    acc, bps = sawtooth(3.0, period)
    small = simulate_curved_base(ECHO, acc, 10.0, breakpoints=bps, rtol=1e-8, atol=1e-10, dense_dt=1e-2)
    assert not small.toppled
    assert 0.2 < small.peak_theta_ratio < 1.0
    assert 0.0 < small.peak_com_disp < 5.0
    assert small.peak_com_disp == pytest.approx(np.max(np.abs(small.x_com)), rel=1e-12)
    assert small.x_com.shape == small.t.shape == small.z_com.shape
