"""SP1 end to end: the validated granite specimen's fragility → survival → reweighted site hazard.

    pbr-xval validate ../shared/data/shake_table --specimen 1 --scenario examples/validation/sp1.toml \
        --engine mujoco --out VALIDATE_DIR                     # 196 tests; F1 0.886 (docs/validation.md)
    python examples/hazard/sp1/run_sp1.py VALIDATE_DIR [--out reports/hazard_sp1] [--members ENSEMBLE.csv]

1. **Fragility.** The model's predictions on the 196 calibration tests (MuJoCo, the committed
   scenario ``examples/validation/sp1.toml``) as a multiple-stripe data set: each test's table
   record, its PGA (corrected record, SI) and the predicted outcome. Lognormal on PGA by binomial
   MLE with 95 % profile-likelihood intervals (``pbr_xval.catalog.fragility.fit_lognormal``), and
   the vector fragility on (PGA, PGV/PGA). With ``--members`` (an ensemble's
   ``ensemble_members.csv``: ``test, record, member, pga_m_s2, toppled, status``) the fragility is
   fitted to the members and its draws are the refits of a record-clustered bootstrap
   (``fit_ensemble_fragility``), each a member of the rock's ``ensemble`` file.
2. **Site (synthetic, a stand-in):** three PGA hazard branches
   ``ln λ = ln λ₀ − a·ln(x/0.1 g) − b·ln²(x/0.1 g)`` on 40 levels 0.005–3 g, written as OpenQuake
   hazard-curve CSVs (poe in 50 yr, g): low (λ₀ 1.0e-4 /yr, a 1.8, b 0.10, weight 0.3), central
   (2.5e-4, 1.8, 0.15, 0.4), high (6.0e-4, 1.6, 0.20, 0.3). SP1 is treated as if it stood at this
   site with an exposure age of 10 ± 1 ka (normal). Nothing here describes a real site.
3. **Run** ``pbr-xval constrain`` → ``OUT/index.html`` (the fragility's draws carried into P_s),
   and the vector variant → ``OUT/vector/`` with a stated model of PGV/PGA given PGA (median 0.10 s,
   σ_ln 0.35: PGV [cm/s] ≈ 100 × PGA [g], typical of shallow crustal events at moderate distance).

The shake-table data stay in ``../shared/data``; only fitted parameters are written.
"""

from __future__ import annotations

import argparse
import csv
import json
import sys
from pathlib import Path

import numpy as np

G = 9.80665
BRANCHES = [
    ("low", 1.0e-4, 1.8, 0.10, 0.3),
    ("central", 2.5e-4, 1.8, 0.15, 0.4),
    ("high", 6.0e-4, 1.6, 0.20, 0.3),
]
AGE, AGE_SD = 10000.0, 1000.0
PGV_PGA = {"median_s": 0.10, "sigma_ln": 0.35}


