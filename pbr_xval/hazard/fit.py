"""Fragility of a rock from a sweep, ready for hazard: several IMs, intervals, vector fragility.

A sweep of records × scale factors (multiple-stripe analysis) gives, per rock, (IM, toppled)
pairs. For each IM — PGA, PGV and SA(T) at the periods asked for — the lognormal fragility is
fitted by binomial maximum likelihood (Baker 2015; :func:`pbr_xval.catalog.fragility.fit_lognormal`)
with **profile-likelihood** confidence intervals on θ and β. The vector fragility
``P = Φ(b0 + b1 ln PGA + b2 ln(PGV/PGA))`` is the probit fit of
:func:`pbr_xval.catalog.fragility.fit_surface`; its dispersion in ln PGA at fixed PGV/PGA is 1/b1,
and a likelihood-ratio test says whether PGV/PGA adds information to PGA alone.

IMs are compared by efficiency: the smaller β, the better the IM predicts toppling — the IM the
rock is most sensitive to. (β of different IMs are comparable: each is a log-standard deviation.)

SA(T) is not stored by a sweep; :func:`sweep_intensity_measures` recomputes it from the catalog,
building each rock × motion excitation exactly as the sweep did (5 % damping by default).
"""

from __future__ import annotations

import json
import math
from typing import Any

import numpy as np
from scipy import stats

from pbr_xval.catalog.fragility import fit_lognormal, fit_surface
from pbr_xval.hazard.ims import canonical_im

__all__ = ["compare_ims", "fit_sweep", "sweep_intensity_measures"]

_COL = {"PGA": "pga", "PGV": "pgv"}


def sweep_intensity_measures(catalog: Any, periods: list[float], damping: float = 0.05) -> Any:
    """SA(T) (m/s²) of every rock × motion of a catalog, as the sweep's scenarios define them.

    Returns
    -------
    pandas.DataFrame
        Columns ``rock_id``, ``motion_id``, ``PGA`` (m/s²), ``PGV`` (m/s), ``SA(T)`` (m/s²) for each T.
    """
    import pandas as pd

    from pbr_xval.catalog.tasks import build_chunks, scenario_dict
    from pbr_xval.motion import intensity_measures
    from pbr_xval.scenario import scenario_from_dict
    from pbr_xval.scene import compile_scene

    engine = catalog.engines[0]
    rows = []
    seen: set[tuple[str, str]] = set()
    for spec in build_chunks(catalog, engines=[engine]):
        for m in spec.motions:
            key = (spec.rock["id"], m["id"])
            if key in seen:
                continue
            seen.add(key)
            scene = compile_scene(scenario_from_dict(scenario_dict(spec, m, 1.0, 0)))
            im = intensity_measures(scene.excitation.horizontal, periods=tuple(periods), damping=damping)
            row = {"rock_id": key[0], "motion_id": key[1], "PGA": im["PGA"], "PGV": im["PGV"]}
            for T in periods:
                row[canonical_im(f"SA({float(T)!r})")] = float(im[f"Sa({float(T)!r})"])
            rows.append(row)
    return pd.DataFrame(rows)


