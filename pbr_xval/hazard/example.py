"""The synthetic example of ``pbr-xval constrain --example``: every input is generated here.

1. **Hazard** — a 5 × 5 logic tree of PGA hazard curves for one site,
   ``ln λ(x) = ln λ₀ − a·ln(x/x₀) − b·ln²(x/x₀)`` (x₀ = 0.1 g, a = 1.8), with the activity rate
   λ₀ ∈ {0.4, 0.6, 1.0, 1.6, 2.5}·10⁻³ /yr and the tail curvature b ∈ {0.05, 0.12, 0.20, 0.30, 0.45}
   (weights 0.1, 0.2, 0.4, 0.2, 0.1 each; branch weight = product), on 30 levels 0.03–3 g, written as OpenQuake
   hazard-curve CSVs (poe in 50 years, IMLs in g) — the same files an OpenQuake run exports.
2. **Rocks** — three rocks with "true" lognormal PGA fragilities (θ = 0.30, 0.45, 0.60 g;
   β = 0.35, 0.30, 0.40). Each is observed through a synthetic multiple-stripe analysis: 10
   stripes θ·exp(β·z), z ∈ [−2, 2], 20 ground motions each, toppled ~ Binomial(20, P_f), seed
   fixed. The stripes are fitted by binomial MLE with profile-likelihood intervals (the same code
   as for a real sweep) and exported as an NRML ``fragilityModel`` (continuous logncdf) and CSV.
3. **Ages** — ¹⁰Be-like exposure ages 10.5 ± 1.2 ka (normal), 18 ± 3 ka (lognormal) and
   7.0 ± 0.8 ka (normal).
4. **Config** — ``constrain.toml`` naming the files (the rocks from ``rocks.csv``, which carries
   the fits' intervals; ``rocks.xml`` holds the same functions for OpenQuake);
   ``pbr-xval constrain`` runs it.

Stand-ins for real data, documented in ``docs/hazard.md``: no number of this example is a
statement about a real site.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy import stats

from pbr_xval.atomic import write_text_atomic
from pbr_xval.hazard.curves import HazardCurve, write_oq_csv
from pbr_xval.hazard.ims import G

__all__ = ["ROCKS", "write_example"]

#: (id, θ in g, β, age mean yr, age sd yr, age distribution)
ROCKS = [
    ("rock_A", 0.30, 0.35, 10500.0, 1200.0, "normal"),
    ("rock_B", 0.45, 0.30, 18000.0, 3000.0, "lognormal"),
    ("rock_C", 0.60, 0.40, 7000.0, 800.0, "normal"),
]
_W = (0.1, 0.2, 0.4, 0.2, 0.1)
_RATES = list(zip((0.4e-3, 0.6e-3, 1.0e-3, 1.6e-3, 2.5e-3), _W, strict=True))
_CURV = list(zip((0.05, 0.12, 0.20, 0.30, 0.45), _W, strict=True))
_SEED = 20240616


def example_branches() -> list[HazardCurve]:
    """The 9 synthetic logic-tree branches (PGA, SI levels, 1/yr)."""
    x_g = np.geomspace(0.03, 3.0, 30)
    out = []
    for i, (l0, w1) in enumerate(_RATES):
        for j, (b, w2) in enumerate(_CURV):
            u = np.log(x_g / 0.1)
            lam = l0 * np.exp(-1.8 * u - b * u * u)
            out.append(HazardCurve("PGA", x_g * G, lam, name=f"rlz-{len(_CURV) * i + j:03d}", weight=w1 * w2))
    return out


def _stripes(theta: float, beta: float, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    levels = theta * np.exp(beta * np.linspace(-2.0, 2.0, 10))
    x = np.repeat(levels, 20)
    t = rng.uniform(size=x.size) < stats.norm.cdf(np.log(x / theta) / beta)
    return x, t


def write_example(out: str | Path) -> Path:
    """Write the synthetic inputs into ``out/inputs`` and return the path of ``constrain.toml``."""
    from pbr_xval.catalog.fragility import fit_lognormal
    from pbr_xval.hazard.fragility_functions import LognormalFragility
    from pbr_xval.hazard.nrml import write_fragility_csv, write_fragility_model

    d = Path(out) / "inputs"
    (d / "hazard").mkdir(parents=True, exist_ok=True)
    toml = ['name = "synthetic-site"', 'joint = "independent"', "rate_of_interest = 1e-4",
            "quantiles = [0.05, 0.5, 0.95]", "", "[hazard]", 'tail = "powerlaw"']  # fmt: skip
    for c in example_branches():
        f = d / "hazard" / f"hazard_curve-{c.name}-PGA_0.csv"
        write_oq_csv(c, f, investigation_time=50.0, kind=c.name, lon=-118.92, lat=34.08)
        toml += [
            "",
            "[[hazard.branch]]",
            f'file = "hazard/{f.name}"',
            f"weight = {c.weight!r}",
            f'name = "{c.name}"',
        ]
    rng = np.random.default_rng(_SEED)
    frags, rows, stripes = [], [], ["rock_id,pga_m_s2,toppled"]
    for rid, th_g, beta, *_ in ROCKS:
        x, t = _stripes(th_g * G, beta, rng)
        stripes += [f"{rid},{xi:.6g},{int(ti)}" for xi, ti in zip(x, t, strict=True)]
        fit = fit_lognormal(x, t, "PGA", ci_level=0.95)
        if fit.status != "ok":  # pragma: no cover - the seed is fixed
            raise RuntimeError(f"synthetic stripes of {rid}: {fit.status} ({fit.message})")
        frags.append(
            LognormalFragility(
                "PGA", rid, theta=fit.theta, beta=fit.beta, theta_ci=fit.theta_ci, beta_ci=fit.beta_ci
            )
        )
        rows.append({"id": rid, "im": "PGA", "theta": fit.theta, "beta": fit.beta, "theta_lo": fit.theta_ci[0],
                     "theta_hi": fit.theta_ci[1], "beta_lo": fit.beta_ci[0], "beta_hi": fit.beta_ci[1], "ci_level": 0.95,
                     "n_runs": fit.n_runs, "n_toppled": fit.n_toppled, "status": "ok",
                     "source": f"synthetic stripes, true θ = {th_g * G:.4g} m/s², β = {beta}"})  # fmt: skip
    (d / "fragility").mkdir(exist_ok=True)
    write_text_atomic(d / "fragility" / "stripes.csv", "\n".join(stripes) + "\n")
    write_fragility_model(d / "fragility" / "rocks.xml", frags, "continuous",
                          description="synthetic example rocks (pbr-xval constrain --example)")  # fmt: skip
    write_fragility_model(d / "fragility" / "rocks_discrete.xml", frags, "discrete",
                          description="synthetic example rocks, discrete form")  # fmt: skip
    write_fragility_csv(d / "fragility" / "rocks.csv", rows)
    for rid, _, _, age, sd, dist in ROCKS:
        toml += ["", "[[rock]]", f'id = "{rid}"', 'fragility = "fragility/rocks.csv"', f"age = {age!r}",
                 f"age_sd = {sd!r}", f'age_dist = "{dist}"']  # fmt: skip
    return write_text_atomic(d / "constrain.toml", "\n".join(toml) + "\n")


def true_fragility_median_g() -> dict[str, float]:
    """The generating medians (g) — for tests comparing the fit with the truth."""
    return {rid: th for rid, th, *_ in ROCKS}
