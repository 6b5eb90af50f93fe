"""Re-measure the one-off figures of docs/validation.md, "Ensemble scores" (not run in CI).

Reads the output folders of ``pbr-xval validate … --ensemble`` (their ``outcomes.csv`` and ``store/``) and
prints, per folder:

* ``rows``: one Markdown table row per model — the ensemble (its P recomputed from the folder's
  ``ensemble_members.csv`` with today's definition, and the share k / n beside it), each engine's members
  alone (the same definition on that engine's members of the same runs), and the deterministic
  engines from the folder's ``outcomes.csv``; the logistic baselines out of fold by record (4 record folds) fitted on *all* 196
  calibration tests of the specimen; the transferred logistic law fitted on every test of the other
  specimen — all scored on the folder's tests (so a run on a subset, ``--tests``, is compared with the
  196-test baselines). On a run over all tests the rows equal the run's own ``scores.csv``.
* ``boot``: a bootstrap over records (tests resampled by record, 4,000 draws, seed 0) of the ensemble's Brier
  minus a baseline's, paired by test (``stacked``: the out-of-fold stacked mixture of
  ``pbr_xval.validation.stacking`` instead of the ensemble as run).
* ``split``: the Brier of the ensemble, the deterministic engines and the logistic baselines of the folder's
  ``outcomes.csv`` on a list of tests (e.g. the 66 screening tests) and on the folder's other tests.
* ``chance``: over the tests of ``ensemble_sp<N>_robustness.json`` records, how many tests' P would leave
  the base run's interval by Monte-Carlo noise alone (``exits_by_chance``), beside the records' exits.
* ``sessions``: does the model's error cluster by test day (the rock re-seated between sessions)? The statistic
  Σ_day (Σ (observed − P))² / n_day against 4,000 permutations of the day labels among the tests of each record
  (seed 0), for the ensemble, the logistic on ln PGA and ln PGV, and the transferred law.
* ``repeats``: the lab's own repeatability — pairs of tests of the same record whose sheet PGAs are within 2, 5
  and 10 % (log ratio), how many gave opposite outcomes (no simulation: ``experiments.csv`` only).
* ``rehearse``: a rehearsal of the held-out judgement inside the calibration half — its records split in two
  (``group_folds(records, 2)``), each half scored with the lab and field ensembles' P of the given folders
  against the logistic laws and the rules fitted on the *other* half (``validate --calibration``'s
  ``add_calibration_baselines``) and against the transferred law.
* ``bands``: where the Brier score comes from — per band of the sheet's PGV/PGA (the lab's edges 0.06, 0.08,
  0.10, 0.15 s) and per test day: tests, topples observed, the summed P of the ensemble and of the best
  out-of-fold logistic (expected topples), and each one's share of the specimen's Brier; then the Brier of both
  with the worst day left out. A deterministic ``validate`` folder (no ``ensemble_members.csv``) gets each
  engine's predicted topples (``pred_<engine>``) per band and per day instead.
* ``recalibrate``: how far an ensemble's P is from the table's outcomes as a map — a Platt map
  (logistic regression on logit P, scikit-learn, P clipped to [0.001, 0.999]) fitted out of fold by record on
  the folder's own tests, and one fitted on every test of the *other* folder (the other specimen) and applied
  to this one; printed with the ensemble's, the best out-of-fold logistic's and the transferred law's Brier.
  For field mode the transferred map is what the other specimen's table says about the unknown direction.
* ``cost``: member runs per test and the summed per-run ``wall_s`` of the store's member runs over its
  deterministic runs, per engine, on the folder's tests.

Usage::

    python tools/ensemble_scores.py rows "SP1, lab" 1 /tmp/ens/sp1
    python tools/ensemble_scores.py boot /tmp/ens/sp1 "p_logistic(lnPGA,lnPGV)"
    python tools/ensemble_scores.py boot /tmp/ens/sp1 "p_logistic(lnPGA,lnPGV)" stacked   # the stacked mixture
    python tools/ensemble_scores.py cost /tmp/ens/sp1
    python tools/ensemble_scores.py chance examples/validation/robustness/ensemble_sp{1,2}_robustness.json
    python tools/ensemble_scores.py split /tmp/ens/sp1 15,19,39,…   # Brier on the listed tests and on the others
    python tools/ensemble_scores.py sessions /tmp/ens/sp1 /tmp/ens/sp2
    python tools/ensemble_scores.py repeats
    python tools/ensemble_scores.py bands /tmp/ens/sp1 /tmp/ens/sp2
    python tools/ensemble_scores.py rehearse 1 /tmp/ens/sp1_lab /tmp/ens/sp1_field
    python tools/ensemble_scores.py recalibrate /tmp/ens/sp1_field /tmp/ens/sp2_field

The campaign is ../shared/data/shake_table and the scenarios examples/validation/sp{1,2}.toml (the geometry
of the transferred law), relative to the repository root.
"""

