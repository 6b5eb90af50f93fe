"""Is this a rock? Size, density and mass bounds checked when a scene is compiled.

These are **errors**, not warnings. A warning scrolls past in a batch log (and pytest turns
warnings into errors anyway), while every case these bounds catch is an input mistake, never a
real rock, and the result of simulating it is worthless:

* size: the largest precariously balanced rocks are metres to tens of metres across; a rock
  larger than 1 km (or smaller than 5 mm) is a unit mistake (a scan in mm read as km) — the
  contact tolerances of every engine (1e-5 m) and the settling times assume rock-sized bodies;
* density: the lightest rock (pumice, ~250 kg/m³) and the densest material of any kind (osmium,
  22 590 kg/m³) bound every real rock generously: [100, 22 600] kg/m³. ``density = 1e308`` used
  to end as "blow-up during settling (nan)" naming nothing;
* mass: a given mass is checked through the density it implies (mass / mesh volume).
"""

from __future__ import annotations

import math
from typing import Any

__all__ = ["DENSITY_RANGE", "SIZE_RANGE", "check_rock"]

#: kg/m³: below pumice, above osmium (the densest element)
DENSITY_RANGE = (100.0, 22_600.0)
#: m: largest extent of the rock (axis-aligned bounding box)
SIZE_RANGE = (0.005, 1000.0)


def check_rock(rock_spec: Any, mass: float, volume: float, extents: Any, *, where: str) -> None:
    """Raise ``ScenarioError`` if the rock is not plausible (see the module docstring).

    Parameters
    ----------
    rock_spec : the scenario's ``rock`` model (which keys the user gave: density or mass, units).
    mass : kg; volume : m³ (of the closed mesh); extents : (3,) m, bounding-box sizes.
    where : the file (or scenario name) that prefixes the message.
    """
    from pbr_xval.errors import ScenarioError

    size = max(float(x) for x in extents)
    lo, hi = SIZE_RANGE
    if not (lo <= size <= hi):
        units = getattr(rock_spec, "units", None)
        hint = f"; is 'rock.units' = {units!r} right?" if units is not None else "; are the sizes in metres?"
        raise ScenarioError(
            f"{where}: key 'rock': the rock is {size:.4g} m across; expected a rock between {lo:g} m and "
            f"{hi:g} m{hint}"
        )
    dlo, dhi = DENSITY_RANGE
    density = mass / volume if volume > 0 else math.inf
    if not (dlo <= density <= dhi):
        given = getattr(rock_spec, "density", None)
        if given is not None:
            key, found = "rock.density", f"{given!r} kg/m³"
        else:
            key, found = "rock.mass", f"{mass:.6g} kg for {volume:.4g} m³, i.e. {density:.4g} kg/m³"
        raise ScenarioError(
            f"{where}: key '{key}': found {found}; expected a rock density between {dlo:g} and "
            f"{dhi:g} kg/m³ (pumice ~250, granite ~2700, osmium, the densest material, 22 590)"
        )
