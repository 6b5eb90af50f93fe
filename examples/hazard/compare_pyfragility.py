"""Our binomial MLE (pbr_xval.catalog.fragility) against pyFragility 0.2.0 on the same data.

    pip install pyfragility==0.2.0        # only for this comparison; not a dependency
    python examples/hazard/compare_pyfragility.py [RESULTS_FOLDER]

Part 1: 200 synthetic multiple-stripe data sets (10 stripes θ·exp(β·z), z ∈ [−2, 2], 20 motions
each, θ = 3 m/s², β = 0.4, seeds 0–199). Part 2 (optional): every rock × IM of a sweep's results
folder (``pbr-xval sweep``). Prints the largest relative differences of θ, β and of the 95 %
profile-likelihood interval ends, and the CPU time per fit (process time, this machine).
"""

from __future__ import annotations

import sys
import time

import numpy as np
from scipy import stats

from pbr_xval.catalog.fragility import fit_lognormal


def _compare(levels, n, z, pf):
    x = np.repeat(levels, n)
    t = np.concatenate([np.arange(k) < zi for k, zi in zip(n, z, strict=True)])
    t0 = time.process_time()
    ours = fit_lognormal(x, t, "IM", ci_level=0.95)
    t1 = time.process_time()
    theirs = pf.fit_msa(levels, z, n)
    t2 = time.process_time()
    pt, pb = theirs.profile_interval("theta")[:2], theirs.profile_interval("beta")[:2]
    t3 = time.process_time()
    if ours.status != "ok":
        return None
    th, b = (float(v) for v in theirs.params)
    d = {
        "theta": abs(ours.theta / th - 1),
        "beta": abs(ours.beta / b - 1),
        "ci": max(
            abs(ours.theta_ci[0] / pt[0] - 1),
            abs(ours.theta_ci[1] / pt[1] - 1),
            abs(ours.beta_ci[0] / pb[0] - 1),
            abs(ours.beta_ci[1] / pb[1] - 1),
        ),
        "t_ours_fit_ci": t1 - t0,
        "t_pf_fit": t2 - t1,
        "t_pf_profile": t3 - t2,
    }
    return d


def main() -> None:
    import pyFragility as pf

    rows = []
    for seed in range(200):
        rng = np.random.default_rng(seed)
        lv = 3.0 * np.exp(0.4 * np.linspace(-2, 2, 10))
        n = np.full(lv.size, 20)
        z = rng.binomial(n, stats.norm.cdf(np.log(lv / 3.0) / 0.4))
        d = _compare(lv, n, z, pf)
        if d:
            rows.append(d)
    print(f"pyFragility {pf.__version__}: {len(rows)} synthetic MSA data sets fitted by both")
    for k in ("theta", "beta", "ci"):
        print(f"  max |rel. diff| {k:5s}: {max(r[k] for r in rows):.2e}")
    for k in ("t_ours_fit_ci", "t_pf_fit", "t_pf_profile"):
        print(f"  mean CPU {k}: {1e3 * np.mean([r[k] for r in rows]):.1f} ms")
    if len(sys.argv) > 1:
        from pbr_xval.catalog import load_results

        df = load_results(sys.argv[1])
        for (rock, eng), g in df[df["status"] == "ok"].groupby(["rock_id", "engine"]):
            for col in ("pga", "pgv"):
                f = fit_lognormal(g[col].to_numpy(float), g["toppled"].to_numpy(bool), col)
                if f.status != "ok":
                    print(f"  {eng} {rock} {col}: {f.status} (not compared)")
                    continue
                d = _compare(np.array(f.levels), np.array(f.n_per_level), np.array(f.z_per_level), pf)
                print(
                    f"  {eng} {rock} {col}: |Δθ/θ| {d['theta']:.1e}, |Δβ/β| {d['beta']:.1e}, CI ends {d['ci']:.1e}"
                )


if __name__ == "__main__":
    main()