from __future__ import annotations

import glob
import json
import os
import platform
import sys
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
CAMPAIGN = ROOT.parent / "shared" / "data" / "shake_table"
#: the lab's PGV/PGA band edges (s) of ``bands``: the sheet's PGV/PGA cut at 0.06, 0.08, 0.10, 0.15 s
LAB_BANDS_S = [0, 0.06, 0.08, 0.10, 0.15, np.inf]
G = 9.80665


def rows(label: str, specimen: str, folder: str) -> None:
    from sklearn.metrics import brier_score_loss, f1_score, log_loss, roc_auc_score

    from pbr_xval.validation.metrics import group_folds
    from pbr_xval.validation.scores import RockGeometry, logistic_baselines, transferred_baseline

    spec = int(specimen)
    other = 3 - spec
    ex = pd.read_csv(CAMPAIGN / "experiments.csv", dtype={"test": str})
    pga = ex.pga_g.to_numpy() * G
    pgv = pga * ex.pgv_over_pga_s.to_numpy()
    obs = ex[f"toppled_specimen{spec}"].to_numpy(int)
    lb = logistic_baselines(pga, pgv, obs, group_folds(ex.motion.tolist(), 4))
    tg = RockGeometry.from_scenario(ROOT / f"examples/validation/sp{spec}.toml")
    sg = RockGeometry.from_scenario(ROOT / f"examples/validation/sp{other}.toml")
    src = pd.DataFrame({"pga": pga, "pgv": pgv, "observed": ex[f"toppled_specimen{other}"]})
    tr = transferred_baseline(pd.DataFrame({"pga": pga, "pgv": pgv}), src, tg, sg)
    oc = pd.read_csv(f"{folder}/outcomes.csv", dtype={"test": str}).set_index("test")
    m = ex.test.isin(oc.index).to_numpy()
    o = obs[m]
    assert (oc.loc[ex.test[m], "observed"].to_numpy(int) == o).all()

    def sc(p: np.ndarray) -> tuple[float, float, float, float]:
        pc = np.clip(p, 1e-3, 1 - 1e-3)
        return (
            brier_score_loss(o, pc),
            log_loss(o, pc, labels=[0, 1]),
            roc_auc_score(o, pc),
            f1_score(o, (p >= 0.5).astype(int)),
        )

    tests = ex.test[m].astype(str).tolist()
    out = {
        "ensemble": sc(_p_ensemble(folder, tests)),
        "ensemble (share k/n)": sc(_p_ensemble(folder, tests, share=True)),
    }
    for e, (pe, ne) in _p_per_engine(folder, tests).items():  # each engine's members alone
        out[f"ensemble, {e} members only ({ne.min()}–{ne.max()} per test)"] = sc(pe)
    for e in ("mujoco", "pybullet"):
        if f"pred_{e}" in oc:
            out[e] = sc(oc.loc[ex.test[m], f"pred_{e}"].to_numpy(float))
    for k, v in lb.items():
        out[k] = sc(np.asarray(v)[m])
    out["transferred"] = sc(np.asarray(tr.p)[m])
    for k, (b, ll, auc, f1) in out.items():
        s = "**" if k == "ensemble" else ""
        print(f"| {label} | {s}{k}{s} | {m.sum()} | {s}{b:.3f}{s} | {ll:.3f} | {auc:.3f} | {f1:.3f} |")
    best = min(v[0] for k, v in out.items() if k.startswith("logistic"))
    e, t = out["ensemble"][0], out["transferred"][0]
    print(
        f"# {label}: ensemble Brier vs best logistic {100 * (e / best - 1):+.1f} % (best {best:.4f}), "
        f"vs transferred {100 * (e / t - 1):+.1f} %; toppled {o.sum()}/{len(o)}"
    )


