"""pbr_xval.validation.sensitivity: Morris members follow the inputs' distributions; indices of known functions."""

from __future__ import annotations

import numpy as np
import pytest

from pbr_xval.uncertainty import parse_uncertainty
from pbr_xval.validation.sensitivity import morris_indices, morris_members


def test_morris_members_and_indices_of_a_known_function() -> None:
    spec = parse_uncertainty(
        {
            "contact.friction_static": {"dist": "uniform", "low": 0.5, "high": 0.8},
            "excitation.azimuth_deg": {"dist": "uniform", "low": 0.0, "high": 360.0},
            "model.collision": {"dist": "choice", "values": ["hull", "coacd"]},
        }
    )
    problem, members, x = morris_members(spec, "mujoco", trajectories=6, levels=4, seed=1)
    assert problem["names"] == ["contact.friction_static", "excitation.azimuth_deg"]  # choice left out
    assert len(members) == len(x) == 6 * 3 and {m.engine for m in members} == {"mujoco"}
    mu = np.array([m.values["contact.friction_static"] for m in members])
    assert mu == pytest.approx(0.5 + 0.3 * np.clip(x[:, 0], 1e-6, 1 - 1e-6))
    # y = 3·u₀: every elementary effect of input 0 is 3 (per unit-cube step), of input 1 zero
    t = morris_indices(problem, x, 3.0 * x[:, 0], levels=4)
    assert t.loc["contact.friction_static", "mu_star"] == pytest.approx(3.0)
    assert t.loc["contact.friction_static", "sigma"] == pytest.approx(0.0, abs=1e-12)
    assert t.loc["excitation.azimuth_deg", "mu_star"] == pytest.approx(0.0, abs=1e-12)
    # y = u₀·u₁: effects of input 0 vary with u₁ (σ > 0, an interaction)
    t2 = morris_indices(problem, x, x[:, 0] * x[:, 1], levels=4)
    assert t2.loc["contact.friction_static", "sigma"] > 0.05
