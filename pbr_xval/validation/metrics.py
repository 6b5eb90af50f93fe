"""Scores of binary toppling predictions, empirical threshold rules and record-grouped folds.

The positive class is "toppled". With TP, FP, FN, TN the confusion counts:
accuracy = (TP+TN)/N, precision = TP/(TP+FP), recall = TP/(TP+FN),
F1 = 2TP/(2TP+FP+FN). An undefined ratio (0/0, e.g. precision with no predicted topple) is NaN.
"""

from __future__ import annotations

import hashlib
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

__all__ = ["Rule", "Scores", "fit_rule", "group_folds", "out_of_fold", "score"]


@dataclass(frozen=True)
class Scores:
    """Confusion counts and the scores derived from them."""

    tp: int
    fp: int
    fn: int
    tn: int

    @property
    def n(self) -> int:
        return self.tp + self.fp + self.fn + self.tn

    @staticmethod
    def _ratio(a: int, b: int) -> float:
        return a / b if b else math.nan

    @property
    def accuracy(self) -> float:
        return self._ratio(self.tp + self.tn, self.n)

    @property
    def precision(self) -> float:
        return self._ratio(self.tp, self.tp + self.fp)

    @property
    def recall(self) -> float:
        return self._ratio(self.tp, self.tp + self.fn)

    @property
    def f1(self) -> float:
        return self._ratio(2 * self.tp, 2 * self.tp + self.fp + self.fn)

    def to_dict(self) -> dict[str, Any]:
        return {
            "n": self.n, "tp": self.tp, "fp": self.fp, "fn": self.fn, "tn": self.tn,
            "accuracy": self.accuracy, "precision": self.precision, "recall": self.recall, "f1": self.f1,
        }  # fmt: skip


def score(observed: ArrayLike, predicted: ArrayLike) -> Scores:
    """Confusion counts of ``predicted`` against ``observed`` ((n,) booleans each)."""
    o = np.asarray(observed, dtype=bool)
    p = np.asarray(predicted, dtype=bool)
    if o.shape != p.shape or o.ndim != 1:
        raise ValueError(f"observed {o.shape} and predicted {p.shape} must be 1-D of the same length")
    return Scores(
        tp=int(np.sum(o & p)), fp=int(np.sum(~o & p)), fn=int(np.sum(o & ~p)), tn=int(np.sum(~o & ~p))
    )


@dataclass(frozen=True)
class Rule:
    """An empirical rule "toppled if every feature ≥ its threshold".

    ``features`` name the columns (e.g. ``("pga",)``, ``("pga", "pgv")``); ``thresholds`` are
    in the features' units.
    """

    features: tuple[str, ...]
    thresholds: tuple[float, ...]

    def predict(self, x: dict[str, np.ndarray]) -> np.ndarray:
        out = np.ones(len(next(iter(x.values()))), dtype=bool)
        for f, th in zip(self.features, self.thresholds, strict=True):
            out &= np.asarray(x[f], dtype=float) >= th
        return out

    def describe(self, units: dict[str, str] | None = None) -> str:
        u = units or {}
        return " and ".join(
            f"{f} ≥ {th:.4g}{(' ' + u[f]) if u.get(f) else ''}"
            for f, th in zip(self.features, self.thresholds, strict=True)
        )


def _cuts(v: np.ndarray) -> np.ndarray:
    """Candidate thresholds: midpoints between consecutive distinct values, plus both ends."""
    u = np.unique(v[np.isfinite(v)])
    if u.size == 0:
        return np.array([math.inf])
    mids = (u[:-1] + u[1:]) / 2
    return np.concatenate([[u[0] - 1.0 - abs(u[0])], mids, [u[-1] + 1.0 + abs(u[-1])]])