def _p_ensemble(folder: str, tests: list[str], share: bool = False) -> np.ndarray:
    """The ensemble's P per test as ``validate --ensemble`` computes it today (the Jeffreys posterior
    mean (k + ½) / (n + 1), :func:`pbr_xval.validation.ensemble.ensemble_p`), from the folder's
    ``ensemble_members.csv`` — so a folder written before that definition is scored with it;
    ``share``: k / n instead (the definition before commit fbf20a4)."""
    from pbr_xval.validation.ensemble import ensemble_counts, ensemble_p

    members = pd.read_csv(f"{folder}/ensemble_members.csv", dtype={"test": str})
    if share:
        k, n, _ = ensemble_counts(members, tests)
        return np.where(n > 0, k / np.maximum(n, 1), np.nan)
    return ensemble_p(members, tests)[0]


def _p_per_engine(folder: str, tests: list[str]) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Per engine of the ensemble: (P, n) — P (tests,) = (k + ½) / (n + 1) from that engine's ok members
    alone, n (tests,) its member count. A test where the adaptive stop left an engine without a member
    takes P = ½ (the Jeffreys prior mean), so every row scores every test."""
    from pbr_xval.validation.ensemble import ensemble_counts

    members = pd.read_csv(f"{folder}/ensemble_members.csv", dtype={"test": str})
    out = {}
    for e in sorted(members.loc[members.status == "ok", "engine"].unique()):
        k, n, _ = ensemble_counts(members[members.engine == e], tests)
        out[str(e)] = ((k + 0.5) / (n + 1.0), n)
    return out


def _stacked(folder: str, oc: pd.DataFrame) -> np.ndarray:
    """The out-of-fold stacked P of ``pbr_xval.validation.stacking`` for the rows of ``oc``."""
    from pbr_xval.validation.stacking import engine_shares, stack_out_of_fold

    members = pd.read_csv(f"{folder}/ensemble_members.csv", dtype={"test": str})
    P, _, _ = engine_shares(members, oc.test.tolist())
    return stack_out_of_fold(P, oc.observed.to_numpy(int), oc.fold.to_numpy(int))[0]


def boot(folder: str, base: str, model: str = "ensemble") -> None:
    oc = pd.read_csv(f"{folder}/outcomes.csv", dtype={"test": str})
    o = oc.observed.to_numpy(float)
    p = _stacked(folder, oc) if model == "stacked" else _p_ensemble(folder, oc.test.tolist())
    d = (p - o) ** 2 - ((oc[base] - o) ** 2).to_numpy()
    rec = oc.motion.to_numpy()
    recs = np.unique(rec)
    idx = {r: np.flatnonzero(rec == r) for r in recs}
    rng = np.random.default_rng(0)
    bs = np.array(
        [d[np.concatenate([idx[r] for r in rng.choice(recs, len(recs))])].mean() for _ in range(4000)]
    )
    lo, hi = np.quantile(bs, [0.025, 0.975])
    print(
        f"{folder} {model} − {base}: {d.mean():+.4f}  record bootstrap 95 % [{lo:+.4f}, {hi:+.4f}]  ({len(recs)} records, {len(o)} tests)"
    )


def cost(folder: str) -> None:
    oc = pd.read_csv(f"{folder}/outcomes.csv", dtype={"test": str})
    tests = set(oc.test)
    cols = ["engine", "motion_params", "wall_s", "status"]
    df = pd.concat(
        [pd.read_parquet(f, columns=cols) for f in glob.glob(f"{folder}/store/**/*.parquet", recursive=True)]
    )
    mp = df.motion_params.map(json.loads)
    df["test"] = mp.map(lambda d: str(d.get("test")))
    df["member"] = mp.map(lambda d: d.get("member"))
    df = df[df.test.isin(tests)]
    det = df[df.member.isna()].drop_duplicates(["engine", "test"])
    mem = df[df.member.notna()].drop_duplicates(["engine", "test", "member"])
    dsum, msum = det.groupby("engine").wall_s.sum(), mem.groupby("engine").wall_s.sum()
    print(
        f"{folder}: {len(tests)} tests, {len(mem) / len(tests):.2f} member runs per test ({len(mem)} runs), "
        f"{len(det)} deterministic runs; members per test {oc.members_ensemble.value_counts().sort_index().to_dict()}"
    )
    for e in sorted(set(dsum.index) | set(msum.index)):
        nd, nm = (det.engine == e).sum(), (mem.engine == e).sum()
        print(
            f"  {e}: deterministic {nd} runs {dsum.get(e, 0):.0f} s ({dsum.get(e, 0) / max(nd, 1):.2f} s/run), "
            f"members {nm} runs {msum.get(e, 0):.0f} s ({msum.get(e, 0) / max(nm, 1):.2f} s/run), "
            f"ratio {msum.get(e, 0) / dsum.get(e, np.nan):.2f}"
        )
    print(
        f"  all engines: members {msum.sum():.0f} s / deterministic {dsum.sum():.0f} s = {msum.sum() / dsum.sum():.2f}; "
        f"runs not ok: {int((det.status != 'ok').sum())} deterministic, {int((mem.status != 'ok').sum())} members"
    )


def split(folder: str, tests: str) -> None:
    oc = pd.read_csv(f"{folder}/outcomes.csv", dtype={"test": str})
    listed = oc.test.isin(tests.split(","))
    oc["p_ensemble"] = _p_ensemble(folder, oc.test.tolist())
    cols = ["p_ensemble", *[c for c in oc if c.startswith(("pred_", "p_logistic"))]]
    for name, m in (("listed", listed), ("others", ~listed)):
        o = oc.observed[m]
        briers = ", ".join(
            f"{c} {((oc[c][m] - o) ** 2).mean():.4f}" for c in cols if not c.startswith("pred_PG")
        )
        print(f"{folder} {name} ({int(m.sum())} tests): Brier {briers}")


def chance(*records: str) -> None:
    """Tests whose P would leave the base interval by Monte-Carlo noise alone, over the robustness records'
    tests (``pbr_xval.validation.robustness.exits_by_chance``, their ensemble settings), against the
    records' measured exits."""
    from pbr_xval.validation.robustness import exits_by_chance

    counts, seen = [], {}
    for f in records:
        d = json.loads(Path(f).read_text())
        counts += [(r["base"]["k"], r["base"]["n"]) for r in d["per_test"].values()]
        for v, ts in d["outside_base_interval"].items():
            seen[v] = seen.get(v, 0) + len(ts)
        ens = d["ensemble"]
    x = exits_by_chance(counts, members=ens["members"], batch=ens["batch"], half_width=ens["half_width"])
    lo, med, hi = np.percentile(x, [2.5, 50, 97.5])
    print(
        f"{len(counts)} tests: by chance alone (fresh members) {x.mean():.2f} leave the base interval "
        f"(median {med:.0f}, 95 % {lo:.0f}–{hi:.0f}; P(≤ 1) {np.mean(x <= 1):.2f}, P(0) {np.mean(x == 0):.2f}); "
        f"measured: {seen}"
    )


