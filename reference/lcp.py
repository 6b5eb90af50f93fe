"""The reference solver's LCP and friction solvers, one import (by solver family).

* :mod:`pbr_xval.reference.pivoting` — Lemke and Dantzig/Baraff pivoting (eq. 3.5);
* :mod:`pbr_xval.reference.selection` — the solution closest to a reference among the
  non-unique solutions of a singular impact LCP;
* :mod:`pbr_xval.reference.cone` — resting contact with the Coulomb cone (eqs. 3.6–3.7):
  iterative cone solver, friction-pyramid LCP, residuals;
* :mod:`pbr_xval.reference.kernel` — the compiled active-set solve used first.
"""

from __future__ import annotations

import numpy as np

from pbr_xval.reference import pivoting
from pbr_xval.reference.cone import (
    FrictionResult,
    friction_residuals,
    solve_friction_cone,
    solve_friction_pyramid,
)
from pbr_xval.reference.pivoting import VERIFY_RTOL, LCPResult, dantzig, lemke
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


def solve_lcp(
    M: np.ndarray,
    q: np.ndarray,
    *,
    method: str = "dantzig",
    warm_start: np.ndarray | None = None,
    max_pivots: int | None = None,
    tol: float = 1e-12,
    fallback: bool = True,
    reference: np.ndarray | None = None,
    select: str | None = None,
) -> LCPResult:
    """:func:`pbr_xval.reference.pivoting.solve_lcp`, optionally followed by a selection.

    Parameters
    ----------
    M : array_like, shape (n, n)
        LCP matrix.
    q : array_like, shape (n,)
        LCP vector.
    method, warm_start, max_pivots, tol, fallback
        As for :func:`pbr_xval.reference.pivoting.solve_lcp`.
    reference : array_like, shape (n,), optional
        Reference for ``select="closest"``.
    select : {None, "closest", "min_norm"}
        ``None`` returns whatever vertex the pivoting produced; ``"closest"`` /
        ``"min_norm"`` post-process with :func:`solve_lcp_min_norm` (``min_norm`` uses
        reference zero).

    Returns
    -------
    LCPResult
    """
    if select is None:
        return pivoting.solve_lcp(
            M, q, method=method, warm_start=warm_start, max_pivots=max_pivots, tol=tol, fallback=fallback
        )
    if method not in ("dantzig", "lemke"):
        raise ValueError(f"unknown method {method!r}; use 'dantzig' or 'lemke'")
    if select not in ("closest", "min_norm"):
        raise ValueError(f"unknown select {select!r}")
    ref = None if select == "min_norm" else reference
    return solve_lcp_min_norm(
        M, q, reference=ref, method=method, tol=tol, max_pivots=max_pivots, warm_start=warm_start
    )
