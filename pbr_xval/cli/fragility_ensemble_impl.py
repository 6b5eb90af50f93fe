"""``pbr-xval fragility RESULTS --ensemble``: lognormal fragility of ensemble members with its band.

RESULTS is a ``validate --ensemble`` report folder (its ``ensemble_members.csv``), that CSV
itself, or a results store holding ensemble member runs (``<out>/store``). Every member run is
one binomial trial at its test's IM; :func:`pbr_xval.catalog.fragility.fit_ensemble_fragility`
fits θ, β and the two-stage bootstrap band (records, then members). Written per IM (PGA in
m/s², PGV in m/s; units in the column names):

* ``ensemble_fragility_<im>.csv`` — θ, β, their bootstrap and profile-likelihood intervals, counts;
* ``ensemble_fragility_<im>_draws.csv`` — the bootstrap (θ, β) pairs, for hazard codes to draw from;
* ``ensemble_fragility_<im>_band.csv`` — P(topple | IM) of the fit and its band on an IM grid.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

__all__ = ["ensemble_fragility_command", "read_member_runs"]

#: IM → (column of the member table, unit suffix of the output columns, unit label)
IMS = {"pga": ("pga_m_s2", "m_s2", "m/s²"), "pgv": ("pgv_m_s", "m_s", "m/s")}


def read_member_runs(results: Path) -> pd.DataFrame:
    """One row per member run: test, record, member, engine, pga_m_s2, pgv_m_s, toppled, status.

    Raises
    ------
    ValueError
        one line naming ``results`` when it holds no ensemble member runs.
    """
    p = Path(results)
    csv = p / "ensemble_members.csv" if p.is_dir() else p
    if csv.is_file() and csv.suffix == ".csv":
        df = pd.read_csv(csv, dtype={"test": str, "record": str})
        need = {"test", "member", "toppled", "status", "pga_m_s2", "pgv_m_s"}
        if not need <= set(df.columns):
            raise ValueError(
                f"{csv}: columns {sorted(need - set(df.columns))} missing; expected ensemble_members.csv"
            )
        if "record" not in df.columns:
            df["record"] = df["test"]
        return df
    from pbr_xval.catalog.store import chunk_files, load_results

    store = p / "store" if (p / "store").is_dir() else p
    if not p.is_dir() or not chunk_files(store):
        raise ValueError(
            f"{results}: no ensemble_members.csv and no results store; expected a `validate --ensemble` report "
            "folder, its ensemble_members.csv, or a store of ensemble runs"
        )
    rows = load_results(store)
    recs = []
    for r in rows.itertuples():
        prm = json.loads(r.motion_params)
        if "member" not in prm:
            continue
        test = str(prm.get("test", r.motion_id))
        recs.append({"test": test, "record": str(prm.get("motion", test)), "member": int(prm["member"]),
                     "engine": r.engine, "pga_m_s2": r.pga, "pgv_m_s": r.pgv, "toppled": bool(r.toppled),
                     "status": str(r.status)})  # fmt: skip
    if not recs:
        raise ValueError(
            f"{store}: no ensemble member runs (only deterministic ones); expected validate --ensemble runs"
        )
    return pd.DataFrame(recs).drop_duplicates(["test", "member", "engine"])


def ensemble_fragility_command(
    results: Path,
    *,
    engine: str | None = None,
    ci: float = 0.95,
    n_boot: int = 200,
    seed: int = 0,
    out: Path = Path("reports/fragility"),
    console: Any = None,
) -> int:
    """Fit PGA and PGV fragilities to the member runs in ``results``; write the CSVs into ``out``."""
    from rich.markup import escape

    from pbr_xval.atomic import write_text_atomic
    from pbr_xval.catalog.fragility import fit_ensemble_fragility
    from pbr_xval.console import make_console

    con = make_console(console)

    def fail(msg: str) -> int:
        con.print("[red]error:[/red] " + escape(msg), highlight=False, soft_wrap=True)
        return 2

    if not 0 < ci < 1:
        return fail(f"--ci {ci!r}: expected a confidence level in (0, 1), e.g. 0.95")
    if n_boot < 0:
        return fail(f"--bootstrap {n_boot}: expected a number of refits ≥ 0")
    if out.exists() and not out.is_dir():
        return fail(f"--out {out}: is a file; expected a folder")
    try:
        df = read_member_runs(results)
    except ValueError as exc:
        return fail(str(exc))
    if engine is not None:
        df = df[df["engine"] == engine]
    df = df[df["status"] == "ok"]
    if df.empty:
        return fail(f"{results}: no successful member run" + (f" of engine {engine!r}" if engine else ""))
    out.mkdir(parents=True, exist_ok=True)
    code = 0
    for im, (col, unit, label) in IMS.items():
        f = fit_ensemble_fragility(
            df[col].to_numpy(float), df["toppled"].to_numpy(bool), df["test"].to_numpy(), df["record"].to_numpy(),
            im_name=im.upper(), n_boot=n_boot, level=ci, seed=seed,
        )  # fmt: skip
        row = {
            f"theta_{unit}": f.theta, f"theta_lo_{unit}": f.theta_ci[0], f"theta_hi_{unit}": f.theta_ci[1],
            "beta": f.beta, "beta_lo": f.beta_ci[0], "beta_hi": f.beta_ci[1],
            f"theta_profile_lo_{unit}": f.theta_profile_ci[0], f"theta_profile_hi_{unit}": f.theta_profile_ci[1],
            "beta_profile_lo": f.beta_profile_ci[0], "beta_profile_hi": f.beta_profile_ci[1],
            "level": f.level, "n_tests": f.n_tests, "n_records": f.n_groups, "n_runs": f.n_runs,
            "n_toppled": f.n_toppled, "members_per_test": f.members_per_test, "bootstrap": f.n_boot,
            "bootstrap_failed": f.boot_failed, "status": f.status, "message": f.message,
            "band": "two-stage bootstrap percentile: records resampled, then each test's members",
        }  # fmt: skip
        write_text_atomic(
            out / f"ensemble_fragility_{im}.csv", pd.DataFrame([row]).to_csv(index=False), hidden=True
        )
        draws = pd.DataFrame(f.draws, columns=[f"theta_{unit}", "beta"])
        draws.insert(0, "draw", range(len(draws)))
        write_text_atomic(out / f"ensemble_fragility_{im}_draws.csv", draws.to_csv(index=False), hidden=True)
        x = df[col].to_numpy(float)
        x = x[np.isfinite(x) & (x > 0)]
        grid = np.geomspace(x.min() / 2, x.max() * 2, 60) if x.size else np.array([])
        p, lo, hi = f.band(grid)
        band = pd.DataFrame({f"{im}_{unit}": grid, "p_fit": p, "p_lo": lo, "p_hi": hi})
        write_text_atomic(out / f"ensemble_fragility_{im}_band.csv", band.to_csv(index=False), hidden=True)
        pct = f"{100 * ci:g} %"
        if f.status == "ok":
            con.print(
                f"{im.upper()}: θ = {f.theta:.4g} {label} [{f.theta_ci[0]:.4g}, {f.theta_ci[1]:.4g}], "
                f"β = {f.beta:.3f} [{f.beta_ci[0]:.3f}, {f.beta_ci[1]:.3f}] ({pct} two-stage bootstrap: "
                f"{f.n_groups} records, {f.n_tests} tests, {f.members_per_test:.3g} members per test; "
                f"{f.n_boot - f.boot_failed} of {f.n_boot} refits usable)",
                highlight=False, soft_wrap=True,
            )  # fmt: skip
        else:
            code = 1
            con.print(
                escape(f"{im.upper()}: no fit ({f.status}: {f.message})"), highlight=False, soft_wrap=True
            )
    con.print(f"wrote {escape(str(out))}/ensemble_fragility_{{pga,pgv}}[_draws|_band].csv", highlight=False)
    return code
