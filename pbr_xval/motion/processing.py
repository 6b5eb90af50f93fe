"""Record processing: resampling and amplitude scaling."""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
from scipy.signal import resample_poly

from .base import GroundMotion
from .intensity import peak_ground_acceleration, peak_ground_velocity
from .records import Record

__all__ = ["resample", "scale_to_pga", "scale_to_pgv"]

_MAX_POLY = 1000  # largest up/down factor for which polyphase resampling is used


def resample(record: Record, dt: float) -> Record:
    """Resample a record onto a new uniform grid ``t0 + k·dt`` within its duration.

    * Upsampling (dt ≤ record.dt): the record's own piecewise-linear a(t) is
      evaluated on the new grid (no information is added or lost).
    * Downsampling: if dt/record.dt equals a fraction down/up with
      up, down ≤ 1000 (to 1e-9 relative), :func:`scipy.signal.resample_poly`
      applies its anti-alias FIR filter (Kaiser window, cut-off at the new
      Nyquist frequency); otherwise plain linear interpolation is used,
      *without* anti-aliasing — low-pass the record first in that case.

    Parameters
    ----------
    record : Record
    dt : float, s
        New time step, > 0.

    Returns
    -------
    Record
        Same provenance, ``metadata["resampled_from_dt"]`` set.
    """
    dt = float(dt)
    if not (math.isfinite(dt) and dt > 0):
        raise ValueError(f"dt must be a positive finite time step in s, got {dt!r}")
    n_new = math.floor((record.npts - 1) * record.dt / dt * (1 + 1e-12)) + 1
    if n_new < 2:
        raise ValueError(
            f"dt={dt!r} s leaves fewer than 2 samples in a record of {record.duration - record.t0} s"
        )
    ratio = dt / record.dt
    frac = Fraction(ratio).limit_denominator(_MAX_POLY)
    method = "linear"
    if ratio <= 1.0:
        acc = record.acceleration(record.t0 + dt * np.arange(n_new))
    elif abs(float(frac) - ratio) <= 1e-9 * ratio and max(frac.numerator, frac.denominator) <= _MAX_POLY:
        acc = resample_poly(record.acc, frac.denominator, frac.numerator)[:n_new]
        method = "resample_poly"
    else:
        acc = record.acceleration(record.t0 + dt * np.arange(n_new))
    return record.replace(acc, dt, resampled_from_dt=record.dt, resample_method=method)


def _scale(motion: GroundMotion, target: float, peak: float, what: str) -> GroundMotion:
    if not (math.isfinite(target) and target > 0):
        raise ValueError(f"target {what} must be a positive finite number, got {target!r}")
    if not peak > 0:
        raise ValueError(f"motion {motion.name!r} has zero {what}; cannot scale it to {target!r}")
    return motion.scaled(target / peak)


def scale_to_pga(motion: GroundMotion, target: float) -> GroundMotion:
    """Copy of ``motion`` scaled so that its PGA equals ``target`` (m/s²).

    Uses the exact ``pga`` of pulses/records, else a fine sampling
    (:func:`~pbr_xval.motion.intensity.peak_ground_acceleration`).
    """
    return _scale(motion, target, peak_ground_acceleration(motion), "PGA")


def scale_to_pgv(motion: GroundMotion, target: float) -> GroundMotion:
    """Copy of ``motion`` scaled so that its PGV equals ``target`` (m/s); exact ``pgv`` when available."""
    return _scale(motion, target, peak_ground_velocity(motion), "PGV")
