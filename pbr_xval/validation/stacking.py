"""Engine weights of an ensemble's mixture, fitted to experiments and cross-validated by record.

An ensemble's ``engines`` list is model uncertainty: each member's engine is drawn from the
mixture's weights (``engine_weights``), so the share of toppled members estimates the weighted
mean of the engines' own shares (``validate --ensemble`` reports it as the Jeffreys posterior mean
(k + ½) / (n + 1) of the pooled members, :func:`pbr_xval.uncertainty.p_topple`). Equal weights say "we do not know which contact model is
right". Once a rock has shake-table experiments they *do* say something about it, and the weights
can be fitted to them — this is "stacking" of predictive distributions (Wolpert 1992; Yao et al.
2018, Bayesian Analysis 13(3)): the weights w on the simplex that minimise the Brier score of the
mixture ``P w`` (a convex quadratic: the minimum is exact, found by SLSQP).

A weight fitted on the tests cannot be scored on the same tests, so :func:`stack_out_of_fold`
fits the weights on the other record folds for every held-out fold (the folds of ``validate``:
whole earthquake records per fold, :func:`~pbr_xval.validation.metrics.group_folds`); a test's
stacked P never depends on its own outcome, nor on any test of its record. That out-of-fold score is
what docs/validation.md quotes, beside the weights fitted on every calibration test (what a
committed scenario carries).

Input: a ``validate --ensemble`` output folder (``outcomes.csv``: observed, fold, p_ensemble;
``ensemble_members.csv``: one row per member with its engine and outcome). No simulation is run.
A test's P per engine is the share k / n of that engine's ok members (adaptive ensembles run few
members per engine: the per-engine P is coarse, which the fit sees as noise; the posterior mean per
engine would shrink 0 of 2 to 1/6 and 2 of 2 to 5/6, a prior stronger than the data); a test without
members of an engine takes the mean of its other engines' shares for it.

Usage (developer tool; seconds)::

    python -m pbr_xval.validation.stacking reports/validate_sp1_ensemble [--json weights.json]
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pbr_xval.atomic import write_text_atomic

__all__ = ["engine_shares", "fit_weights", "main", "stack_folder", "stack_out_of_fold"]


def engine_shares(members: pd.DataFrame, tests: Sequence[Any]) -> tuple[np.ndarray, list[str], np.ndarray]:
    """(P, engines, counts): P (n, k) share of toppled ok members per test and engine [–],
    counts (n, k) ok members; an engine without members for a test takes the mean of the test's
    other engines' shares (a test without any ok member raises)."""
    need = {"test", "engine", "toppled", "status"}
    if missing := need - set(members.columns):
        raise ValueError(f"ensemble members: columns {sorted(missing)} missing (expected {sorted(need)})")
    from .ensemble import ensemble_counts

    m = members.assign(test=members["test"].astype(str))
    engines = sorted(m.loc[m["status"] == "ok", "engine"].unique())
    idx = [str(t) for t in tests]
    p = np.full((len(idx), len(engines)), np.nan)
    count = np.zeros((len(idx), len(engines)), dtype=int)
    for j, e in enumerate(engines):  # the counts per test as validate --ensemble computes them
        k, count[:, j], _ = ensemble_counts(m[m["engine"] == e], idx)
        p[:, j] = np.where(count[:, j] > 0, k / np.maximum(count[:, j], 1), np.nan)
    if (empty := count.sum(axis=1) == 0).any():
        raise ValueError(f"tests {[t for t, e in zip(idx, empty, strict=True) if e]} have no ok member")
    fill = np.nanmean(p, axis=1)
    rows, cols = np.nonzero(np.isnan(p))
    p[rows, cols] = fill[rows]
    return p, engines, count


def fit_weights(P: np.ndarray, observed: np.ndarray) -> np.ndarray:
    """Weights w (k,) on the simplex minimising the Brier score mean((P w − o)²) [–].

    P : (n, k) per-engine P(topple); observed : (n,) 0/1. Convex: SLSQP from equal weights, then
    clipped to [0, 1] and renormalised (round-off). Ties (e.g. identical columns) keep the
    solver's answer; k = 1 returns [1].
    """
    p = np.asarray(P, dtype=float)
    o = np.asarray(observed, dtype=float)
    if p.ndim != 2 or p.shape[0] != o.size:
        raise ValueError(f"P {p.shape} and observed {o.shape}: expected (n, k) and (n,)")
    k = p.shape[1]
    if k == 1:
        return np.ones(1)
    from scipy.optimize import minimize

    def brier(w: np.ndarray) -> float:
        return float(np.mean((p @ w - o) ** 2))

    def grad(w: np.ndarray) -> np.ndarray:
        return 2.0 * p.T @ (p @ w - o) / o.size

    res = minimize(
        brier, np.full(k, 1.0 / k), jac=grad, method="SLSQP", bounds=[(0.0, 1.0)] * k,
        constraints=({"type": "eq", "fun": lambda w: float(w.sum() - 1.0)},), options={"ftol": 1e-12},
    )  # fmt: skip
    w = np.clip(res.x, 0.0, 1.0)
    return w / w.sum()