def sessions(*folders: str) -> None:
    """Day clustering of the residuals (observed − P), against day labels permuted within each record."""
    ex = pd.read_csv(CAMPAIGN / "experiments.csv", dtype={"test": str})[["test", "date"]]

    def stat(r: np.ndarray, day: np.ndarray) -> float:
        g = pd.DataFrame({"r": r, "d": day}).groupby("d")["r"].agg(["sum", "size"])
        return float((g["sum"] ** 2 / g["size"]).sum())

    for folder in folders:
        oc = pd.read_csv(f"{folder}/outcomes.csv", dtype={"test": str}).merge(ex, on="test")
        groups = [np.flatnonzero(oc.motion.to_numpy() == m) for m in oc.motion.unique()]
        for col in ("p_ensemble", "p_logistic(lnPGA,lnPGV)", "p_transferred"):
            rng = np.random.default_rng(0)
            r = (oc.observed - oc[col]).to_numpy(float)
            t0 = stat(r, oc.date.to_numpy())
            ts = np.empty(4000)
            for k in range(ts.size):
                day = oc.date.to_numpy().copy()
                for ix in groups:
                    day[ix] = day[rng.permutation(ix)]
                ts[k] = stat(r, day)
            print(
                f"{folder} {col}: statistic {t0:.2f}, permuted mean {ts.mean():.2f}, p {np.mean(ts >= t0):.4f}"
            )