def fit_rule(x: dict[str, np.ndarray], observed: ArrayLike, features: Sequence[str]) -> Rule:
    """The thresholds maximising F1 on (x, observed); ties go to the highest accuracy, then the
    lowest thresholds (deterministic). One or two features (an exhaustive grid of midpoints)."""
    o = np.asarray(observed, dtype=bool)
    feats = tuple(features)
    if len(feats) == 1:
        v = np.asarray(x[feats[0]], dtype=float)
        cuts = _cuts(v)
        pred = v[None, :] >= cuts[:, None]  # (k, n)
        tp = (pred & o).sum(1)
        fp = (pred & ~o).sum(1)
        fn = (~pred & o).sum(1)
        tn = (~pred & ~o).sum(1)
        den = 2 * tp + fp + fn
        f1 = np.where(den > 0, 2 * tp / np.maximum(den, 1), -1.0)
        acc = (tp + tn) / o.size
        k = int(np.lexsort((cuts, -acc, -f1))[0])
        return Rule(feats, (float(cuts[k]),))
    if len(feats) == 2:
        a = np.asarray(x[feats[0]], dtype=float)
        b = np.asarray(x[feats[1]], dtype=float)
        ca, cb = _cuts(a), _cuts(b)
        pa = a[None, :] >= ca[:, None]  # (ka, n)
        pb = b[None, :] >= cb[:, None]  # (kb, n)
        pred = pa[:, None, :] & pb[None, :, :]  # (ka, kb, n)
        tp = (pred & o).sum(2)
        fp = (pred & ~o).sum(2)
        fn = (~pred & o).sum(2)
        tn = (~pred & ~o).sum(2)
        den = 2 * tp + fp + fn
        f1 = np.where(den > 0, 2 * tp / np.maximum(den, 1), -1.0)
        acc = (tp + tn) / o.size
        ia, ib = np.meshgrid(np.arange(ca.size), np.arange(cb.size), indexing="ij")
        order = np.lexsort((cb[ib].ravel(), ca[ia].ravel(), -acc.ravel(), -f1.ravel()))
        k = int(order[0])
        return Rule(feats, (float(ca[ia.ravel()[k]]), float(cb[ib.ravel()[k]])))
    raise ValueError(f"fit_rule takes one or two features, got {feats}")


def group_folds(groups: Sequence[str], k: int) -> np.ndarray:
    """Fold index (0..k−1) per item, whole groups per fold (group k-fold by earthquake record).

    Groups are ordered by the SHA-256 of their name (deterministic, independent of row order)
    and dealt to the currently smallest fold (largest groups first), so folds are balanced.
    """
    names = sorted(set(groups))
    if k < 2:
        raise ValueError(f"k = {k}: cross-validation needs at least 2 folds")
    if len(names) < k:
        raise ValueError(f"{len(names)} record(s) cannot make {k} folds (expected at least {k} records)")
    size = {g: 0 for g in names}
    for g in groups:
        size[g] += 1
    keyed = sorted(names, key=lambda g: (-size[g], hashlib.sha256(g.encode()).hexdigest()))
    load = [0] * k
    fold_of: dict[str, int] = {}
    for g in keyed:
        f = int(np.argmin(load))
        fold_of[g] = f
        load[f] += size[g]
    return np.array([fold_of[g] for g in groups], dtype=int)


def out_of_fold(
    x: dict[str, np.ndarray], observed: ArrayLike, features: Sequence[str], folds: np.ndarray
) -> tuple[np.ndarray, list[Rule]]:
    """Predictions of a rule refitted on the other folds for every held-out fold; (pred, rules)."""
    o = np.asarray(observed, dtype=bool)
    pred = np.zeros(o.size, dtype=bool)
    rules = []
    for f in range(int(folds.max()) + 1):
        held = folds == f
        rule = fit_rule({k: np.asarray(v)[~held] for k, v in x.items()}, o[~held], features)
        pred[held] = rule.predict({k: np.asarray(v)[held] for k, v in x.items()})
        rules.append(rule)
    return pred, rules