def fit_sweep(
    results: Any,
    ims: tuple[str, ...] = ("PGA", "PGV"),
    extra_ims: Any = None,
    ci_level: float = 0.95,
    min_runs: int = 2,
) -> Any:
    """Per engine × rock: lognormal MLE fragility on each IM with profile-likelihood CIs, and the
    vector fragility on (PGA, PGV/PGA).

    Parameters
    ----------
    results : pandas.DataFrame
        :func:`pbr_xval.catalog.load_results` output (only ``status == 'ok'`` runs count).
    ims : tuple of str
        IMs to fit; ``SA(T)`` needs ``extra_ims``.
    extra_ims : pandas.DataFrame, optional
        :func:`sweep_intensity_measures` output, merged on (rock_id, motion_id).
    ci_level : float

    Returns
    -------
    pandas.DataFrame
        One row per engine × profile × settings × rock × IM: ``im``, ``unit``, ``theta`` (IM units,
        SI), ``beta``, ``theta_lo``, ``theta_hi``, ``beta_lo``, ``beta_hi``, ``loglik``, counts,
        ``status``, ``message``; plus an ``im = "PGA|PGV/PGA"`` row per rock with the vector fit
        (``beta`` = 1/b1, ``theta`` = median PGA at the runs' median PGV/PGA, ``coef`` = [b0, b1, b2],
        ``lr_p`` = p-value of the likelihood-ratio test against PGA alone).
    """
    import pandas as pd

    from pbr_xval.hazard.ims import im_unit

    df = results[results["status"] == "ok"].copy()
    names = [canonical_im(i) for i in ims]
    if extra_ims is not None and len(extra_ims):
        keep = ["rock_id", "motion_id"] + [c for c in extra_ims.columns if c.startswith("SA(")]
        df = df.merge(extra_ims[keep], on=["rock_id", "motion_id"], how="left")
    for n in names:
        col = _COL.get(n, n)
        if col not in df.columns:
            raise ValueError(
                f"IM {n}: column {col!r} not in the results; SA(T) needs sweep_intensity_measures()"
            )
    keys = ["engine", "profile", "settings", "rock_id"]
    rows = []
    for key, g in df.groupby(keys, sort=True):
        base = dict(zip(keys, key, strict=True))
        t = g["toppled"].to_numpy(bool)
        pga_fit = None
        for n in names:
            f = fit_lognormal(g[_COL.get(n, n)].to_numpy(float), t, n, min_runs=min_runs, ci_level=ci_level)
            if n == "PGA":
                pga_fit = f
            rows.append({**base, "im": n, "unit": im_unit(n), "theta": f.theta, "beta": f.beta,
                         "theta_lo": f.theta_ci[0], "theta_hi": f.theta_ci[1], "beta_lo": f.beta_ci[0],
                         "beta_hi": f.beta_ci[1], "ci_level": ci_level, "loglik": f.loglik, "n_runs": f.n_runs,
                         "n_toppled": f.n_toppled, "status": f.status, "message": f.message, "coef": "", "lr_p": math.nan})  # fmt: skip
        s = fit_surface(g["pga"].to_numpy(float), g["pgv_pga"].to_numpy(float), t)
        b = s.coef
        ok = s.converged and s.status == "ok"
        ratio = float(np.median(g["pgv_pga"].to_numpy(float)))
        lr_p = math.nan
        if ok and pga_fit is not None and pga_fit.converged:
            lr = 2.0 * (s.loglik - pga_fit.loglik)
            lr_p = float(stats.chi2.sf(max(lr, 0.0), 1))
        rows.append({**base, "im": "PGA|PGV/PGA", "unit": im_unit("PGA"),
                     "theta": float(s.median_pga(ratio)) if ok else math.nan,
                     "beta": 1.0 / b[1] if ok and b[1] > 0 else math.nan,
                     "theta_lo": math.nan, "theta_hi": math.nan, "beta_lo": math.nan, "beta_hi": math.nan,
                     "ci_level": ci_level, "loglik": s.loglik, "n_runs": s.n_runs, "n_toppled": s.n_toppled,
                     "status": s.status, "message": s.message or f"median PGA at PGV/PGA = {ratio:.4g} s",
                     "coef": json.dumps([round(v, 6) for v in b]), "lr_p": lr_p})  # fmt: skip
    return pd.DataFrame(rows)


def compare_ims(fits: Any) -> Any:
    """Per engine × rock: the fitted IMs ranked by dispersion β (smallest first = most efficient,
    the IM toppling is most sensitive to), with the vector fit's verdict on PGV/PGA. A completely
    separated IM (every non-toppling run below every toppling one: β → 0) ranks first.

    Returns
    -------
    pandas.DataFrame
        ``engine``, ``rock_id``, ``ranking`` (``"PGV (β 0.21) < PGA (β 0.35) < …"``), ``best_im``,
        ``best_beta``, ``pgv_pga_adds`` (likelihood-ratio p < 0.05), ``lr_p``.
    """
    import pandas as pd

    rows = []
    for (eng, rock), g in fits.groupby(["engine", "rock_id"], sort=True):
        sc = g[(g["im"] != "PGA|PGV/PGA") & g["status"].isin(["ok", "separated"])].sort_values("beta")
        vec = g[g["im"] == "PGA|PGV/PGA"]
        lr_p = float(vec["lr_p"].iloc[0]) if len(vec) else math.nan
        rows.append({
            "engine": eng, "rock_id": rock,
            "ranking": " < ".join(
                f"{r.im} (β {r.beta:.3g})" if r.status == "ok" else f"{r.im} (β → 0: separated)" for r in sc.itertuples()
            ) or "no converged fit",
            "best_im": sc["im"].iloc[0] if len(sc) else "", "best_beta": float(sc["beta"].iloc[0]) if len(sc) else math.nan,
            "pgv_pga_adds": bool(lr_p < 0.05) if lr_p == lr_p else None, "lr_p": lr_p,
        })  # fmt: skip
    return pd.DataFrame(rows)