def repeats() -> None:
    """Same-record test pairs at nearly the same sheet PGA, and how often the lab's outcomes disagree."""
    ex = pd.read_csv(CAMPAIGN / "experiments.csv")
    for tol in (0.02, 0.05, 0.10):
        for spec in (1, 2):
            col = f"toppled_specimen{spec}"
            n = dis = 0
            pairs = []
            for _, s in ex.groupby("motion"):
                v = s[["test", "pga_g", "date", col]].to_numpy()
                for i in range(len(v)):
                    for j in range(i + 1, len(v)):
                        if abs(np.log(v[j][1] / v[i][1])) <= tol:
                            n += 1
                            if v[i][3] != v[j][3]:
                                dis += 1
                                pairs.append(
                                    f"{int(v[i][0])}/{int(v[j][0])} ({v[i][1]:.3f}/{v[j][1]:.3f} g, {int(v[i][3])}/{int(v[j][3])})"
                                )
            print(
                f"PGA within {tol:.0%}: SP{spec} {n} pairs, {dis} with opposite outcomes: {', '.join(pairs)}"
            )


def bands(*folders: str) -> None:
    """Expected against observed topples and the Brier's share per sheet PGV/PGA band and per test day."""
    ex = pd.read_csv(CAMPAIGN / "experiments.csv", dtype={"test": str})[["test", "date"]]
    for folder in folders:
        if not Path(folder, "outcomes.csv").is_file():
            raise SystemExit(
                f"bands: {folder}: no outcomes.csv (expected a `pbr-xval validate` output folder)"
            )
        oc = pd.read_csv(f"{folder}/outcomes.csv", dtype={"test": str}).merge(ex, on="test")
        if not Path(folder, "ensemble_members.csv").is_file():
            _bands_deterministic(folder, oc)
            continue
        oc["p_ensemble"] = _p_ensemble(folder, oc.test.tolist())
        o = oc.observed.to_numpy(float)
        logit = [c for c in oc if c.startswith("p_logistic")]
        best = min(logit, key=lambda c: float(np.mean((oc[c] - o) ** 2)))
        oc["se_ens"] = (oc.p_ensemble - o) ** 2
        oc["se_log"] = (oc[best] - o) ** 2
        oc["band"] = pd.cut(oc.sheet_pgv_over_pga_s, LAB_BANDS_S)
        n = len(oc)
        print(
            f"{folder}: {n} tests, ensemble Brier {oc.se_ens.mean():.4f}, best logistic {best} {oc.se_log.mean():.4f}"
        )
        for key in ("band", "date"):
            g = oc.groupby(key, observed=True).agg(
                tests=("test", "size"),
                toppled=("observed", "sum"),
                expected_ensemble=("p_ensemble", "sum"),
                expected_logistic=(best, "sum"),
                brier_share_ensemble=("se_ens", "sum"),
                brier_share_logistic=("se_log", "sum"),
            )
            g[["brier_share_ensemble", "brier_share_logistic"]] /= n
            print(g.round(4).to_string())
        worst = oc.groupby("date").se_ens.sum().idxmax()
        rest = oc.date != worst
        print(
            f"  without day {worst} ({int((~rest).sum())} tests, {int(oc.observed[~rest].sum())} toppled, "
            f"ensemble expected {oc.p_ensemble[~rest].sum():.1f}): ensemble {oc.se_ens[rest].mean():.4f}, "
            f"{best} {oc.se_log[rest].mean():.4f} ({100 * (oc.se_ens[rest].mean() / oc.se_log[rest].mean() - 1):+.0f} %)"
        )


