"""Closed-form anchors (science.md §0, §1) for pbr_xval.analytical.closed_form."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pbr_xval.analytical.closed_form import (
    free_rocking_period,
    housner1963_halfsine,
    housner_amplitude_sequence,
    makris_roussos_halfsine,
    rectangle_restitution,
    rectangular_pulse_threshold,
)

G = 9.81
B, H = 0.2, 0.6
R = math.hypot(B, H)
ALPHA = math.atan2(B, H)
P = math.sqrt(3 * G / (4 * R))
OMEGA = 2 * math.pi


def test_project_block_parameters() -> None:
    assert R == pytest.approx(0.632456, abs=1e-6)
    assert ALPHA == pytest.approx(0.321751, abs=1e-6)
    assert P == pytest.approx(3.41075, abs=1e-5)


def test_housner1963_halfsine() -> None:
    assert housner1963_halfsine(ALPHA, P, OMEGA, G) == pytest.approx(6.616, abs=1e-3)


def test_makris_roussos_halfsine() -> None:
    a = makris_roussos_halfsine(ALPHA, P, OMEGA, G)
    assert a == pytest.approx(5.4405, abs=1e-4)
    # M&R 2000 Fig. 2: no overturn at 5.430, overturn at 5.440 (linear formulation)
    assert 5.430 < a < 5.441
    # eq. 27 holds at the returned amplitude
    psi = math.asin(ALPHA * G / a)
    lhs = OMEGA / P * math.sin(psi) - math.cos(psi)
    assert lhs == pytest.approx(math.exp(-(P / OMEGA) * (math.pi - psi)), rel=1e-10)
    # and it lies between the exact-nonlinear 5.638 and Housner's unconservative 6.616 from below
    assert a < 5.638 < housner1963_halfsine(ALPHA, P, OMEGA, G)


def test_rectangular_pulse_threshold_matches_cosh_form() -> None:
    for t1 in (0.1, 0.3, 1.0):
        a = rectangular_pulse_threshold(ALPHA, P, t1, G)
        lhs = math.cosh(P * t1)
        rhs = 1 + ALPHA**2 / (2 * (a / G) * (a / G - ALPHA))
        assert lhs == pytest.approx(rhs, rel=1e-12)


def test_free_rocking_period() -> None:
    assert free_rocking_period(ALPHA, P, 0.5 * ALPHA) == pytest.approx(1.5445, abs=1e-4)


def test_housner_amplitude_sequence() -> None:
    e = rectangle_restitution(ALPHA)
    phi = housner_amplitude_sequence(0.5, e**2, 3)
    assert phi.shape == (3,)
    np.testing.assert_allclose(phi, [0.3232, 0.2199, 0.1532], atol=1e-4)


def test_rectangle_restitution() -> None:
    assert rectangle_restitution(ALPHA) == pytest.approx(0.85, abs=1e-12)
    assert rectangle_restitution(math.asin(math.sqrt(2 / 3))) == pytest.approx(0.0, abs=1e-12)
