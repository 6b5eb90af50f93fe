"""Ground motions for PBR toppling simulations: analytic pulses, recorded
accelerograms, 3-D excitation, processing and intensity measures (SI units)."""

from __future__ import annotations

from .base import Excitation3D, GroundMotion, MotionFileError, ScaledMotion
from .intensity import (
    default_dt,
    intensity_measures,
    peak_ground_acceleration,
    peak_ground_velocity,
    pga,
    pgd,
    pgv,
    response_spectrum,
    sdof_response,
)
from .processing import resample, scale_to_pga, scale_to_pgv
from .pulses import PULSES, HalfSine, OneCosine, OneSine, Rectangular, Ricker, Sawtooth
from .records import FORMATS, G_STANDARD, UNITS, Record, read_at2, read_record, read_table, write_at2

__all__ = [
    "FORMATS",
    "G_STANDARD",
    "PULSES",
    "UNITS",
    "Excitation3D",
    "GroundMotion",
    "HalfSine",
    "MotionFileError",
    "OneCosine",
    "OneSine",
    "Record",
    "Rectangular",
    "Ricker",
    "Sawtooth",
    "ScaledMotion",
    "default_dt",
    "intensity_measures",
    "peak_ground_acceleration",
    "peak_ground_velocity",
    "pga",
    "pgd",
    "pgv",
    "read_at2",
    "read_record",
    "read_table",
    "resample",
    "response_spectrum",
    "scale_to_pga",
    "scale_to_pgv",
    "sdof_response",
    "write_at2",
]
