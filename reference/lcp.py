"""The reference solver's LCP and friction solvers, one import (by solver family).

* :mod:`pbr_xval.reference.pivoting` — Lemke and Dantzig/Baraff pivoting (eq. 3.5);
* :mod:`pbr_xval.reference.selection` — the solution closest to a reference among the
  non-unique solutions of a singular impact LCP;
* :mod:`pbr_xval.reference.cone` — resting contact with the Coulomb cone (eqs. 3.6–3.7):
  iterative cone solver, friction-pyramid LCP, residuals;
* :mod:`pbr_xval.reference.kernel` — the compiled active-set solve used first.
"""

from __future__ import annotations

from pbr_xval.reference.cone import (
    FrictionResult,
    friction_residuals,
    solve_friction_cone,
    solve_friction_pyramid,
)
from pbr_xval.reference.pivoting import VERIFY_RTOL, LCPResult, dantzig, lemke, solve_lcp
from pbr_xval.reference.selection import solve_lcp_min_norm

__all__ = [
    "VERIFY_RTOL",
    "FrictionResult",
    "LCPResult",
    "dantzig",
    "friction_residuals",
    "lemke",
    "solve_friction_cone",
    "solve_friction_pyramid",
    "solve_lcp",
    "solve_lcp_min_norm",
]
