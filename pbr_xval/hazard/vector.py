"""The vector fragility on (PGA, PGV/PGA) under a PGA hazard with a stated PGV/PGA model.

``pbr-xval fragility`` fits ``P(topple | PGA = a, PGV/PGA = r) = Φ(b0 + b1 ln a + b2 ln r)``
(:func:`pbr_xval.catalog.fragility.fit_surface`; a in m/s², r in s). A site hazard curve is on one IM;
a joint PGA–PGV hazard (vector-valued PSHA) is not what OpenQuake's classical calculator exports,
so pbr-xval takes the route that needs only a PGA hazard: **ln(PGV/PGA) given PGA is normal**,

    ln r | a ~ N(ln r_med + c·ln(a / a_ref), σ²)

with r_med (s), σ (natural-log standard deviation) and the slope c stated by the user (from a
ground-motion model's PGV and PGA medians for the events that dominate the site's hazard, or
from a record set; c = 0: the ratio independent of the level). Then the event's toppling
probability given its PGA is, in closed form,

    P_f(a) = E[Φ(b0 + b1 ln a + b2 ln r) | a] = Φ((c0 + c1 ln a) / sqrt(1 + b2² σ²))

with c1 = b1 + b2·c and c0 = b0 + b2 (ln r_med − c ln a_ref): a lognormal on PGA with
θ = exp(−c0/c1) and β = sqrt(1 + b2²σ²)/c1 (:meth:`VectorFragility.on_pga`), used by
``constrain`` like any other PGA fragility. (E[Φ(u + bZ)] = Φ(u/√(1 + b²)) for Z ~ N(0, 1).)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from pbr_xval.hazard.fragility_functions import LognormalFragility
from pbr_xval.hazard.ims import G, HazardInputError

__all__ = ["PgvPgaModel", "VectorFragility"]


@dataclass(frozen=True)
class PgvPgaModel:
    """ln(PGV/PGA) | PGA ~ N(ln median_s + slope·ln(PGA/ref_pga), sigma_ln²); PGA in m/s², ratio in s."""

    median_s: float
    sigma_ln: float
    slope: float = 0.0
    ref_pga: float = G

    def __post_init__(self) -> None:
        if not (self.median_s > 0 and math.isfinite(self.median_s)):
            raise HazardInputError(f"PGV/PGA model: median_s = {self.median_s!r}; expected > 0 s")
        if not (self.sigma_ln >= 0 and math.isfinite(self.sigma_ln)):
            raise HazardInputError(f"PGV/PGA model: sigma_ln = {self.sigma_ln!r}; expected ≥ 0")
        if not (math.isfinite(self.slope) and self.ref_pga > 0):
            raise HazardInputError(
                f"PGV/PGA model: slope {self.slope!r}, ref_pga {self.ref_pga!r}; expected finite, > 0"
            )

    def describe(self) -> str:
        s = f"ln(PGV/PGA) | PGA ~ N(ln {self.median_s:g} s"
        if self.slope:
            s += f" + {self.slope:g}·ln(PGA/{self.ref_pga / G:g} g)"
        return s + f", {self.sigma_ln:g}²)"


@dataclass(frozen=True)
class VectorFragility:
    """``Φ(b0 + b1 ln PGA + b2 ln(PGV/PGA))``, PGA in m/s², PGV/PGA in s (``coef`` = (b0, b1, b2))."""

    id: str
    coef: tuple[float, float, float]

    def probability(self, pga: float, ratio: float) -> float:
        from scipy import stats

        b0, b1, b2 = self.coef
        return float(stats.norm.cdf(b0 + b1 * math.log(pga) + b2 * math.log(ratio)))

    def on_pga(self, model: PgvPgaModel) -> LognormalFragility:
        """The PGA fragility this vector fragility implies under ``model`` (closed form above)."""
        b0, b1, b2 = (float(v) for v in self.coef)
        if not all(math.isfinite(v) for v in (b0, b1, b2)):
            raise HazardInputError(
                f"vector fragility {self.id!r}: coef {list(self.coef)}; expected 3 finite numbers"
            )
        c1 = b1 + b2 * model.slope
        if not c1 > 0:
            raise HazardInputError(
                f"vector fragility {self.id!r}: b1 + b2·slope = {c1:.3g} under {model.describe()}; expected > 0 "
                "(P_f must rise with PGA)"
            )
        c0 = b0 + b2 * (math.log(model.median_s) - model.slope * math.log(model.ref_pga))
        d = math.sqrt(1.0 + (b2 * model.sigma_ln) ** 2)
        return LognormalFragility(
            "PGA", self.id, theta=math.exp(-c0 / c1), beta=d / c1,
            meta={"vector_coef": [b0, b1, b2], "pgv_pga_model": model.describe()},
        )  # fmt: skip