def _outcomes(path: Path, engine: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[str], np.ndarray]:
    rows = list(csv.DictReader(path.read_text().splitlines()))
    ok = [
        r
        for r in rows
        if r.get(f"status_{engine}", "ok") == "ok" and r.get(f"pred_{engine}", "") in ("0", "1")
    ]
    pga = np.array([float(r["pga_m_s2"]) for r in ok])
    ratio = np.array([float(r["pgv_over_pga_s"]) for r in ok])
    pred = np.array([r[f"pred_{engine}"] == "1" for r in ok])
    obs = np.array([r["observed"] == "1" for r in ok])
    return pga, ratio, pred, [r["motion"] for r in ok], obs


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("validate_dir", type=Path, help="pbr-xval validate output (outcomes.csv)")
    ap.add_argument("--out", type=Path, default=Path("reports/hazard_sp1"))
    ap.add_argument("--engine", default="mujoco")
    ap.add_argument("--members", type=Path, default=None, help="ensemble_members.csv of an ensemble run")
    ap.add_argument(
        "--bootstrap", action="store_true",
        help="deterministic outcomes, band from a record-clustered bootstrap (fit_ensemble_fragility, 1 member per test)",
    )  # fmt: skip
    a = ap.parse_args(argv)

    from pbr_xval.catalog.fragility import fit_lognormal, fit_surface
    from pbr_xval.cli.hazard_impl import constrain_command
    from pbr_xval.hazard.curves import HazardCurve, write_oq_csv
    from pbr_xval.hazard.fragility_functions import LognormalFragility
    from pbr_xval.hazard.nrml import write_fragility_csv, write_fragility_model

    pga, ratio, pred, _motions, obs = _outcomes(a.validate_dir / "outcomes.csv", a.engine)
    inp = a.out / "inputs"
    (inp / "hazard").mkdir(parents=True, exist_ok=True)
    (inp / "fragility").mkdir(parents=True, exist_ok=True)
    fit = fit_lognormal(pga, pred, "PGA", ci_level=0.95)
    lab = fit_lognormal(pga, obs, "PGA", ci_level=0.95)
    surf = fit_surface(pga, ratio, pred)
    if fit.status != "ok" or not surf.converged:
        print(f"fit failed: {fit.status} {fit.message}; surface {surf.status}", file=sys.stderr)
        return 1
    src = f"SP1, {a.engine}, examples/validation/sp1.toml: {fit.n_runs} shake-table tests ({fit.n_toppled} predicted topples)"
    row = {"id": "SP1", "im": "PGA", "theta": fit.theta, "beta": fit.beta, "theta_lo": fit.theta_ci[0],
           "theta_hi": fit.theta_ci[1], "beta_lo": fit.beta_ci[0], "beta_hi": fit.beta_ci[1], "ci_level": 0.95,
           "n_runs": fit.n_runs, "n_toppled": fit.n_toppled, "status": "ok", "source": src}  # fmt: skip
    method = "profile"
    rock_extra = ""
    if a.members is not None or a.bootstrap:
        # through `pbr-xval fragility … --ensemble` (pbr_xval.cli.fragility_ensemble_impl): the member runs'
        # fit and its two-stage bootstrap (records, then each test's members); its draws file is the rock's
        # `ensemble`. The deterministic outcomes enter as a one-member ensemble (a record-clustered
        # bootstrap); the per-test table is written to a temporary folder, not next to the report.
        import tempfile

        from pbr_xval.cli.fragility_ensemble_impl import ensemble_fragility_command

        with tempfile.TemporaryDirectory() as td:
            members = a.members
            if members is None:
                members = Path(td) / "members.csv"
                lines = ["test,record,member,engine,pga_m_s2,pgv_m_s,toppled,status"]
                lines += [f"{i},{m},0,{a.engine},{x!r},{x * r!r},{bool(t)},ok"
                          for i, (x, r, t, m) in enumerate(zip(pga.tolist(), ratio.tolist(), pred, _motions, strict=True))]  # fmt: skip
                members.write_text("\n".join(lines) + "\n")
            if ensemble_fragility_command(members, n_boot=400, seed=0, out=Path(td) / "frag"):
                print("ensemble fragility failed", file=sys.stderr)
                return 1
            fr = next(
                iter(
                    csv.DictReader(
                        (Path(td) / "frag" / "ensemble_fragility_pga.csv").read_text().splitlines()
                    )
                )
            )
            (inp / "fragility" / "sp1_draws.csv").write_text(
                (Path(td) / "frag" / "ensemble_fragility_pga_draws.csv").read_text()
            )
        n_mem = float(fr["members_per_test"])
        row.update({"theta": float(fr["theta_m_s2"]), "beta": float(fr["beta"]), "theta_lo": float(fr["theta_lo_m_s2"]),
                    "theta_hi": float(fr["theta_hi_m_s2"]), "beta_lo": float(fr["beta_lo"]), "beta_hi": float(fr["beta_hi"]),
                    "n_runs": int(fr["n_runs"]), "n_toppled": int(fr["n_toppled"]),
                    "source": f"SP1 {'ensemble' if a.members else a.engine}: {fr['n_tests']} tests × {n_mem:.0f} "
                              f"member(s), {int(fr['bootstrap']) - int(fr['bootstrap_failed'])} two-stage bootstrap refits"})  # fmt: skip
        method = (
            "ensemble members' bootstrap" if a.members else "record-clustered bootstrap (one member per test)"
        )
        rock_extra = 'ensemble = "fragility/sp1_draws.csv"\n'
    write_fragility_csv(inp / "fragility" / "sp1.csv", [row])
    frag = LognormalFragility("PGA", "SP1", theta=row["theta"], beta=row["beta"])
    write_fragility_model(inp / "fragility" / "sp1.xml", [frag], "continuous", description=src)
    desc = (f"description = \"SP1 is a granite shake-table specimen (Chen et al. 2024), its fragility the model's "
            f"({a.engine}, examples/validation/sp1.toml) on {fit.n_runs} uniaxial table tests; the site hazard (3 "
            "branches), the exposure age (10 ± 1 ka) and the placement of SP1 at the site are synthetic stand-ins, "
            "not statements about a real site. The table is uniaxial: the hazard's PGA component definition "
            "(e.g. RotD50) is not the table's.\"")  # fmt: skip
    toml = ['name = "SP1 at a synthetic site"', desc, "rate_of_interest = 1e-4", "im_of_interest = 0.2",
            "quantiles = [0.05, 0.5, 0.95]", "fragility_draws = 512", "", "[hazard]", 'tail = "powerlaw"']  # fmt: skip
    x_g = np.geomspace(0.005, 3.0, 40)
    for name, l0, s, b, w in BRANCHES:
        u = np.log(x_g / 0.1)
        c = HazardCurve("PGA", x_g * G, l0 * np.exp(-s * u - b * u * u), name=name, weight=w)
        write_oq_csv(c, inp / "hazard" / f"hazard_curve-{name}-PGA.csv", 50.0, name, -117.0, 34.0)
        toml += ["", "[[hazard.branch]]", f'file = "hazard/hazard_curve-{name}-PGA.csv"', f"weight = {w!r}",
                 f'name = "{name}"']  # fmt: skip
    rock = f'[[rock]]\nid = "SP1"\nage = {AGE!r}\nage_sd = {AGE_SD!r}\nage_dist = "normal"\n'
    (inp / "constrain.toml").write_text(
        "\n".join(toml) + f'\n\n{rock}fragility = "fragility/sp1.csv"\n{rock_extra}'
    )
    b0, b1, b2 = surf.coef
    pv = f"\n[hazard.pgv_pga]\nmedian_s = {PGV_PGA['median_s']}\nsigma_ln = {PGV_PGA['sigma_ln']}\n"
    pv += 'source = "stated: PGV [cm/s] ≈ 100 × PGA [g] (shallow crustal, moderate distance), ln scatter 0.35"\n'
    vt = "\n".join(toml).replace(
        'name = "SP1 at a synthetic site"', 'name = "SP1 at a synthetic site (vector fragility)"'
    )
    vt = vt.replace('tail = "powerlaw"', 'tail = "powerlaw"' + pv)
    (inp / "constrain_vector.toml").write_text(vt + f"\n\n{rock}vector_coef = [{b0!r}, {b1!r}, {b2!r}]\n")
    meta = {
        "fragility_pga": {"theta_g": fit.theta / G, "beta": fit.beta, "theta_ci_g": [v / G for v in fit.theta_ci],
                          "beta_ci": list(fit.beta_ci), "n_tests": fit.n_runs, "n_toppled": fit.n_toppled},
        "lab_observed_pga": {"theta_g": lab.theta / G, "beta": lab.beta, "theta_ci_g": [v / G for v in lab.theta_ci],
                             "beta_ci": list(lab.beta_ci), "n_toppled": lab.n_toppled},
        "vector": {"coef": [b0, b1, b2], "dispersion_at_fixed_ratio": 1 / b1,
                   "lab_median_pgv_pga_s": float(np.median(ratio))},
        "fragility_uncertainty": method, "engine": a.engine,
        "band_theta_ci_g": [row["theta_lo"] / G, row["theta_hi"] / G], "band_beta_ci": [row["beta_lo"], row["beta_hi"]],
    }  # fmt: skip
    (inp / "sp1_fit.json").write_text(json.dumps(meta, indent=2) + "\n")
    print(f"SP1 PGA fragility ({a.engine}): θ = {fit.theta / G:.3f} g [{fit.theta_ci[0] / G:.3f}, "
          f"{fit.theta_ci[1] / G:.3f}], β = {fit.beta:.2f} [{fit.beta_ci[0]:.2f}, {fit.beta_ci[1]:.2f}]; lab outcomes: "
          f"θ = {lab.theta / G:.3f} g, β = {lab.beta:.2f}; vector b = ({b0:.3g}, {b1:.3g}, {b2:.3g})")  # fmt: skip
    code = constrain_command(inp / "constrain.toml", a.out)
    if code:
        return code
    code = constrain_command(inp / "constrain_vector.toml", a.out / "vector")
    (a.out / "README.md").write_text(
        "# SP1 end to end: fragility → survival → reweighted synthetic site hazard\n\n"
        f"Written by `python examples/hazard/sp1/run_sp1.py VALIDATE_DIR --out {a.out}"
        + (" --bootstrap" if a.bootstrap else "")
        + (" --members …" if a.members else "")
        + "` from the "
        f"`pbr-xval validate … --specimen 1 --scenario examples/validation/sp1.toml --engine {a.engine}` outcomes "
        f"({fit.n_runs} calibration tests). "
        + (
            "The fragility is an ensemble's (`--members`). "
            if a.members
            else "The fragility is SP1's **deterministic** one (one engine, the committed scenario: the model's yes/no per "
            "test), not an ensemble fragility: no SP1 ensemble run existed when this was written. "
        )
        + f"Its band: {method}, θ ∈ [{row['theta_lo'] / G:.3f}, {row['theta_hi'] / G:.3f}] g, β ∈ "
        f"[{row['beta_lo']:.2f}, {row['beta_hi']:.2f}] (95 %). `index.html`: the scalar PGA fragility; "
        "`vector/index.html`: the vector fragility under the stated PGV/PGA model. Inputs in `inputs/` "
        "(fitted parameters only; the shake-table data stay in ../shared/data). See docs/hazard.md.\n"
    )
    return code


if __name__ == "__main__":
    raise SystemExit(main())