def stack_out_of_fold(
    P: np.ndarray, observed: np.ndarray, folds: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(p, weights): out-of-fold stacked P (n,) and the weights fitted per fold (n_folds, k).

    Each fold's tests get ``P w`` with w fitted by :func:`fit_weights` on the other folds only.
    """
    p = np.asarray(P, dtype=float)
    o = np.asarray(observed)
    f = np.asarray(folds, dtype=int)
    out = np.full(o.size, np.nan)
    ws = []
    for k in np.unique(f):
        held = f == k
        w = fit_weights(p[~held], o[~held])
        out[held] = p[held] @ w
        ws.append(w)
    return out, np.array(ws)


def stack_folder(folder: Path) -> dict[str, Any]:
    """Stack the engines of a ``validate --ensemble`` output folder (see the module docstring).

    Returns a dict: ``engines``, ``n_tests``, ``members_per_test``, ``weights_all`` (fitted on every
    test), ``weights_per_fold``, and ``scores`` per model (``probabilistic_scores``): ``stacked``
    (out of fold), ``ensemble`` (as run), one per engine's member share, and the out-of-fold
    logistic baselines found in ``outcomes.csv``.
    """
    from .scores import probabilistic_scores

    folder = Path(folder)
    for name in ("outcomes.csv", "ensemble_members.csv"):
        if not (folder / name).is_file():
            raise FileNotFoundError(
                f"{folder / name}: not found (expected a validate --ensemble output folder)"
            )
    out = pd.read_csv(folder / "outcomes.csv", dtype={"test": str})
    for col in ("observed", "fold", "p_ensemble"):
        if col not in out.columns:
            raise ValueError(
                f"{folder / 'outcomes.csv'}: column {col!r} missing (a validate --ensemble run writes it)"
            )
    out = out[out["p_ensemble"].notna()]
    members = pd.read_csv(folder / "ensemble_members.csv", dtype={"test": str})
    P, engines, counts = engine_shares(members, out["test"].tolist())
    o = out["observed"].to_numpy(dtype=int)
    folds = out["fold"].to_numpy(dtype=int)
    p_oof, w_fold = stack_out_of_fold(P, o, folds)
    models: dict[str, np.ndarray] = {"stacked": p_oof, "ensemble": out["p_ensemble"].to_numpy(dtype=float)}
    for j, e in enumerate(engines):
        models[f"{e} members"] = P[:, j]
    for col in out.columns:
        if col.startswith("p_logistic") or col == "p_transferred":
            models[col[2:]] = out[col].to_numpy(dtype=float)
    return {
        "folder": str(folder),
        "engines": engines,
        "n_tests": int(o.size),
        "members_per_test": float(counts.sum(axis=1).mean()),
        "weights_all": fit_weights(P, o).round(4).tolist(),
        "weights_per_fold": w_fold.round(4).tolist(),
        "scores": {m: probabilistic_scores(o, np.clip(p, 0.0, 1.0)) for m, p in models.items()},
    }


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m pbr_xval.validation.stacking", description=__doc__.split("\n")[0]
    )
    ap.add_argument("folders", nargs="+", type=Path, help="validate --ensemble output folders")
    ap.add_argument("--json", type=Path, help="also write the results of every folder to this JSON file")
    a = ap.parse_args(argv)
    results = []
    for folder in a.folders:
        r = stack_folder(folder)
        results.append(r)
        e = r["engines"]
        print(
            f"stacking {folder}: {r['n_tests']} tests, engines {', '.join(e)}, {r['members_per_test']:.2f} members per test"
        )
        for i, w in enumerate(r["weights_per_fold"]):
            print(
                f"  weights fitted without fold {i}: "
                + ", ".join(f"{n} {x:.2f}" for n, x in zip(e, w, strict=True))
            )
        print(
            "  weights fitted on every test: "
            + ", ".join(f"{n} {x:.2f}" for n, x in zip(e, r["weights_all"], strict=True))
        )
        for m, s in r["scores"].items():
            print(
                f"  {m:<24} Brier {s['brier']:.4f}  log loss {s['log_loss']:.3f}  AUC {s['auc']:.3f}  F1 {s['f1']:.3f}"
            )
    if a.json:
        write_text_atomic(a.json, json.dumps(results, indent=1) + "\n")
    return 0


if __name__ == "__main__":  # pragma: no cover - exercised through main() in the tests
    raise SystemExit(main())