def _bands_deterministic(folder: str, oc: pd.DataFrame) -> None:
    """:func:`bands` for a deterministic ``validate`` folder: each engine's yes/no (``pred_<engine>``)
    counted against the observed topples per sheet PGV/PGA band and per test day."""
    engines = [c for c in oc if c.startswith("pred_") and not c.endswith("rule")]
    if not engines:
        raise SystemExit(
            f"bands: {folder}: found neither ensemble_members.csv nor a pred_<engine> column in outcomes.csv"
        )
    oc = oc.assign(band=pd.cut(oc.sheet_pgv_over_pga_s, LAB_BANDS_S))
    print(
        f"{folder}: {len(oc)} tests, {int(oc.observed.sum())} toppled (deterministic: predicted topples per engine)"
    )
    for key in ("band", "date"):
        g = oc.groupby(key, observed=True).agg(
            tests=("test", "size"), toppled=("observed", "sum"), **{c[5:]: (c, "sum") for c in engines}
        )
        print(g.to_string())


def _logit_p(folder: str) -> tuple[pd.DataFrame, np.ndarray]:
    oc = pd.read_csv(f"{folder}/outcomes.csv", dtype={"test": str})
    p = np.clip(_p_ensemble(folder, oc.test.tolist()), 1e-3, 1 - 1e-3)
    return oc, np.log(p / (1 - p))


def recalibrate(folder_a: str, folder_b: str) -> None:
    """Platt maps of each folder's ensemble P: out of fold by record, and fitted on the other folder."""
    from sklearn.linear_model import LogisticRegression
    from sklearn.metrics import brier_score_loss

    data = {f: _logit_p(f) for f in (folder_a, folder_b)}
    for this, other in ((folder_a, folder_b), (folder_b, folder_a)):
        oc, x = data[this]
        o = oc.observed.to_numpy(int)
        q = np.zeros(len(o))
        for k in np.unique(oc.fold):
            tr = oc.fold.to_numpy() != k
            q[~tr] = LogisticRegression(C=1e6).fit(x[tr, None], o[tr]).predict_proba(x[~tr, None])[:, 1]
        ox, xo = data[other]
        m = LogisticRegression(C=1e6).fit(xo[:, None], ox.observed.to_numpy(int))
        t = m.predict_proba(x[:, None])[:, 1]
        best = min(brier_score_loss(o, oc[c]) for c in oc if c.startswith("p_logistic"))
        print(
            f"{this}: ensemble Brier {brier_score_loss(o, 1 / (1 + np.exp(-x))):.4f}; Platt out of fold by record "
            f"{brier_score_loss(o, q):.4f}; Platt fitted on {other} {brier_score_loss(o, t):.4f} "
            f"(logit P' = {m.intercept_[0]:.2f} + {m.coef_[0, 0]:.2f} logit P); best logistic {best:.4f}, "
            f"transferred {brier_score_loss(o, oc.p_transferred):.4f}"
        )


