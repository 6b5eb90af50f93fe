"""Response spectrum (Nigam & Jennings), intensity measures, 3-D excitation, processing."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from pbr_xval.motion import (
    Excitation3D,
    HalfSine,
    OneSine,
    Record,
    Ricker,
    Sawtooth,
    intensity_measures,
    pga,
    resample,
    response_spectrum,
    scale_to_pga,
    scale_to_pgv,
    sdof_response,
)


# ---------------------------------------------------------------- spectrum
@pytest.mark.parametrize("period", [0.3, 1.0, 2.5])
def test_harmonic_steady_state(period):
    """Steady-state |u| = A/ω² / sqrt((1-β²)² + (2ζβ)²), β = Ω/ω; tolerance 1 %."""
    A, Omega, zeta, dt = 2.0, 2 * math.pi * 0.7, 0.05, 0.005
    t = np.arange(0, 120.0, dt)
    a = A * np.sin(Omega * t)
    w = 2 * math.pi / period
    beta = Omega / w
    u_ss = A / w**2 / math.sqrt((1 - beta**2) ** 2 + (2 * zeta * beta) ** 2)
    u = sdof_response(a, dt, period, zeta)
    tail = t > 80.0  # transients decayed by exp(-ζω·80) < 1e-3 for T <= 2.5 s
    assert np.max(np.abs(u[tail])) == pytest.approx(u_ss, rel=0.01)
    # with a slow, smooth (sin²) onset over 40 s the transient is small and Sa itself matches
    ramp = np.sin(np.pi / 2 * np.minimum(t / 40.0, 1.0)) ** 2
    sa = response_spectrum(a * ramp, dt, [period], zeta)[0]
    assert sa == pytest.approx(w**2 * u_ss, rel=0.01)


def test_short_period_gives_pga():
    dt = 0.01
    t = np.arange(0, 20, dt)
    a = 3.0 * np.sin(2 * np.pi * 0.8 * t) * np.exp(-(((t - 8) / 3) ** 2))
    sa = response_spectrum(a, dt, [0.0, 1e-3, 0.01], 0.05)
    assert sa[0] == pga(a)
    np.testing.assert_allclose(sa[1:], pga(a), rtol=0.01)


def test_against_solve_ivp():
    """Recurrence vs an adaptive ODE solve of the SDOF with the same piecewise-linear input; 0.5 %."""
    rng = np.random.default_rng(42)
    dt = 0.01
    t = np.arange(0, 15, dt)
    freqs, phases, amps = rng.uniform(0.3, 5.0, 8), rng.uniform(0, 2 * np.pi, 8), rng.normal(0, 1, 8)
    a = (amps[:, None] * np.sin(2 * np.pi * freqs[:, None] * t + phases[:, None])).sum(0) * (1 - t / 15) ** 2
    assert abs(a[0]) > 0.1  # starts with a jump from rest: exercises the initial-state handling
    periods = np.array([0.1, 0.4, 1.0, 3.0])
    zeta = 0.05
    sa = response_spectrum(a, dt, periods, zeta)
    al = a.tolist()

    def ground(tt):  # the same piecewise-linear a(t)
        x = tt / dt
        k = min(int(x), len(al) - 2)
        return al[k] + (al[k + 1] - al[k]) * (x - k)

    for T, s in zip(periods, sa, strict=True):
        w = 2 * np.pi / T

        def rhs(tt, y, w=w):
            return (y[1], -ground(tt) - 2 * zeta * w * y[1] - w * w * y[0])

        # rtol 1e-8 let RK45's steps straddle the input's kinks (2e-4 relative error with scipy 1.17);
        # at 1e-10 the adaptive solve agrees with the recurrence to 5e-7 of the peak, 20× inside the bound.
        sol = solve_ivp(rhs, (0, t[-1]), [0.0, 0.0], t_eval=t, rtol=1e-10, atol=1e-13, max_step=dt)
        assert s == pytest.approx(w**2 * np.max(np.abs(sol.y[0])), rel=0.005)
        np.testing.assert_allclose(
            sdof_response(a, dt, T, zeta), sol.y[0], atol=1e-5 * np.max(np.abs(sol.y[0]))
        )


def test_spectrum_validation():
    with pytest.raises(ValueError, match="damping"):
        response_spectrum(np.ones(10), 0.01, [1.0], damping=1.0)
    with pytest.raises(ValueError, match="periods"):
        response_spectrum(np.ones(10), 0.01, [-1.0])


def test_intensity_measures_sawtooth():
    m = Sawtooth(0.5, 1.0)
    im = intensity_measures(m)
    assert im["PGA"] == pytest.approx(1.0) and im["PGV"] == pytest.approx(0.5)
    assert im["PGD"] == pytest.approx(0.25, rel=1e-6)  # PGV·T/2 at the end
    assert im["PGV/PGA"] == pytest.approx(0.5)
    assert set(im) >= {"Sa(0.2)", "Sa(1.0)", "Sa(2.0)"}
    json.dumps(im)


def test_intensity_measures_record_uses_exact_integrals():
    dt = 0.01
    t = np.arange(0, 10, dt)
    r = Record(np.sin(2 * np.pi * t) * np.sin(np.pi * t / 10), dt)
    im = intensity_measures(r, periods=(1.0,))
    assert im["PGA"] == pytest.approx(np.max(np.abs(r.acc)))
    tf = np.linspace(0, 10, 100001)
    assert im["PGV"] == pytest.approx(np.max(np.abs(r.velocity(tf))), rel=1e-9)


# ---------------------------------------------------------------- 3-D
def test_excitation3d_azimuth_and_vertical():
    h, v = HalfSine(2.0, 1.0), Ricker(1.0, 3.0)
    e = Excitation3D(h, math.pi / 2, vertical=v)
    a = e.acceleration(0.2)
    assert a.shape == (3,)
    np.testing.assert_allclose(a, [0.0, h.acceleration(0.2), v.acceleration(0.2)], atol=1e-12)
    t = np.linspace(0, 1, 11)
    for kind in ("acceleration", "velocity", "displacement"):
        x = getattr(e, kind)(t)
        assert x.shape == (11, 3)
        np.testing.assert_allclose(x[:, 1], getattr(h, kind)(t))
        np.testing.assert_allclose(x[:, 0], 0.0, atol=1e-12)
        np.testing.assert_allclose(x[:, 2], getattr(v, kind)(t))
    e2 = Excitation3D(h, math.radians(30))
    np.testing.assert_allclose(
        e2.acceleration(0.1), h.acceleration(0.1) * np.array([math.sqrt(3) / 2, 0.5, 0.0])
    )
    assert e.duration == v.duration and e.breakpoints == (0.0, h.duration, v.duration)
    json.dumps(e.describe())


# ---------------------------------------------------------------- processing
@pytest.mark.parametrize("motion", [HalfSine(2.0, 1.0, 0.3), OneSine(1.0, 2.0), Ricker(3.0, 1.0)])
def test_scale_to_pga_pgv(motion):
    s = scale_to_pga(motion, 4.2)
    t = np.linspace(0, motion.duration, 200001)[:-1]
    assert np.max(np.abs(s.acceleration(t))) == pytest.approx(4.2, rel=1e-6)
    s = scale_to_pgv(motion, 0.37)
    assert np.max(np.abs(s.velocity(t))) == pytest.approx(0.37, rel=1e-6)


def test_scale_record():
    r = Record([0.0, 1.0, -3.0, 0.5], 0.01)
    s = scale_to_pga(r, 9.0)
    assert isinstance(s, Record) and np.max(np.abs(s.acc)) == pytest.approx(9.0)


@pytest.mark.parametrize("new_dt", [0.0005, 0.004, 0.01, 0.0073])
def test_resample_preserves_sine_amplitude(new_dt):
    dt, f = 0.002, 1.5
    t = np.arange(0, 20, dt)
    r = Record(2.0 * np.sin(2 * np.pi * f * t), dt)
    out = resample(r, new_dt)
    assert out.dt == new_dt
    tn = out.time
    inner = (tn > 2) & (tn < 18)  # away from filter edge effects
    assert np.max(np.abs(out.acc[inner])) == pytest.approx(2.0, rel=0.005)
    np.testing.assert_allclose(out.acc[inner], 2.0 * np.sin(2 * np.pi * f * tn[inner]), atol=0.01)
    assert out.metadata["resampled_from_dt"] == dt
