"""Intensity-measure names, SI units and the OpenQuake unit convention.

Inside pbr-xval every intensity measure is SI: PGA and SA(T) in m/s², PGV in m/s. OpenQuake
files (NRML fragility models, hazard curves) use PGA and SA in g and PGV in cm/s (the
OpenQuake manual: "if the intensity measure is PGA or SA ... the units ... will be 'g'"), so
readers and writers of OpenQuake formats convert with :func:`oq_factor`; g is standard
gravity 9.80665 m/s² (:data:`pbr_xval.motion.G_STANDARD`).

Names are canonical strings ``"PGA"``, ``"PGV"``, ``"SA(T)"`` with T the period in s written
as a float (``"SA(0.3)"``); :func:`canonical_im` accepts the spellings met in practice
(``pga``, ``Sa(0.3)``, ``SA(0.30)``, OpenQuake's ``IMT="SA" saPeriod="0.3"``).
"""

from __future__ import annotations

import math
import re

from pbr_xval.units import QUANTITIES

__all__ = [
    "G",
    "HazardInputError",
    "canonical_im",
    "im_label",
    "im_period",
    "im_unit",
    "oq_factor",
    "oq_unit",
]

#: standard gravity, m/s² (the "g" of OpenQuake and of PEER records)
G = 9.80665

_SA = re.compile(r"^\s*s\s*a\s*\(\s*([0-9.eE+-]+)\s*\)\s*$", re.IGNORECASE)


class HazardInputError(ValueError):
    """Bad hazard/fragility input: the message names the file and field, what was found and expected."""


def canonical_im(name: str, period: float | None = None) -> str:
    """Canonical IM name: ``"PGA"``, ``"PGV"`` or ``"SA(T)"`` (T in s).

    Parameters
    ----------
    name : str
        ``PGA``, ``PGV``, ``SA(T)`` in any case; ``SA`` alone needs ``period``.
    period : float, s, optional
        Period of a bare ``SA`` (OpenQuake's ``saPeriod``).

    Raises
    ------
    HazardInputError
        An unknown IM (one line: what was found, what is expected).
    """
    s = str(name).strip()
    u = s.upper()
    if u in ("PGA", "PGV"):
        return u
    if u == "SA" and period is not None:
        return f"SA({float(period)!r})"
    m = _SA.match(s)
    if m:
        try:
            t = float(m.group(1))
        except ValueError:
            t = math.nan
        if math.isfinite(t) and t > 0:
            return f"SA({t!r})"
    raise HazardInputError(f"unknown intensity measure {name!r}; expected PGA, PGV or SA(T) with T > 0 in s")


def im_period(im: str) -> float | None:
    """Period (s) of an ``SA(T)`` name, ``None`` for PGA/PGV."""
    c = canonical_im(im)
    return float(c[3:-1]) if c.startswith("SA(") else None


def im_unit(im: str) -> str:
    """SI unit of an IM as printed: ``m/s²`` (PGA, SA) or ``m/s`` (PGV)."""
    c = canonical_im(im)
    key = "pgv" if c == "PGV" else ("pga" if c == "PGA" else "sa")
    return QUANTITIES[key].unit


def im_label(im: str) -> str:
    """Axis label with unit: ``"PGA [m/s²]"``, ``"SA(1.0) [m/s²]"``."""
    c = canonical_im(im)
    return f"{c} [{im_unit(c)}]"


def oq_unit(im: str) -> str:
    """OpenQuake's unit for an IM: ``g`` (PGA, SA) or ``cm/s`` (PGV)."""
    return "cm/s" if canonical_im(im) == "PGV" else "g"


def oq_factor(im: str) -> float:
    """SI value = OpenQuake value × factor (g → m/s²: 9.80665; cm/s → m/s: 0.01)."""
    return 0.01 if canonical_im(im) == "PGV" else G
