"""From fragility to hazard: what surviving precarious rocks say about shaking that never happened.

* :mod:`~pbr_xval.hazard.fragility_functions` — lognormal / step / discrete fragility functions and the
  (θ, β) ↔ linear-moment conversion of OpenQuake's NRML.
* :mod:`~pbr_xval.hazard.fit` — multiple-stripe fragility fits of a sweep on PGA, PGV, SA(T) with
  profile-likelihood intervals, the vector fragility on (PGA, PGV/PGA), the IM comparison.
* :mod:`~pbr_xval.hazard.curves` — site hazard curves, readers for CSV and OpenQuake output.
* :mod:`~pbr_xval.hazard.nrml` — NRML ``fragilityModel`` writer and readers.
* :mod:`~pbr_xval.hazard.survival` — survival probability, joint survival, reweighting of hazard
  branches (constrained mean and fractile curves), the check that a curve spans a fragility.
* :mod:`~pbr_xval.hazard.fragility_draws` — the fragility's draws carried into P_s and the reweighted
  hazard, with variance shares (hazard branch, fragility, exposure age).
* :mod:`~pbr_xval.hazard.vector` — the vector fragility (PGA × PGV/PGA) as a PGA fragility under a
  stated model of PGV/PGA given PGA.
* :mod:`~pbr_xval.hazard.constrain_report` and :mod:`~pbr_xval.hazard.example` — the ``pbr-xval constrain``
  report and its synthetic example.

See ``docs/hazard.md``.
"""

from __future__ import annotations

from pbr_xval.hazard.curves import (
    HazardCurve,
    poe_to_rate,
    rate_to_poe,
    read_hazard_curve,
    read_hazard_curves,
)
from pbr_xval.hazard.fragility_draws import FragilityDraws, UncertaintyResult, draws_from_profile, propagate
from pbr_xval.hazard.fragility_functions import (
    DiscreteFragility,
    LognormalFragility,
    StepFragility,
    UnionFragility,
    lognormal_to_moments,
    moments_to_lognormal,
)
from pbr_xval.hazard.ims import HazardInputError, canonical_im
from pbr_xval.hazard.survival import (
    Age,
    Constraint,
    RockInput,
    TruncationCheck,
    branches_from_quantiles,
    constrain,
    joint_survival,
    survival_probability,
    toppling_rate,
    truncation_check,
    weighted_quantile,
)
from pbr_xval.hazard.vector import PgvPgaModel, VectorFragility

__all__ = [
    "Age",
    "Constraint",
    "DiscreteFragility",
    "FragilityDraws",
    "HazardCurve",
    "HazardInputError",
    "LognormalFragility",
    "PgvPgaModel",
    "RockInput",
    "StepFragility",
    "TruncationCheck",
    "UncertaintyResult",
    "UnionFragility",
    "VectorFragility",
    "branches_from_quantiles",
    "canonical_im",
    "constrain",
    "draws_from_profile",
    "joint_survival",
    "lognormal_to_moments",
    "moments_to_lognormal",
    "poe_to_rate",
    "propagate",
    "rate_to_poe",
    "read_hazard_curve",
    "read_hazard_curves",
    "survival_probability",
    "toppling_rate",
    "truncation_check",
    "weighted_quantile",
]
