"""Units of scenario keys and result quantities: one registry for the CLI, studies and reports.

Everything inside pbr-xval is SI; this module only says which SI unit a named quantity
carries, how to print it, and how to suffix a table column with it. A key is looked up by
its last dotted component (``excitation.amplitude`` → ``amplitude``), so the same table
serves scenario keys, study parameters and result columns.

Examples
--------
>>> unit("excitation.amplitude")
'm/s²'
>>> label("excitation.pgv")
'PGV [m/s]'
>>> column("excitation.period")
'period_s'
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["QUANTITIES", "UNIT_SCALE", "Quantity", "column", "label", "quantity", "unit"]

#: length unit of an input file (mesh, scan, cut height) -> metres per unit
UNIT_SCALE: dict[str, float] = {"m": 1.0, "cm": 0.01, "mm": 0.001, "km": 1000.0, "ft": 0.3048, "in": 0.0254}


@dataclass(frozen=True)
class Quantity:
    """A named quantity: its human label, its unit as printed, and its column suffix.

    Attributes
    ----------
    label : str
        Short human name (``"PGA"``, ``"pulse amplitude"``).
    unit : str
        Unit as printed (``"m/s²"``); ``""`` for a dimensionless quantity.
    suffix : str
        ASCII unit suffix for column names (``"m_s2"``); ``""`` when dimensionless.
    """

    label: str
    unit: str
    suffix: str


_M_S2 = ("m/s²", "m_s2")
_M_S = ("m/s", "m_s")
_M = ("m", "m")
_S = ("s", "s")
_HZ = ("Hz", "Hz")
_RAD = ("rad", "rad")
_RAD_S = ("rad/s", "rad_s")
_DEG = ("°", "deg")
_KG = ("kg", "kg")
_KG_M3 = ("kg/m³", "kg_m3")
_ONE = ("", "")
_PER_YR = ("1/yr", "per_yr")
_YR = ("yr", "yr")

#: last dotted component of a key → quantity
QUANTITIES: dict[str, Quantity] = {
    k: Quantity(lbl, *u)
    for k, lbl, u in [
        ("amplitude", "pulse amplitude", _M_S2),
        ("pga", "PGA", _M_S2),
        ("target_pga", "PGA", _M_S2),
        ("sa", "Sa", _M_S2),
        ("pgv", "PGV", _M_S),
        ("target_pgv", "PGV", _M_S),
        ("pgd", "PGD", _M),
        ("pgv_over_pga", "PGV/PGA", _S),
        ("period", "pulse period", _S),
        ("pulse_duration", "pulse duration", _S),
        ("duration", "duration", _S),
        ("settle_time", "settle time", _S),
        ("start_time", "start time", _S),
        ("timestep", "time step", _S),
        ("dt", "time step", _S),
        ("wall_s", "wall time", _S),
        ("frequency", "frequency", _HZ),
        ("r", "base radius r", _M),
        ("h", "flat base length h", _M),
        ("H", "height H", _M),
        ("half_extents", "half extents", _M),
        ("theta", "rocking angle", _RAD),
        ("max_tilt", "largest tilt", _RAD),
        ("omega", "rocking rate", _RAD_S),
        ("azimuth_deg", "shaking azimuth", _DEG),
        ("yaw_deg", "rock yaw", _DEG),
        ("mass", "mass", _KG),
        ("density", "density", _KG_M3),
        ("friction_static", "μ_s", _ONE),
        ("friction_dynamic", "μ_d", _ONE),
        ("restitution", "restitution", _ONE),
        ("impact_ratio", "impact velocity ratio η", _ONE),
        ("scale", "scale factor", _ONE),
        ("annual_rate", "annual exceedance rate λ", _PER_YR),
        ("toppling_rate", "toppling rate ν", _PER_YR),
        ("exposure_age", "exposure age", _YR),
        ("skew", "pulse skew s", _ONE),
        ("theta_over_alpha", "θ/α", _ONE),
    ]
}


def _leaf(key: str) -> str:
    return key.rsplit(".", 1)[-1]


def quantity(key: str) -> Quantity | None:
    """The registered quantity of a dotted key, or ``None`` when the key is not registered."""
    return QUANTITIES.get(_leaf(key))


def unit(key: str) -> str:
    """Printed SI unit of a dotted key (``""`` when dimensionless or unknown)."""
    q = quantity(key)
    return q.unit if q else ""


def label(key: str, *, with_unit: bool = True) -> str:
    """Axis/column label of a dotted key: ``"PGV [m/s]"``; an unknown key is printed as given."""
    q = quantity(key)
    name = q.label if q else key
    u = q.unit if q else ""
    return f"{name} [{u}]" if with_unit and u else name


def column(key: str) -> str:
    """Column name with an ASCII unit suffix: ``excitation.period`` → ``period_s``."""
    q = quantity(key)
    leaf = _leaf(key)
    return f"{leaf}_{q.suffix}" if q and q.suffix else leaf
