"""Plain functions behind ``pbr-xval fragility`` and ``pbr-xval constrain``.

Both return a process exit code: 0 success, 1 nothing usable came out, 2 invalid input.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from pbr_xval.console import make_console

__all__ = ["constrain_command", "fragility_command"]


def _error(con: Any, msg: str) -> int:
    from rich.markup import escape

    con.print("[red]error:[/red] " + escape(msg), highlight=False, soft_wrap=True)
    return 2


def _unreadable_chunk(results: Path) -> str | None:
    """The first chunk file of a results store that is not readable Parquet, as a message (None: all read)."""
    import pyarrow.parquet as pq

    from pbr_xval.catalog.store import chunk_files

    for f in chunk_files(results):
        try:
            pq.read_metadata(f)
        except Exception as exc:  # truncated, empty, or not Parquet at all
            why = str(exc).split(". ")[0].split(": ")[-1]
            return (
                f"{f}: not a readable Parquet chunk ({why}); expected a complete chunk file (delete it and "
                "rerun the sweep to recompute it)"
            )
    return None


def fragility_command(
    results: Path,
    catalog: Path | None,
    periods: list[float],
    engine: str | None = None,
    ci: float = 0.95,
    out: Path = Path("reports/fragility"),
    console: Any = None,
) -> int:
    """Fit every rock of a sweep on PGA, PGV and SA(``periods``); write ``fits.csv``,
    ``im_comparison.csv``, ``fragility.csv`` and NRML (continuous and discrete) into ``out``."""
    from rich.markup import escape

    from pbr_xval.atomic import check_output_dir, write_text_atomic
    from pbr_xval.catalog import CatalogError, load_catalog, load_results
    from pbr_xval.errors import OutputPathError
    from pbr_xval.hazard.fit import compare_ims, fit_sweep, sweep_intensity_measures
    from pbr_xval.hazard.fragility_functions import LognormalFragility
    from pbr_xval.hazard.ims import oq_factor, oq_unit
    from pbr_xval.hazard.nrml import write_fragility_csv, write_fragility_model

    con = make_console(console)
    if not 0 < ci < 1:
        return _error(con, f"--ci {ci!r}: expected a confidence level in (0, 1), e.g. 0.95")
    if any(not (p > 0 and math.isfinite(p)) for p in periods):
        return _error(con, f"--period {periods}: expected periods > 0 s")
    if periods and catalog is None:
        return _error(con, "--period needs --catalog (SA(T) is recomputed from the sweep's catalog)")
    if not Path(results).is_dir():
        return _error(con, f"{results}: results folder not found; expected a pbr-xval sweep output")
    try:
        check_output_dir(out, "--out")
    except OutputPathError as exc:
        return _error(con, str(exc))
    bad = _unreadable_chunk(results)
    if bad:
        return _error(con, bad)
    df = load_results(results)
    if df is None or len(df) == 0:
        return _error(con, f"{results}: no simulation rows; expected a finished (or partial) sweep")
    if engine is not None:
        df = df[df["engine"] == engine]
        if len(df) == 0:
            return _error(con, f"{results}: no runs of engine {engine!r}")
    ok_rows = df["status"].astype(str) == "ok"
    if not ok_rows.any():
        counts = df["status"].astype(str).value_counts()
        msgs = [m.strip().splitlines()[0] for m in df["message"].astype(str) if m.strip()]
        first = f"; first message: {msgs[0][:200]}" if msgs else ""
        return _error(
            con,
            f"{results}: none of its {len(df)} simulation rows succeeded (status "
            + ", ".join(f"{k} × {v}" for k, v in counts.items())
            + f"{first}); expected successful runs to fit",
        )
    extra = None
    ims = ["PGA", "PGV"]
    if periods:
        try:
            cat = load_catalog(catalog)  # type: ignore[arg-type]
        except CatalogError as exc:
            return _error(con, str(exc))
        extra = sweep_intensity_measures(cat, periods)
        ims += [c for c in extra.columns if c.startswith("SA(")]
    fits = fit_sweep(df, tuple(ims), extra, ci_level=ci)
    cmp = compare_ims(fits)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    write_text_atomic(out / "fits.csv", fits.to_csv(index=False))
    write_text_atomic(out / "im_comparison.csv", cmp.to_csv(index=False))
    ok = fits[(fits["status"] == "ok") & (fits["im"] != "PGA|PGV/PGA")]
    frags, rows = [], []
    multi = ok["engine"].nunique() > 1 or ok["profile"].nunique() > 1 or ok["settings"].nunique() > 1
    for r in ok.itertuples():
        fid = f"{r.rock_id}__{r.im}" + (f"__{r.engine}" if multi else "")
        frags.append(LognormalFragility(r.im, fid, theta=r.theta, beta=r.beta, theta_ci=(r.theta_lo, r.theta_hi),
                                        beta_ci=(r.beta_lo, r.beta_hi)))  # fmt: skip
        rows.append({"id": fid, "im": r.im, "theta": r.theta, "beta": r.beta, "theta_lo": r.theta_lo,
                     "theta_hi": r.theta_hi, "beta_lo": r.beta_lo, "beta_hi": r.beta_hi, "ci_level": ci,
                     "n_runs": r.n_runs, "n_toppled": r.n_toppled, "status": "ok", "source": f"{results} ({r.engine})"})  # fmt: skip
    if frags:
        write_fragility_csv(out / "fragility.csv", rows)
        write_fragility_model(out / "fragility.xml", frags, "continuous")
        write_fragility_model(out / "fragility_discrete.xml", frags, "discrete")
    for r in fits.itertuples():
        if r.status == "ok":
            # the field's units on the console (g for PGA/SA, cm/s for PGV); the files stay SI
            k, fu = oq_factor(r.im.split("|")[0]), oq_unit(r.im.split("|")[0])
            ci_txt = (f"  θ ∈ [{r.theta_lo / k:.4g}, {r.theta_hi / k:.4g}] {fu}, β ∈ [{r.beta_lo:.3g}, {r.beta_hi:.3g}]"
                      if r.theta_lo == r.theta_lo else f"  b = {r.coef} (SI), LR p = {r.lr_p:.3g}")  # fmt: skip
            con.print(escape(f"{r.engine} {r.rock_id} {r.im}: θ = {r.theta / k:.4g} {fu} ({r.theta:.4g} {r.unit}), "
                             f"β = {r.beta:.3g}{ci_txt}"), highlight=False)  # fmt: skip
        else:
            con.print(escape(f"{r.engine} {r.rock_id} {r.im}: {r.status} — {r.message}"), highlight=False)
    for r in cmp.itertuples():
        con.print(escape(f"{r.engine} {r.rock_id}: IMs by dispersion: {r.ranking}"), highlight=False)
    con.print(f"written: {out}/fits.csv, im_comparison.csv" + (", fragility.csv, fragility.xml, fragility_discrete.xml" if frags else ""),
              highlight=False)  # fmt: skip
    return 0 if frags else 1


def constrain_command(
    config: Path | None,
    out: Path = Path("reports/constrain"),
    example: bool = False,
    joint: str | None = None,
    rate: float | None = None,
    console: Any = None,
) -> int:
    """Run a constrain file (or the synthetic example) and write the report into ``out``."""
    from rich.markup import escape

    from pbr_xval.atomic import check_output_dir
    from pbr_xval.errors import OutputPathError
    from pbr_xval.hazard.config import load_config
    from pbr_xval.hazard.constrain_report import write_report
    from pbr_xval.hazard.ims import G, HazardInputError
    from pbr_xval.hazard.survival import constrain

    con = make_console(console)
    try:  # before the example's inputs or any computation are written
        check_output_dir(out, "--out")
    except OutputPathError as exc:
        return _error(con, str(exc))
    if example:
        from pbr_xval.hazard.example import write_example

        if config is not None:
            return _error(con, "give either CONFIG or --example, not both")
        config = write_example(out)
        con.print(f"synthetic inputs written to {config.parent}", highlight=False)
    if config is None:
        return _error(con, "no constrain file; give CONFIG (TOML) or --example")
    if joint is not None and joint not in ("independent", "shared-events"):
        return _error(con, f"--joint {joint!r}: expected 'independent' or 'shared-events'")
    if rate is not None and not (rate > 0 and math.isfinite(rate)):
        return _error(con, f"--rate {rate!r}: expected an annual rate > 0 (1/yr)")
    try:
        cfg = load_config(config)
        res = constrain(
            cfg.branches, cfg.rocks, joint or cfg.joint, rate or cfg.rate_of_interest, cfg.quantiles,
            allow_truncated=cfg.allow_truncated, p_low_max=cfg.truncation_p_max, top_tol=cfg.tail_tolerance,
            im_of_interest=cfg.im_of_interest,
        )  # fmt: skip
    except HazardInputError as exc:
        return _error(con, str(exc))
    unc = None
    notes = list(cfg.notes) + sorted({n for c in cfg.branches for n in c.notes})
    if cfg.draws and res.joint_mode == "independent":
        from pbr_xval.hazard.fragility_draws import propagate

        unc = propagate(res, cfg.branches, cfg.rocks, cfg.draws)
        res.summary["fragility_uncertainty"] = unc.to_dict()
    elif cfg.draws:
        notes.append("joint = shared-events: the fragilities are taken at their fits (draws not propagated)")
    sources = sorted({c.source for c in cfg.branches if c.source})
    for wmsg in res.warnings:
        con.print("[bold yellow]WARNING:[/bold yellow] " + escape(wmsg), highlight=False)
    page = write_report(
        res, cfg.rocks, out, cfg.name, notes, [str(config), *sources], cfg.given_mean, unc, cfg.draws
    )
    s = res.summary
    k = 0.01 if res.im == "PGV" else G
    u = "cm/s" if res.im == "PGV" else "g"
    con.print(escape(f"{cfg.name}: {len(cfg.branches)} branches, {len(cfg.rocks)} rocks, joint = {res.joint_mode}"),
              highlight=False)  # fmt: skip
    for i, (rid, p) in enumerate(s["rock_survival"].items()):
        line = f"  P_s({rid}) = {p:.3g} (prior mean, fitted fragility)"
        if unc is not None and unc.methods[i] != "none":
            sh = unc.shares[rid]
            line += (f"; with the fragility's uncertainty {unc.ps_mean[i]:.3g} [5–95 %: {unc.ps_band[i, 0]:.3g}–"
                     f"{unc.ps_band[i, 1]:.3g}] ({unc.methods[i]}, {unc.n_draws[i]} draws); variance shares: hazard "
                     f"{sh['hazard']:.0%}, fragility {sh['fragility']:.0%}, age {sh['age']:.0%}")  # fmt: skip
        con.print(escape(line), highlight=False)
    con.print(f"  P(all survive) = {s['prior_joint_survival']:.3g} (prior mean)", highlight=False)
    rng = (f"; 5–95 % range {s['im05_before'] / k:.3g}–{s['im95_before'] / k:.3g} → {s['im05_after'] / k:.3g}–"
           f"{s['im95_after'] / k:.3g} {u} (width × {s['range_ratio']:.3g})" if math.isfinite(s["range_ratio"])
           else "; one branch: no fractile range")  # fmt: skip
    con.print(escape(f"  at λ = {s['rate_of_interest']:g}/yr: mean-curve {res.im} {s['mean_im_before'] / k:.3g} → "
                     f"{s['mean_im_after'] / k:.3g} {u} ({100 * s['mean_im_change']:+.1f} %){rng}"), highlight=False)  # fmt: skip
    x0 = s.get("im_of_interest", math.nan)
    if x0 is not None and math.isfinite(x0):
        con.print(escape(f"  at {res.im} = {x0 / k:.3g} {u}: mean annual rate {s['mean_rate_before_at_im']:.3g} → "
                         f"{s['mean_rate_after_at_im']:.3g}/yr (× {s['mean_rate_ratio_at_im']:.3g})"), highlight=False)  # fmt: skip
    if unc is not None:
        lo, hi = unc.mean_im_after_band
        con.print(escape(f"  with the fragility's uncertainty: mean-curve {res.im} at λ = {s['rate_of_interest']:g}/yr "
                         f"{unc.mean_im_after / k:.3g} {u} [5–95 % over draws {lo / k:.3g}–{hi / k:.3g}]"), highlight=False)  # fmt: skip
    if not math.isfinite(s["mean_im_before"]):
        lo, hi = float(res.mean().min()), float(res.mean().max())
        con.print(f"  note: λ = {s['rate_of_interest']:g}/yr is outside the mean curve's range on the common IM grid "
                  f"({lo:.3g}–{hi:.3g}/yr); choose --rate inside it", highlight=False)  # fmt: skip
    con.print(f"report: {page}", highlight=False)
    return 0
