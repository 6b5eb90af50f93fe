"""Analytic pulses: consistency of a, v, d and the defining properties."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy.integrate import cumulative_trapezoid

from pbr_xval.motion import PULSES, HalfSine, OneCosine, OneSine, Rectangular, Ricker, Sawtooth

CASES = {
    "half_sine": HalfSine(5.638, 1.0, 0.6),
    "half_sine_phase0": HalfSine(2.0, 2.5),
    "sawtooth": Sawtooth(0.8, 1.2),
    "sawtooth_skewed": Sawtooth(0.8, 1.2, skew=0.8),
    "one_sine": OneSine(3.0, 1.5),
    "one_cosine": OneCosine(3.0, 1.5),
    "rectangular": Rectangular(2.0, 0.3),
    "ricker": Ricker(4.0, 2.0),
}
IDS = list(CASES)


def _segments(m, tail=1.0):
    """Intervals between breakpoints, plus a tail after the pulse."""
    b = [*m.breakpoints, m.duration + tail]
    return [(b[i], b[i + 1]) for i in range(len(b) - 1) if b[i + 1] > b[i]]


@pytest.mark.parametrize("key", IDS)
def test_derivatives_by_central_differences(key):
    """a = dv/dt and v = dd/dt; central differences h = 1e-5 s, tolerance 1e-6 of the peak."""
    m = CASES[key]
    h = 1e-5
    for lo, hi in _segments(m):
        t = np.linspace(lo + 1e-3 * (hi - lo), hi - 1e-3 * (hi - lo), 301)
        dv = (m.velocity(t + h) - m.velocity(t - h)) / (2 * h)
        dd = (m.displacement(t + h) - m.displacement(t - h)) / (2 * h)
        np.testing.assert_allclose(dv, m.acceleration(t), rtol=0, atol=1e-6 * m.pga)
        np.testing.assert_allclose(dd, m.velocity(t), rtol=0, atol=1e-6 * m.pgv)


@pytest.mark.parametrize("key", IDS)
def test_integrals_by_trapezoid(key):
    """v(t) - v(t_lo) = ∫a and d(t) - d(t_lo) = ∫v per smooth segment, 20001 points: error < 1e-7 of peak."""
    m = CASES[key]
    for lo, hi in _segments(m):
        t = np.linspace(lo, hi, 20001)
        # one-sided limits at the segment ends so jumps of a do not enter the trapezoid sums
        ta = np.clip(t, lo + 1e-12, hi - 1e-12)
        v_num = m.velocity(lo) + cumulative_trapezoid(m.acceleration(ta), t, initial=0.0)
        np.testing.assert_allclose(v_num, m.velocity(t), rtol=0, atol=1e-7 * m.pgv)
        d_num = m.displacement(lo) + cumulative_trapezoid(m.velocity(t), t, initial=0.0)
        np.testing.assert_allclose(d_num, m.displacement(t), rtol=0, atol=1e-7 * m.pgv * max(m.duration, 1.0))


@pytest.mark.parametrize("key", IDS)
def test_rest_at_start_and_zero_outside(key):
    m = CASES[key]
    if key == "ricker":
        # not truncated: v(0), d(0) are exp(-(1.5π)²)-small (documented)
        assert abs(m.velocity(0.0)) < 1e-8 * m.pgv
        assert abs(m.displacement(0.0)) < 1e-8 * m.pgd
        assert abs(m.acceleration(m.duration + 1.0)) < 1e-8 * m.pga
        return
    assert m.velocity(0.0) == 0.0 and m.displacement(0.0) == 0.0
    t_before = np.array([-1.0, -1e-9])
    assert np.all(m.acceleration(t_before) == 0) and np.all(m.velocity(t_before) == 0)
    t_after = m.duration + np.array([1e-9, 0.5, 3.0])
    assert np.all(m.acceleration(t_after) == 0.0)
    v_end = m.velocity(m.duration)
    np.testing.assert_allclose(m.velocity(t_after), v_end, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(
        m.displacement(t_after),
        m.displacement(m.duration) + v_end * (t_after - m.duration),
        rtol=1e-12,
        atol=1e-12,
    )


@pytest.mark.parametrize("key", IDS)
def test_exact_peaks_match_sampling(key):
    m = CASES[key]
    t = np.linspace(0, m.duration, 200001)
    assert m.pga == pytest.approx(np.max(np.abs(m.acceleration(t[:-1]))), rel=1e-6)
    assert m.pgv == pytest.approx(np.max(np.abs(m.velocity(t))), rel=1e-6)


@pytest.mark.parametrize("key", IDS)
def test_scalar_in_scalar_out_and_describe(key):
    m = CASES[key]
    assert isinstance(m.acceleration(0.1), float)
    assert m.velocity(np.array([0.1, 0.2])).shape == (2,)
    d = json.loads(json.dumps(m.describe()))
    assert d["duration"] == pytest.approx(m.duration)
    t, a = m.sample(m.duration / 100)
    assert t.shape == a.shape == (101,)
    assert m.breakpoints[0] == 0.0 and m.breakpoints[-1] == pytest.approx(m.duration)


def test_half_sine_definition():
    A, f, phi = 5.638, 1.0, 0.6
    m = HalfSine(A, f, phi)
    w = 2 * math.pi * f
    assert m.duration == pytest.approx((math.pi - phi) / w)
    assert m.acceleration(0.0) == pytest.approx(A * math.sin(phi))
    assert m.acceleration(0.17) == pytest.approx(A * math.sin(w * 0.17 + phi))
    assert m.velocity(0.2) == pytest.approx(A / w * (math.cos(phi) - math.cos(w * 0.2 + phi)))
    assert m.acceleration(m.duration - 1e-12) == pytest.approx(0.0, abs=1e-9)


def test_housner_phase():
    m = HalfSine.housner(5.638, 9.81 / 3)
    assert m.amplitude * math.sin(m.phase) == pytest.approx(3.27, abs=1e-12)
    assert m.acceleration(0.0) == pytest.approx(3.27)
    weak = HalfSine.housner(2.0, 9.81 / 3)  # cannot reach uplift: quarter sine from its peak
    assert weak.phase == pytest.approx(math.pi / 2)
    assert weak.duration == pytest.approx(0.25)


@pytest.mark.parametrize("skew", [0.3, 0.5, 0.7])
def test_sawtooth_definition(skew):
    P, T = 0.9, 1.5
    m = Sawtooth(P, T, skew)
    assert m.velocity(skew * T) == pytest.approx(P)
    t = np.linspace(0, T, 3001)
    assert np.max(m.velocity(t)) == pytest.approx(P)
    assert m.velocity(T) == pytest.approx(0.0, abs=1e-14)
    assert m.displacement(T) == pytest.approx(P * T / 2)
    assert m.acceleration(0.01) == pytest.approx(P / (skew * T))
    assert m.acceleration(T - 0.01) == pytest.approx(-P / ((1 - skew) * T))
    if skew <= 0.5:
        assert m.pga == pytest.approx(P / (skew * T))
    assert m.breakpoints == pytest.approx((0.0, skew * T, T))


def test_sawtooth_rejects_impulsive_drop():
    with pytest.raises(ValueError, match="impulse"):
        Sawtooth(1.0, 1.0, skew=1.0)
    with pytest.raises(ValueError, match="skew"):
        Sawtooth(1.0, 1.0, skew=0.0)


def test_cycloidal_closed_forms():
    A, f = 2.0, 1.25
    w = 2 * math.pi * f
    s, c = OneSine(A, f), OneCosine(A, f)
    tau = 0.3
    assert s.velocity(tau) == pytest.approx(A / w * (1 - math.cos(w * tau)))
    assert s.displacement(tau) == pytest.approx(A / w * (tau - math.sin(w * tau) / w))
    assert c.velocity(tau) == pytest.approx(A / w * math.sin(w * tau))
    assert c.displacement(tau) == pytest.approx(A / w**2 * (1 - math.cos(w * tau)))
    assert c.displacement(1 / f + 2.0) == pytest.approx(0.0, abs=1e-12)  # type B returns home


def test_rectangular_residual_velocity():
    m = Rectangular(2.0, 0.3)
    assert m.velocity(5.0) == pytest.approx(0.6)
    assert m.displacement(1.3) == pytest.approx(0.5 * 2.0 * 0.09 + 0.6 * 1.0)


def test_ricker_closed_form():
    A, f = 4.0, 2.0
    m = Ricker(A, f)
    assert m.t0 == pytest.approx(0.75) and m.duration == pytest.approx(1.5)
    assert m.acceleration(m.t0) == pytest.approx(A)
    assert m.displacement(m.t0) == pytest.approx(-A / (2 * math.pi**2 * f**2))


@pytest.mark.parametrize(
    ("cls", "kwargs", "param"),
    [
        (HalfSine, {"amplitude": -1.0}, "amplitude"),
        (HalfSine, {"amplitude": 1.0, "frequency": 0.0}, "frequency"),
        (HalfSine, {"amplitude": 1.0, "phase": 4.0}, "phase"),
        (Sawtooth, {"pgv": 1.0, "period": -2.0}, "period"),
        (OneSine, {"amplitude": float("nan"), "frequency": 1.0}, "amplitude"),
        (Rectangular, {"amplitude": 1.0, "duration": 0.0}, "duration"),
        (Ricker, {"amplitude": 1.0, "frequency": 1.0, "t0": -1.0}, "t0"),
    ],
)
def test_parameter_validation(cls, kwargs, param):
    with pytest.raises(ValueError, match=param):
        cls(**kwargs)


def test_registry():
    assert set(PULSES) == {"half_sine", "sawtooth", "one_sine", "one_cosine", "rectangular", "ricker"}
    assert PULSES["sawtooth"] is Sawtooth
