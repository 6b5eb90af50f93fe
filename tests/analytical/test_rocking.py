"""Two-pivot rocking solver vs independent anchors (science.md §0, §1; engines notes §1 and §4)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pbr_xval.analytical.closed_form import (
    free_rocking_period,
    housner_amplitude_sequence,
    makris_roussos_halfsine,
    rectangular_pulse_threshold,
)
from pbr_xval.analytical.rocking import TwoPivotBody, rocking_rhs, simulate_rocking, theta_ratio

G = 9.81
BLOCK = TwoPivotBody.rectangle(0.2, 0.6, mass=460.8)
ALPHA = math.atan2(0.2, 0.6)


def halfsine(amp: float, uplift: float, omega: float = 2 * math.pi):
    """a(t) = A sin(ωt + φ) with A sin φ = ``uplift``, zero after (π − φ)/ω; returns (accel, t_pulse_end)."""
    phi = math.asin(uplift / amp)
    t_p = (math.pi - phi) / omega
    return (lambda t: amp * math.sin(omega * t + phi) if t <= t_p else 0.0), t_p


def bisect(topples, lo: float, hi: float, tol: float) -> float:
    assert not topples(lo) and topples(hi)
    while hi - lo > tol:
        mid = 0.5 * (lo + hi)
        if topples(mid):
            hi = mid
        else:
            lo = mid
    return 0.5 * (lo + hi)


# ---------------------------------------------------------------------------------------------------------------
# body geometry
# ---------------------------------------------------------------------------------------------------------------


def test_rectangle_properties() -> None:
    b = BLOCK
    for side in ("left", "right", 1, -1):
        assert b.R(side) == pytest.approx(0.632456, abs=1e-6)
        assert b.alpha(side) == pytest.approx(ALPHA, rel=1e-14)
        assert b.I_O(side) == pytest.approx(4 / 3 * b.mass * b.R(side) ** 2, rel=1e-14)
        assert b.p(side, G) == pytest.approx(math.sqrt(3 * G / (4 * b.R(side))), rel=1e-14)
        assert b.uplift_accel(side, G) == pytest.approx(G / 3, rel=1e-14)
        assert b.impact_ratio(side) == pytest.approx(1 - 1.5 * math.sin(ALPHA) ** 2, abs=1e-14)
    # any slenderness: ratio = 1 − 1.5 sin²α exactly
    for bb, hh in ((0.1, 1.0), (0.5, 0.5), (0.3, 2.0)):
        r = TwoPivotBody.rectangle(bb, hh)
        assert r.impact_ratio("left") == pytest.approx(1 - 1.5 * math.sin(math.atan2(bb, hh)) ** 2, abs=1e-14)


def test_sign_convention() -> None:
    # positive a_g above the uplift level at θ = 0⁻ drives θ negative (notes: θ̈ = −0.82 rad/s² at a_g = 4)
    acc = rocking_rhs(BLOCK, -0.0, "left", 4.0, G)
    assert acc == pytest.approx(-0.82, abs=0.01)
    assert rocking_rhs(BLOCK, 0.0, "right", -4.0, G) == pytest.approx(0.82, abs=0.01)
    sol = simulate_rocking(BLOCK, lambda t: 4.0, 0.2, dense_dt=1e-2)
    assert sol.events[0]["kind"] == "uplift" and sol.events[0]["side"] == "left"
    assert sol.events[0]["t"] == pytest.approx(0.0, abs=1e-12)
    assert np.all(sol.theta <= 0) and sol.theta[-1] < 0


# ---------------------------------------------------------------------------------------------------------------
# half-sine thresholds
# ---------------------------------------------------------------------------------------------------------------


def _topples_halfsine(body: TwoPivotBody, variant: str, amp: float, uplift: float) -> bool:
    acc, t_p = halfsine(amp, uplift)
    sol = simulate_rocking(
        body, acc, 2.5, breakpoints=[t_p], variant=variant, rtol=1e-9, atol=1e-11, dense_dt=1e-2
    )
    return sol.toppled


def test_halfsine_trajectory_matches_notes() -> None:
    # engines notes §1: at a = 5.0 the ODE gives θmin/α = −0.3474 and the block returns at t = 0.798 s
    acc, t_p = halfsine(5.0, G * math.tan(ALPHA))
    sol = simulate_rocking(BLOCK, acc, 1.0, breakpoints=[t_p])
    assert not sol.toppled
    assert sol.peak_theta_ratio == pytest.approx(0.3474, abs=1e-4)
    first_impact = next(e for e in sol.events if e["kind"] == "impact")
    assert first_impact["t"] == pytest.approx(0.798, abs=1e-3)


def test_halfsine_exact_threshold() -> None:
    thr = bisect(lambda a: _topples_halfsine(BLOCK, "exact", a, G * math.tan(ALPHA)), 5.55, 5.75, 5e-4)
    assert thr == pytest.approx(5.6381, rel=5e-4)  # notes 5.6381; published 5.62–5.64
    assert 5.62 <= thr <= 5.64


def test_halfsine_linearized_threshold_matches_makris_roussos() -> None:
    p = BLOCK.p("right", G)
    ref = makris_roussos_halfsine(ALPHA, p, 2 * math.pi, G)
    thr = bisect(lambda a: _topples_halfsine(BLOCK, "linearized", a, G * ALPHA), 5.35, 5.55, 2e-3)
    assert thr == pytest.approx(ref, rel=2e-3)


def test_rectangular_pulse_linearized_threshold() -> None:
    # Housner's rectangular pulse, right side (a_g = −A for t < t1): a/(gα) = 1/(1 − e^{−p t1})
    t1 = 0.3
    p = BLOCK.p("right", G)
    ref = rectangular_pulse_threshold(ALPHA, p, t1, G)

    def topples(amp: float) -> bool:
        sol = simulate_rocking(
            BLOCK,
            lambda t: -amp if t < t1 else 0.0,
            3.0,
            breakpoints=[t1],
            variant="linearized",
            rtol=1e-9,
            atol=1e-11,
            dense_dt=1e-2,
        )
        return sol.toppled

    thr = bisect(topples, 0.95 * ref, 1.05 * ref, 1e-3 * ref)
    assert thr == pytest.approx(ref, rel=1e-3)


# ---------------------------------------------------------------------------------------------------------------
# free rocking
# ---------------------------------------------------------------------------------------------------------------


def test_free_rocking_exact_ratios() -> None:
    sol = simulate_rocking(BLOCK, lambda t: 0.0, 6.0, theta0=0.5 * ALPHA, rtol=1e-10)
    impacts = [e for e in sol.events if e["kind"] == "impact"]
    assert len(impacts) >= 8 and sol.n_impacts == len(impacts)
    for e in impacts:
        assert e["omega_plus"] / e["omega_minus"] == pytest.approx(0.85, abs=1e-9)
    # sides alternate, θ stays within ±α, no uplift before the first impact (started in motion)
    assert [e["to_side"] for e in impacts[:4]] == ["left", "right", "left", "right"]
    assert not sol.toppled and sol.peak_theta_ratio == pytest.approx(0.5, abs=1e-12)
    # between impacts the energy-equivalent speed at θ = 0 is conserved (exact dynamics):
    # ω0² = ω² + 2p²[cos(α − |θ|) − cos α]
    p2 = BLOCK.p("right", G) ** 2
    w0sq = sol.omega**2 + 2 * p2 * (np.cos(ALPHA - np.abs(sol.theta)) - math.cos(ALPHA))
    t_imp = [e["t"] for e in impacts]
    seg = (sol.t > t_imp[0]) & (sol.t < t_imp[1])
    assert np.ptp(w0sq[seg]) < 1e-8 * w0sq[seg].mean()
    first = w0sq[sol.t < t_imp[0]]
    assert w0sq[seg].mean() / first.mean() == pytest.approx(0.85**2, rel=1e-8)


def test_free_rocking_linearized_amplitudes_and_period() -> None:
    sol = simulate_rocking(BLOCK, lambda t: 0.0, 3.0, theta0=0.5 * ALPHA, variant="linearized", rtol=1e-10)
    impacts = [e for e in sol.events if e["kind"] == "impact"]
    p = BLOCK.p("right", G)
    assert impacts[0]["t"] == pytest.approx(free_rocking_period(ALPHA, p, 0.5 * ALPHA) / 4, rel=1e-8)
    # peaks after impact k: use the exact θ̇ = 0 events
    phi = [abs(th) / ALPHA for t, th in sol.peaks if t > impacts[0]["t"]][:3]
    np.testing.assert_allclose(phi, housner_amplitude_sequence(0.5, 0.85**2, 3), atol=1e-6)
    np.testing.assert_allclose(phi, [0.3232, 0.2199, 0.1532], atol=1e-3)
    np.testing.assert_allclose(theta_ratio(BLOCK, sol.peaks[:, 1])[:3], phi, rtol=1e-12)


def test_free_rocking_settles_to_rest() -> None:
    sol = simulate_rocking(
        BLOCK, lambda t: 0.0, 20.0, theta0=0.2 * ALPHA, rtol=1e-8, atol=1e-10, dense_dt=1e-2
    )
    assert sol.events[-1]["kind"] == "rest"
    assert sol.n_impacts < 400
    assert sol.theta[-1] == 0.0 and sol.omega[-1] == 0.0
    assert np.all(np.diff(sol.t) > 0)
    assert sol.t[-1] == pytest.approx(20.0)


# ---------------------------------------------------------------------------------------------------------------
# uplift
# ---------------------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(("variant", "sign"), [("exact", -1), ("exact", 1), ("linearized", -1)])
def test_uplift_under_slow_ramp(variant: str, sign: int) -> None:
    k = 1.0  # m/s³
    sol = simulate_rocking(BLOCK, lambda t: sign * k * t, 3.6, variant=variant, rtol=1e-8, atol=1e-10)
    up = sol.events[0]
    assert up["kind"] == "uplift"
    assert up["side"] == ("right" if sign < 0 else "left")
    expected = G * (math.tan(ALPHA) if variant == "exact" else ALPHA)
    assert k * up["t"] == pytest.approx(expected, rel=1e-6)
    assert np.all(sol.theta[sol.t < up["t"]] == 0.0)
    assert sign * sol.theta[-1] < 0


def test_vertical_acceleration_is_gravity_shift() -> None:
    acc, t_p = halfsine(5.0, 3.5)
    a = simulate_rocking(BLOCK, acc, 1.2, breakpoints=[t_p], g=G, accel_v=lambda t: 1.0, rtol=1e-10)
    b = simulate_rocking(BLOCK, acc, 1.2, breakpoints=[t_p], g=G + 1.0, rtol=1e-10)
    assert a.t.shape == b.t.shape
    np.testing.assert_allclose(a.theta, b.theta, atol=1e-10)
    assert a.events[0]["t"] == pytest.approx(b.events[0]["t"], abs=1e-12)


# ---------------------------------------------------------------------------------------------------------------
# generic body: notched block
# ---------------------------------------------------------------------------------------------------------------


def notched_block(density: float = 2400.0, depth: float = 0.4) -> TwoPivotBody:
    """0.4 × 1.2 box minus a 0.2 wide × 0.3 high notch at the base centre; exact decomposition."""
    w, hgt, nw, nh = 0.4, 1.2, 0.2, 0.3
    a_box, a_n = w * hgt, nw * nh
    z_n = -hgt / 2 + nh / 2  # notch centroid (box-centre frame)
    area = a_box - a_n
    z_c = (0.0 * a_box - z_n * a_n) / area
    j_box = a_box * (w**2 + hgt**2) / 12  # polar, about the box centre
    j_n = a_n * (nw**2 + nh**2) / 12 + a_n * z_n**2
    j_c = j_box - j_n - area * z_c**2
    rho = density * depth
    zb = -hgt / 2 - z_c
    return TwoPivotBody(mass=rho * area, inertia_com=rho * j_c, left=(-w / 2, zb), right=(w / 2, zb))


def test_notched_block() -> None:
    nb = notched_block()
    assert nb.mass == pytest.approx(403.2, rel=1e-12)
    assert -nb.right[1] - 0.6 == pytest.approx(0.0643, abs=1e-4)  # COM 0.0643 m above the box centre
    assert nb.alpha("left") == pytest.approx(0.29244, abs=1e-5)
    assert nb.p("right", G) == pytest.approx(3.3706, abs=1e-4)
    assert nb.impact_ratio("left") == pytest.approx(0.8665, abs=5e-4)
    thr = bisect(lambda a: _topples_halfsine(nb, "exact", a, nb.uplift_accel("left", G)), 5.05, 5.2, 2e-3)
    # independent reference: conformance.PlanarBlock, an exact two-pivot ODE with closed-form mass
    # properties written without pbr_xval.analytical (5.12410 m/s²); bisection tolerance 2e-3 m/s²
    from pbr_xval.conformance import notched_reference

    assert thr == pytest.approx(notched_reference()["threshold"], abs=2.5e-3)


def test_notched_block_free_rocking_ratio_in_simulation() -> None:
    nb = notched_block()
    sol = simulate_rocking(nb, lambda t: 0.0, 4.0, theta0=-0.5 * nb.alpha("left"), rtol=1e-9, atol=1e-11)
    impacts = [e for e in sol.events if e["kind"] == "impact"]
    assert len(impacts) >= 3
    for e in impacts:
        assert e["omega_plus"] / e["omega_minus"] == pytest.approx(0.8665, abs=5e-4)


def _momentum_about(
    point: np.ndarray, pivot: np.ndarray, com: np.ndarray, omega: float, m: float, ig: float
) -> float:
    """y angular momentum about ``point`` of a body rotating at ``omega`` about ``pivot`` (x–z plane, +y axis)."""
    rel = com - pivot
    v = omega * np.array([rel[1], -rel[0]])  # ω ŷ × (x, z) = ω (z, −x)
    rho = com - point
    return ig * omega + m * (rho[1] * v[0] - rho[0] * v[1])


def test_asymmetric_body_uplift_and_impact() -> None:
    body = TwoPivotBody(mass=2.0, inertia_com=0.07, left=(-0.1, -0.5), right=(0.3, -0.45))
    for sign, side in ((1, "left"), (-1, "right")):
        sol = simulate_rocking(body, lambda t, sign=sign: 10.0 * sign * t, 1.2, rtol=1e-8, atol=1e-10)
        up = sol.events[0]
        assert up["side"] == side
        x, z = body.left if side == "left" else body.right
        assert 10.0 * up["t"] == pytest.approx(G * abs(x) / -z, rel=1e-6)
    # impact ratio from first principles: angular momentum about the new pivot is conserved
    com = np.zeros(2)
    for new, old in (("left", "right"), ("right", "left")):
        p_new, p_old = body.pivot(new), body.pivot(old)
        l_before = _momentum_about(p_new, p_old, com, 1.0, body.mass, body.inertia_com)
        l_after_per_omega = _momentum_about(p_new, p_new, com, 1.0, body.mass, body.inertia_com)
        assert body.impact_ratio(new) == pytest.approx(l_before / l_after_per_omega, rel=1e-12)
        assert l_after_per_omega == pytest.approx(body.I_O(new), rel=1e-12)
    # free rocking from the right side: per-impact ratios alternate between the two sides' values
    sol = simulate_rocking(body, lambda t: 0.0, 3.0, theta0=0.3 * body.alpha("right"), rtol=1e-9, atol=1e-11)
    for e in [e for e in sol.events if e["kind"] == "impact"]:
        assert e["omega_plus"] / e["omega_minus"] == pytest.approx(body.impact_ratio(e["to_side"]), rel=1e-12)


def test_initial_state_beyond_topple_angle() -> None:
    sol = simulate_rocking(BLOCK, lambda t: 0.0, 1.0, theta0=1.01 * ALPHA)
    assert sol.toppled and sol.toppled_at == 0.0 and sol.events[-1]["kind"] == "toppled"
    sol = simulate_rocking(BLOCK, lambda t: 0.0, 3.0, theta0=0.99 * ALPHA, omega0=0.1)
    assert sol.toppled and sol.toppled_at > 0 and abs(sol.theta[-1]) == pytest.approx(ALPHA, rel=1e-9)