def rehearse(specimen: str, lab: str, field: str) -> None:
    """The held-out judgement rehearsed on the two record halves of the calibration campaign."""
    import tempfile
    from types import SimpleNamespace

    from sklearn.metrics import f1_score

    from pbr_xval.validation.campaign import load_campaign
    from pbr_xval.validation.campaign_report import add_calibration_baselines, evaluate
    from pbr_xval.validation.metrics import group_folds

    spec = int(specimen)
    ex = pd.read_csv(CAMPAIGN / "experiments.csv")
    fold = group_folds(ex.motion.tolist(), 2)
    p_lab = pd.read_csv(f"{lab}/outcomes.csv").set_index("test")
    p_field = pd.read_csv(f"{field}/outcomes.csv").set_index("test")
    with tempfile.TemporaryDirectory() as tmp:
        halves = []
        for k in (0, 1):
            d = Path(tmp) / f"half{k}"
            d.mkdir()
            ex[fold == k].to_csv(d / "experiments.csv", index=False)
            (d / "table_motions.npz").symlink_to((CAMPAIGN / "table_motions.npz").resolve())
            halves.append(d)
        for fit_on, scored in ((halves[0], halves[1]), (halves[1], halves[0])):
            camp = load_campaign(scored, spec)
            motions = {t.test: SimpleNamespace(pga=1.0, pgv=0.1, duration=1.0) for t in camp.tests}
            rows = pd.DataFrame(columns=["test", "engine", "toppled", "status", "wall_s"])
            res = evaluate(camp, rows, motions, [], folds=4, baseline_source="sheet")
            add_calibration_baselines(res, str(fit_on), spec)
            sc = res.scores.set_index("model")
            t = res.outcomes.test.astype(int).to_numpy()
            o = res.outcomes.observed.to_numpy(int)
            logit = [m for m in sc.index if m.startswith("logistic") and m.endswith("@calibration")]
            best = min(logit, key=lambda m: sc.loc[m, "brier"])
            b_lab = float(np.mean((p_lab.loc[t, "p_ensemble"].to_numpy() - o) ** 2))
            b_field = float(np.mean((p_field.loc[t, "p_ensemble"].to_numpy() - o) ** 2))
            b_tr = float(np.mean((p_field.loc[t, "p_transferred"].to_numpy() - o) ** 2))
            f1 = f1_score(o, p_lab.loc[t, "p_ensemble"].to_numpy() >= 0.5)
            print(
                f"SP{spec} scored on {scored.name} ({len(t)} tests, {o.sum()} toppled), fitted on {fit_on.name}: "
                f"lab ensemble Brier {b_lab:.3f} F1 {f1:.3f}; best logistic {best} {sc.loc[best, 'brier']:.3f} "
                f"({100 * (b_lab / sc.loc[best, 'brier'] - 1):+.0f} %); best rule F1 "
                f"{max(sc.loc[m, 'f1'] for m in sc.index if 'rule@' in m):.3f}; field ensemble {b_field:.3f} "
                f"vs transferred {b_tr:.3f} ({100 * (b_field / b_tr - 1):+.0f} %)"
            )


COMMANDS = {
    "rows": rows,
    "boot": boot,
    "cost": cost,
    "split": split,
    "chance": chance,
    "sessions": sessions,
    "repeats": repeats,
    "rehearse": rehearse,
    "bands": bands,
    "recalibrate": recalibrate,
}

if __name__ == "__main__":
    if len(sys.argv) < 2 or sys.argv[1] not in COMMANDS:
        found = sys.argv[1] if len(sys.argv) > 1 else "nothing"
        if found in ("-h", "--help"):
            print(__doc__)
            sys.exit(0)
        print(
            f"error: command: found {found!r}, expected one of {', '.join(COMMANDS)} (--help)",
            file=sys.stderr,
        )
        sys.exit(2)
    print(f"# {platform.processor() or platform.machine()}, load {os.getloadavg()[0]:.1f}")
    cmd, *args = sys.argv[1:]
    COMMANDS[cmd](*args)  # type: ignore[operator]
