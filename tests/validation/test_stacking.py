"""Engine weights fitted by stacking (pbr_xval.validation.stacking): closed forms and no leakage."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from pbr_xval.validation import stacking


def _closed_form_two(P: np.ndarray, o: np.ndarray) -> float:
    """The Brier-optimal weight of engine 1 in w·P1 + (1 − w)·P2: the least-squares slope of
    o − P2 on P1 − P2, clipped to [0, 1] (the quadratic is convex in w)."""
    d = P[:, 0] - P[:, 1]
    return float(np.clip(np.dot(o - P[:, 1], d) / np.dot(d, d), 0.0, 1.0))


@pytest.mark.parametrize("seed", range(6))
def test_two_engine_weight_is_the_clipped_least_squares_slope(seed: int) -> None:
    rng = np.random.default_rng(seed)
    o = rng.integers(0, 2, 80)
    # engine 1 informative to a degree that varies with the seed, engine 2 noisier
    P = np.column_stack([
        np.clip(o * rng.uniform(0.2, 1.0) + rng.uniform(0, 0.6, 80), 0, 1),
        rng.uniform(0, 1, 80),
    ])  # fmt: skip
    w = stacking.fit_weights(P, o)
    assert w.sum() == pytest.approx(1.0)
    assert w[0] == pytest.approx(_closed_form_two(P, o), abs=1e-6)


def test_a_perfect_engine_takes_all_the_weight_and_a_useless_one_none() -> None:
    rng = np.random.default_rng(1)
    o = rng.integers(0, 2, 60)
    P = np.column_stack([rng.uniform(0, 1, 60), o.astype(float), np.full(60, 0.5)])
    w = stacking.fit_weights(P, o)
    assert w == pytest.approx([0.0, 1.0, 0.0], abs=1e-6)


def test_out_of_fold_p_never_sees_its_own_fold() -> None:
    """Flipping every outcome of fold 2 changes the weights of the other folds, never fold 2's P."""
    rng = np.random.default_rng(3)
    n = 90
    o = rng.integers(0, 2, n)
    folds = np.repeat(np.arange(3), n // 3)
    P = np.column_stack([np.clip(o + rng.normal(0, 0.4, n), 0, 1), rng.uniform(0, 1, n)])
    p1, w1 = stacking.stack_out_of_fold(P, o, folds)
    o2 = o.copy()
    o2[folds == 2] = 1 - o2[folds == 2]
    p2, _ = stacking.stack_out_of_fold(P, o2, folds)
    np.testing.assert_array_equal(p1[folds == 2], p2[folds == 2])
    assert not np.allclose(p1[folds != 2], p2[folds != 2])
    assert w1.shape == (3, 2)


def test_engine_shares_fill_a_missing_engine_with_the_others_mean() -> None:
    members = pd.DataFrame({
        "test": ["1", "1", "1", "2", "2", "3"],
        "engine": ["a", "a", "b", "a", "b", "a"],
        "toppled": [True, False, True, False, False, True],
        "status": ["ok", "ok", "ok", "ok", "ok", "failed"],
    })  # fmt: skip
    with pytest.raises(ValueError, match=r"\['3'\] have no ok member"):
        stacking.engine_shares(members, ["1", "2", "3"])
    members.loc[5, "status"] = "ok"
    P, engines, counts = stacking.engine_shares(members, ["1", "2", "3"])
    assert engines == ["a", "b"]
    np.testing.assert_allclose(P, [[0.5, 1.0], [0.0, 0.0], [1.0, 1.0]])
    np.testing.assert_array_equal(counts, [[2, 1], [1, 1], [1, 0]])


def test_stack_folder_reads_a_validate_output_and_says_what_is_missing(tmp_path, capsys) -> None:
    with pytest.raises(FileNotFoundError, match=r"outcomes\.csv: not found"):
        stacking.stack_folder(tmp_path)
    rng = np.random.default_rng(7)
    n = 40
    o = rng.integers(0, 2, n)
    tests = [str(100 + i) for i in range(n)]
    rows = []
    for t, y in zip(tests, o, strict=True):
        for m in range(4):  # engine "good" agrees with the lab 3 times in 4, "coin" is a coin
            eng = "good" if m % 2 == 0 else "coin"
            top = bool(y) if (eng == "good" and m < 2) else bool(rng.integers(0, 2))
            rows.append({"test": t, "engine": eng, "toppled": top, "status": "ok"})
    pd.DataFrame(rows).to_csv(tmp_path / "ensemble_members.csv", index=False)
    pd.DataFrame({"test": tests, "observed": o}).to_csv(tmp_path / "outcomes.csv", index=False)
    with pytest.raises(ValueError, match="column 'fold' missing"):
        stacking.stack_folder(tmp_path)
    share = pd.DataFrame(rows).groupby("test")["toppled"].mean().reindex(tests).to_numpy()
    pd.DataFrame({"test": tests, "observed": o, "fold": np.arange(n) % 4, "p_ensemble": share}).to_csv(
        tmp_path / "outcomes.csv", index=False
    )
    assert stacking.main([str(tmp_path), "--json", str(tmp_path / "w.json")]) == 0
    out = capsys.readouterr().out
    assert "weights fitted on every test: coin" in out and "stacked" in out
    r = stacking.stack_folder(tmp_path)
    assert r["engines"] == ["coin", "good"] and r["weights_all"][1] > 0.8
    assert r["scores"]["stacked"]["brier"] < r["scores"]["ensemble"]["brier"]
    assert (tmp_path / "w.json").is_file()
