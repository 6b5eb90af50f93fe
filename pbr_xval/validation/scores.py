"""Probabilistic scores of toppling predictions and the logistic baselines they are compared with.

A probability of toppling P ∈ [0, 1] per shake-table test is scored against the observed
outcome (1 = toppled) with **proper scores** (scikit-learn's implementations, not our own):

* **Brier score** — mean of (P − o)² over the tests, [–], 0 is perfect; a 0/1 prediction's Brier
  is its error rate, so deterministic engines and threshold rules get a comparable Brier line;
* **log loss** — −mean(o ln P + (1 − o) ln(1 − P)), [nats], with P clipped to [ε, 1 − ε],
  ε = :data:`LOG_LOSS_EPS` = 1e-3: a 0/1 prediction that is wrong has an infinite log loss, so
  the clip is what makes a deterministic prediction's log loss finite (each confident miss
  costs −ln ε = 6.91 nats; a right one costs −ln(1 − ε) = 0.001);
* **ROC AUC** — the probability that a random toppled test gets a higher P than a random standing
  one (ties count ½); NaN when the tests hold one class only;
* **F1 at P ≥ 0.5** with its confusion counts (the same F1 as
  :func:`pbr_xval.validation.metrics.score` for 0/1 predictions).

Baselines, every one out of fold by earthquake record with the folds of the threshold rules
(:func:`pbr_xval.validation.metrics.group_folds`): logistic regressions of the outcome on ln PGA,
ln PGV and both (:func:`logistic_baselines`), and a **transferred** logistic regression fitted on
another specimen with the intensity measures normalised by each rock's geometry
(:func:`transferred_baseline`, :class:`RockGeometry`) — what a user has for a rock that was never
on a shake table.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike

__all__ = [
    "LOGISTIC_C",
    "LOGISTIC_MODELS",
    "LOG_LOSS_EPS",
    "LogisticFit",
    "RockGeometry",
    "Transferred",
    "fit_logistic",
    "logistic_baselines",
    "logistic_out_of_fold",
    "normalised_ims",
    "probabilistic_scores",
    "reliability",
    "transferred_baseline",
]

#: probabilities are clipped to [ε, 1 − ε] before the log loss (a 0/1 miss would cost ∞)
LOG_LOSS_EPS = 1e-3
#: inverse L2 strength of every logistic fit (scikit-learn's C), on standardised features
LOGISTIC_C = 100.0
#: name → features (columns of ln PGA, ln PGV) of the logistic baselines; names carry no spaces
#: so that ``Brier <model> <value>`` lines split into three fields
LOGISTIC_MODELS: dict[str, tuple[str, ...]] = {
    "logistic(lnPGA)": ("pga",),
    "logistic(lnPGV)": ("pgv",),
    "logistic(lnPGA,lnPGV)": ("pga", "pgv"),
}


def _check(observed: ArrayLike, p: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    o = np.asarray(observed)
    q = np.asarray(p, dtype=float)
    if o.ndim != 1 or q.shape != o.shape:
        raise ValueError(f"observed {o.shape} and p {q.shape} must be 1-D of the same length")
    if o.size == 0:
        raise ValueError("no tests to score")
    if not np.all(np.isin(o, (0, 1))):
        raise ValueError("observed outcomes must be 0/1 (or booleans)")
    if not np.all(np.isfinite(q)) or q.min() < 0 or q.max() > 1:
        raise ValueError("p must be finite probabilities in [0, 1] (leave failed runs out before scoring)")
    return o.astype(int), q


def probabilistic_scores(observed: ArrayLike, p: ArrayLike, *, eps: float = LOG_LOSS_EPS) -> dict[str, Any]:
    """Brier score, log loss, ROC AUC and F1 at P ≥ 0.5 of toppling probabilities.

    Parameters
    ----------
    observed : (n,) 0/1 or bool — 1 when the specimen toppled.
    p : (n,) float in [0, 1], [–] — predicted P(topple) per test; a deterministic prediction is
        given as 0/1 and is scored the same way.
    eps : clip of ``p`` for the log loss only, [–] (default :data:`LOG_LOSS_EPS` = 1e-3; see the
        module docstring: without it a wrong 0/1 prediction has an infinite log loss).

    Returns
    -------
    dict with ``n``; ``brier`` [–] (``sklearn.metrics.brier_score_loss``); ``log_loss`` [nats]
    (``sklearn.metrics.log_loss`` of the clipped ``p``); ``auc`` [–]
    (``sklearn.metrics.roc_auc_score``, NaN when ``observed`` holds one class); ``f1`` at
    P ≥ 0.5 (``sklearn.metrics.f1_score``, NaN when undefined: no topple observed nor
    predicted); ``tp``, ``fp``, ``fn``, ``tn`` at P ≥ 0.5 (``sklearn.metrics.confusion_matrix``);
    ``log_loss_eps`` (the clip used).
    """
    from sklearn.metrics import brier_score_loss, confusion_matrix, f1_score, log_loss, roc_auc_score

    o, q = _check(observed, p)
    if not 0 < eps < 0.5:
        raise ValueError(f"eps = {eps!r}: expected 0 < eps < 0.5")
    pred = (q >= 0.5).astype(int)
    tn, fp, fn, tp = (int(v) for v in confusion_matrix(o, pred, labels=[0, 1]).ravel())
    two = np.unique(o).size == 2
    return {
        "n": int(o.size),
        "brier": float(brier_score_loss(o, q, pos_label=1)),
        "log_loss": float(log_loss(o, np.clip(q, eps, 1 - eps), labels=[0, 1])),
        "auc": float(roc_auc_score(o, q)) if two else math.nan,
        "f1": float(f1_score(o, pred, labels=[0, 1], pos_label=1, zero_division=np.nan)),
        "tp": tp, "fp": fp, "fn": fn, "tn": tn,
        "log_loss_eps": float(eps),
    }  # fmt: skip


def reliability(
    observed: ArrayLike, p: ArrayLike, n_bins: int = 10, strategy: str = "uniform"
) -> pd.DataFrame:
    """Reliability (calibration) curve with the number of tests per bin, for the diagram.

    ``sklearn.calibration.calibration_curve`` gives each non-empty bin's mean predicted P and
    observed frequency; this adds the bin edges and counts (computed with the same binning, and
    checked against scikit-learn's means).

    Parameters
    ----------
    observed : (n,) 0/1 or bool.
    p : (n,) float in [0, 1], [–].
    n_bins : number of bins on [0, 1].
    strategy : ``"uniform"`` (equal widths) or ``"quantile"`` (equal counts), as scikit-learn.

    Returns
    -------
    DataFrame, one row per **non-empty** bin in increasing P: ``bin_lo``, ``bin_hi`` [–] (edges),
    ``n`` (tests in the bin; the column sums to len(p)), ``mean_predicted`` [–],
    ``observed_frequency`` [–] (share of toppled tests in the bin).
    """
    from sklearn.calibration import calibration_curve

    o, q = _check(observed, p)
    if n_bins < 1:
        raise ValueError(f"n_bins = {n_bins}: expected at least 1")
    prob_true, prob_pred = calibration_curve(o, q, n_bins=n_bins, strategy=strategy)
    if strategy == "quantile":
        edges = np.percentile(q, np.linspace(0, 100, n_bins + 1))
    else:
        edges = np.linspace(0.0, 1.0, n_bins + 1)
    ids = np.searchsorted(edges[1:-1], q)  # scikit-learn's binning
    counts = np.bincount(ids, minlength=n_bins)
    keep = np.flatnonzero(counts)
    mean_pred = np.bincount(ids, weights=q, minlength=n_bins)[keep] / counts[keep]
    if mean_pred.shape != prob_pred.shape or not np.allclose(mean_pred, prob_pred, rtol=0, atol=1e-12):
        raise RuntimeError("bin counts do not match scikit-learn's calibration_curve binning")
    return pd.DataFrame(
        {
            "bin_lo": np.round(edges[keep], 12),  # 0.3, not 0.30000000000000004
            "bin_hi": np.round(edges[keep + 1], 12),
            "n": counts[keep].astype(int),
            "mean_predicted": prob_pred,
            "observed_frequency": prob_true,
        }
    )


# ------------------------------------------------------------------ logistic regressions
@dataclass(frozen=True)
class LogisticFit:
    """P(topple) = 1 / (1 + exp(−(intercept + Σ coef_j · x_j))), fitted by :func:`fit_logistic`.

    ``coef`` are per unit of the features as given (e.g. per unit of ln PGA), not of the
    standardised features the fit used internally.
    """

    features: tuple[str, ...]
    intercept: float
    coef: tuple[float, ...]
    C: float
    n: int

    def predict(self, X: ArrayLike) -> np.ndarray:
        """(n,) P(topple) for ``X`` (n, k) in the features' units (a 1-D array is one feature)."""
        from scipy.special import expit

        x = np.asarray(X, dtype=float)
        x = x[:, None] if x.ndim == 1 else x
        return np.asarray(expit(self.intercept + x @ np.asarray(self.coef)), dtype=float)


def fit_logistic(
    X: ArrayLike, observed: ArrayLike, *, features: Sequence[str] | None = None, C: float = LOGISTIC_C
) -> LogisticFit:
    """Logistic regression of the outcome on ``X`` (``sklearn.linear_model.LogisticRegression``).

    The features are standardised (mean 0, s.d. 1 over these rows) and fitted with scikit-learn's
    default L2 penalty at ``C`` = :data:`LOGISTIC_C` = 100 (lbfgs; the intercept is not
    penalised): a weak penalty that moves a slope by a fraction ~1/(C·n·p(1−p)) — below 1 % for
    the campaign's ~150 training tests, far inside the slope's sampling error — while keeping
    the fit finite when a fold happens to be separable (an unpenalised fit would diverge and
    give 0/1 probabilities with an infinite log loss). The coefficients are converted back to
    the units of ``X``.

    Parameters
    ----------
    X : (n, k) or (n,) float — features (e.g. ln PGA with PGA in m/s²).
    observed : (n,) 0/1 or bool; both classes must be present.
    features : names of the k columns (default ``x0``, ``x1``, …).
    C : inverse penalty strength on the standardised features.
    """
    from sklearn.linear_model import LogisticRegression

    x = np.asarray(X, dtype=float)
    x = x[:, None] if x.ndim == 1 else x
    o = np.asarray(observed).astype(int)
    if x.ndim != 2 or x.shape[0] != o.size:
        raise ValueError(f"X {x.shape} and observed {o.shape} do not match")
    if not np.all(np.isfinite(x)):
        raise ValueError("X has non-finite values (a PGA or PGV ≤ 0 has no logarithm)")
    if np.unique(o).size < 2:
        raise ValueError("a logistic fit needs both outcomes (toppled and standing) among its tests")
    mu = x.mean(axis=0)
    sd = x.std(axis=0)
    sd = np.where(sd > 0, sd, 1.0)
    model = LogisticRegression(C=C, max_iter=1000)
    model.fit((x - mu) / sd, o)
    w = model.coef_[0] / sd
    b = float(model.intercept_[0] - np.sum(w * mu))
    names = tuple(features) if features is not None else tuple(f"x{j}" for j in range(x.shape[1]))
    return LogisticFit(
        features=names, intercept=b, coef=tuple(float(v) for v in w), C=float(C), n=int(o.size)
    )


def logistic_out_of_fold(
    X: ArrayLike, observed: ArrayLike, folds: ArrayLike, *, C: float = LOGISTIC_C
) -> tuple[np.ndarray, list[LogisticFit | None]]:
    """Out-of-fold P(topple): each fold predicted by :func:`fit_logistic` on the other folds.

    Parameters
    ----------
    X : (n, k) or (n,) float — features.
    observed : (n,) 0/1.
    folds : (n,) int fold index per test (e.g. :func:`~pbr_xval.validation.metrics.group_folds`
        over the earthquake records, as the threshold rules use).

    Returns
    -------
    (p, fits): p (n,) [–], a test's P never depends on its own outcome; fits, one per fold
    (None for a fold whose training folds hold one outcome only: no logistic law can be fitted,
    and its tests get that base rate, 0 or 1, the constant model's prediction).
    """
    x = np.asarray(X, dtype=float)
    x = x[:, None] if x.ndim == 1 else x
    o = np.asarray(observed).astype(int)
    f = np.asarray(folds, dtype=int)
    if f.shape != o.shape:
        raise ValueError(f"folds {f.shape} and observed {o.shape} do not match")
    p = np.full(o.size, math.nan)
    fits: list[LogisticFit | None] = []
    for k in np.unique(f):
        held = f == k
        if np.unique(o[~held]).size < 2:  # no contrast to fit: the training folds' base rate
            p[held] = float(o[~held].mean())
            fits.append(None)
            continue
        fit = fit_logistic(x[~held], o[~held], C=C)
        p[held] = fit.predict(x[held])
        fits.append(fit)
    return p, fits


def _ln_ims(pga: ArrayLike, pgv: ArrayLike) -> dict[str, np.ndarray]:
    a = np.asarray(pga, dtype=float)
    v = np.asarray(pgv, dtype=float)
    if a.shape != v.shape or a.ndim != 1:
        raise ValueError(f"pga {a.shape} and pgv {v.shape} must be 1-D of the same length")
    if not (np.all(a > 0) and np.all(v > 0)):
        raise ValueError("PGA and PGV must be > 0 (their logarithms are the features)")
    return {"pga": np.log(a), "pgv": np.log(v)}


def logistic_baselines(
    pga: ArrayLike, pgv: ArrayLike, observed: ArrayLike, folds: ArrayLike, *, C: float = LOGISTIC_C
) -> dict[str, np.ndarray]:
    """The three logistic baselines, out of fold: P(topple) per test for each of :data:`LOGISTIC_MODELS`.

    Parameters
    ----------
    pga : (n,) m/s²; pgv : (n,) m/s — the tests' intensity measures (the same ones the rules
        use); the features are ln PGA and ln PGV (natural logs of the values in these units).
    observed : (n,) 0/1.
    folds : (n,) int — record-grouped folds (:func:`~pbr_xval.validation.metrics.group_folds`).

    Returns
    -------
    {``"logistic(lnPGA)"``, ``"logistic(lnPGV)"``, ``"logistic(lnPGA,lnPGV)"``} → (n,) P [–].
    """
    ln = _ln_ims(pga, pgv)
    out = {}
    for name, feats in LOGISTIC_MODELS.items():
        X = np.column_stack([ln[f] for f in feats])
        out[name], _ = logistic_out_of_fold(X, observed, folds, C=C)
    return out


# ------------------------------------------------------------------ transferred baseline
@dataclass(frozen=True)
class RockGeometry:
    """What the transferred baseline needs of a rock: its critical tilt, pivot distance and frequency.

    Attributes
    ----------
    alpha : rad — critical tilt α (by default α_min, the smallest over all directions φ).
    R : m — distance from the COM to the pivot axis (the support edge the rock rocks on toward
        the direction of ``alpha``), measured in the rocking plane.
    p : rad/s — Housner's frequency parameter √(m g R / I_O), I_O the moment of inertia about
        the pivot axis; √(3g / (4R)) for a rectangular block of half-diagonal R.
    g : m/s².
    azimuth : rad — the direction of ``alpha`` (from +x toward +y).
    """

    alpha: float
    R: float
    p: float
    g: float = 9.81
    azimuth: float = 0.0

    @classmethod
    def block(cls, half_width: float, half_height: float, g: float = 9.81) -> RockGeometry:
        """A rectangular block (half-width b, half-height h, m): α = atan(b/h), R = √(b²+h²), p = √(3g/4R)."""
        R = math.hypot(half_width, half_height)
        return cls(alpha=math.atan2(half_width, half_height), R=R, p=math.sqrt(3 * g / (4 * R)), g=g)

    @classmethod
    def from_scene(cls, scene: Any, azimuth: float | str = "min") -> RockGeometry:
        """The geometry of a compiled scene's rock (:func:`pbr_xval.scene.compile_scene`).

        ``azimuth``: ``"min"`` (default) — the direction of the smallest critical tilt over all
        φ (:meth:`StabilityTable.minimum <pbr_xval.geometry.stability.StabilityTable.minimum>`:
        branch and bound on a 0.25° grid, then a bounded scalar search), what matters
        when the shaking direction is unknown (a field rock); ``"scenario"`` — the
        weaker of ±d for the scenario's shaking direction d (:attr:`Scene.alpha`); or an angle
        in rad.
        """
        from pbr_xval.geometry.stability import critical_tilt, hull_vertices, support_lever

        rock = scene.rock
        v = hull_vertices(rock.mesh.vertices)
        com = np.asarray(rock.com, dtype=float)

        def tilt(phi: float) -> float:
            a = critical_tilt(v, com, np.array([math.cos(phi), math.sin(phi), 0.0]))
            return a if np.isfinite(a) else math.inf

        if azimuth == "min":
            _, phi = rock.stability.minimum()
        else:
            base = scene.azimuth if azimuth == "scenario" else float(azimuth)
            phi = min((base, base + math.pi), key=tilt)
        phi %= 2 * math.pi
        alpha = tilt(phi)
        if not math.isfinite(alpha):
            raise ValueError("the rock is not at rest: no critical tilt")
        d = np.array([math.cos(phi), math.sin(phi), 0.0])
        b, h = support_lever(v, com, d)
        R = math.hypot(b, h)
        e = np.cross([0.0, 0.0, 1.0], d)
        i_pivot = float(e @ np.asarray(rock.inertia, dtype=float) @ e) + rock.mass * R**2
        g = float(scene.gravity)
        return cls(alpha=alpha, R=R, p=math.sqrt(rock.mass * g * R / i_pivot), g=g, azimuth=phi)

    @classmethod
    def from_scenario(cls, path: Any, azimuth: float | str = "min") -> RockGeometry:
        """:meth:`from_scene` of a scenario file (loaded and compiled)."""
        from pbr_xval.scenario import load_scenario
        from pbr_xval.scene import compile_scene

        return cls.from_scene(compile_scene(load_scenario(path)), azimuth)

    @property
    def uplift(self) -> float:
        """g·tan α, m/s² — the acceleration scale of the normalisation."""
        return self.g * math.tan(self.alpha)


def normalised_ims(pga: ArrayLike, pgv: ArrayLike, geom: RockGeometry) -> np.ndarray:
    """(n, 2) dimensionless features of the transferred baseline (see :func:`transferred_baseline`).

    x1 = ln(PGA / (g tan α)), x2 = ln(PGV · p / (g tan α)); ``pga`` (n,) m/s², ``pgv`` (n,) m/s.
    """
    ln = _ln_ims(pga, pgv)
    s = math.log(geom.uplift)
    return np.column_stack([ln["pga"] - s, ln["pgv"] + math.log(geom.p) - s])


@dataclass(frozen=True)
class Transferred:
    """Result of :func:`transferred_baseline`: ``p`` (n_target,) [–], the fit, both feature sets."""

    p: np.ndarray
    fit: LogisticFit
    x_target: np.ndarray
    x_source: np.ndarray


def transferred_baseline(
    target: pd.DataFrame | Mapping[str, ArrayLike],
    source: pd.DataFrame | Mapping[str, ArrayLike],
    target_geom: RockGeometry,
    source_geom: RockGeometry,
    *,
    C: float = LOGISTIC_C,
) -> Transferred:
    """P(topple) of the target rock's tests from a logistic law fitted on another rock.

    The law is fitted on every test of ``source`` (none of the target's outcomes is used, so
    every target test is out of sample) in dimensionless intensity measures:

    * x1 = ln(PGA / (g tan α)) — PGA in units of the rock's quasi-static uplift acceleration
      (for a block g tan α is exactly the uplift level; no rock topples below its uplift);
    * x2 = ln(PGV · p / (g tan α)) — PGV in units of g tan α / p, p = √(m g R / I_O) Housner's
      frequency parameter (√(3g/4R) for a block of half-diagonal R).

    Why these two: by dimensional analysis the rocking of a rigid block under a pulse of
    amplitude a_p and circular frequency ω_p depends only on a_p / (g tan α), ω_p / p and α
    (and the restitution) (Makris & Roussos 2000; Dimitrakopoulos & DeJong 2012); with
    PGV ≈ a_p / ω_p, x2 = x1 + ln(p / ω_p) combines both groups. It is also the velocity scale
    of toppling itself: a ground velocity step v overturns a block when the rotation it imparts,
    θ̇ = v·mR cos α / I_O, carries the energy m g R (1 − cos α), i.e. v = 2 g sin(α/2) / (p cos α)
    ≈ g tan α / p, so x2 ≈ 0 at the impulsive threshold. Dividing by p rather than by √(gR)
    keeps the rock's inertia (its size) in the velocity scale, which is what makes a large rock
    harder to topple at the same PGV and α. For rocks of different size and slenderness, the
    same (x1, x2) puts them at the same distance from their thresholds, so a law learnt on one
    rock can be carried to another.

    Parameters
    ----------
    target : columns ``pga`` (n,) m/s² and ``pgv`` (n,) m/s of the target's tests.
    source : columns ``pga`` m/s², ``pgv`` m/s and ``observed`` (0/1) of the source's tests.
    target_geom, source_geom : :class:`RockGeometry` of each rock (e.g.
        :meth:`RockGeometry.from_scenario`; the same ``azimuth`` convention for both).
    C : see :func:`fit_logistic`.

    Returns
    -------
    :class:`Transferred` (``p`` per target test, in the target's row order).
    """
    xs = normalised_ims(np.asarray(source["pga"]), np.asarray(source["pgv"]), source_geom)
    xt = normalised_ims(np.asarray(target["pga"]), np.asarray(target["pgv"]), target_geom)
    fit = fit_logistic(xs, np.asarray(source["observed"]), features=("ln_pga_norm", "ln_pgv_norm"), C=C)
    return Transferred(p=fit.predict(xt), fit=fit, x_target=xt, x_source=xs)
