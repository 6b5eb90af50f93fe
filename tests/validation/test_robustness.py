"""pbr_xval.validation.robustness: fragile tests, F1 per variant, what a guard may pin."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pandas as pd
import pytest

from pbr_xval.validation.robustness import f1_range, fragility_table, main, summarise

from .conftest import REPO


def _oc(pred: list[int]) -> pd.DataFrame:
    return pd.DataFrame({"test": ["1", "2", "3", "4"], "observed": [1, 1, 0, 0], "pred_e": pred})


def test_fragile_tests_are_those_any_variant_flips() -> None:
    t = fragility_table(
        {"base": _oc([1, 0, 0, 1]), "tilt": _oc([1, 1, 0, 1]), "dt+1%": _oc([1, 0, 0, 0])}, "e"
    )
    assert t["fragile"].tolist() == [False, True, False, True]
    s = summarise(t, ["base", "tilt", "dt+1%"])
    assert s["fragile"] == 2 and s["fragile_share"] == 0.5 and s["fragile_tests"] == ["2", "4"]
    assert s["robust_outcomes"] == {"1": 1, "3": 0}
    # F1 = 2TP / (2TP + FP + FN): base TP 1 FP 1 FN 1 → 0.5; tilt TP 2 FP 1 → 0.8; dt+1% TP 1 FN 1 → 2/3
    assert s["f1"] == pytest.approx({"base": 0.5, "tilt": 0.8, "dt+1%": 2 / 3})


def test_variants_are_checked_before_anything_runs(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        main(["x", "--scenario", "s.toml", "--engine", "housner", "--out", "o", "--variants", "base,wobble"])
    assert "wobble" in capsys.readouterr().err


def test_f1_range_over_the_fragile_tests() -> None:
    observed = {"1": 1, "2": 1, "3": 0, "4": 0, "5": 1}
    robust = {"1": 1, "3": 0, "4": 1}  # TP 1, FP 1
    lo, hi = f1_range(observed, robust, ["2", "5"])  # both topple in the lab
    assert lo == pytest.approx(2 / (2 + 1 + 2))  # both missed: TP 1, FP 1, FN 2
    assert hi == pytest.approx(6 / (6 + 1))  # both caught: TP 3, FP 1
    assert f1_range(observed, robust, []) == (pytest.approx(2 / 3), pytest.approx(2 / 3))


# --------------------------------------------------------------------------- ensembles
def test_ensemble_variants_move_every_member_by_the_stated_amount() -> None:
    from pbr_xval.scenario import load_scenario
    from pbr_xval.uncertainty import EnsembleSpec, ensemble_spec
    from pbr_xval.validation.robustness import ensemble_variant_uncertainty

    table: dict[str, Any] = {
        "members": 16, "seed": 0, "sampling": "sobol", "engines": ["mujoco", "pybullet"],
        "initial.theta": {"dist": "normal", "mean": 0.0, "sd": 0.002, "low": -0.005, "high": 0.005},
        "timestep": {"dist": "uniform", "low": 0.8e-3, "high": 1.2e-3},
    }  # fmt: skip
    assert ensemble_variant_uncertainty(table, "base") == table
    tilt = ensemble_variant_uncertainty(table, "tilt")
    assert tilt["initial.theta"]["mean"] == 1e-9 and tilt["initial.theta"]["sd"] == 0.002
    assert tilt["timestep"] == table["timestep"] and table["initial.theta"]["mean"] == 0.0  # a copy
    dt = ensemble_variant_uncertainty(table, "dt+1%")
    assert dt["timestep"] == {"dist": "uniform", "low": 0.8e-3 * 1.01, "high": 1.2e-3 * 1.01}
    with pytest.raises(ValueError, match=r"initial\.theta"):
        ensemble_variant_uncertainty({"members": 4}, "tilt")

    def members(t: dict) -> list:
        scn = load_scenario(REPO / "examples" / "validation" / "sp1.toml", check_files=False)
        spec = ensemble_spec(scn.model_copy(update={"uncertainty": t}))
        assert isinstance(spec, EnsembleSpec)
        return spec.sample(engines=["mujoco", "pybullet"])

    base, moved, slower = members(table), members(tilt), members(dt)
    for b, m, s in zip(base, moved, slower, strict=True):
        assert m.values["initial.theta"] - b.values["initial.theta"] == pytest.approx(1e-9, rel=1e-6)
        assert m.values["timestep"] == b.values["timestep"] and m.engine == b.engine
        assert s.values["timestep"] == pytest.approx(1.01 * b.values["timestep"], rel=1e-12)


def test_ensemble_score_range_over_each_tests_range() -> None:
    from pbr_xval.validation.robustness import ensemble_score_range

    observed = {"a": 1, "b": 0, "c": 1}
    # a: 0.75 … 1 (always ≥ 0.5); b: 0 … 0.5 (straddles 0.5: fragile); c: 0.25
    r = ensemble_score_range(observed, {"a": (0.75, 1.0), "b": (0.0, 0.5), "c": (0.25, 0.25)})
    assert r["brier"][0] == pytest.approx((0.0 + 0.0 + 0.5625) / 3)
    assert r["brier"][1] == pytest.approx((0.0625 + 0.25 + 0.5625) / 3)
    # robust: a TP, c FN; b a false alarm (F1 2/(2+1+1)) or a true negative (2/(2+0+1))
    assert r["f1"] == (pytest.approx(0.5), pytest.approx(2 / 3))
    # a range around the observed outcome contains a zero term: (0.8 … 1) for o = 1
    assert ensemble_score_range({"x": 1}, {"x": (0.8, 1.0)})["brier"] == (0.0, pytest.approx(0.04))


def test_member_flips_name_the_tests_whose_members_changed() -> None:
    from pbr_xval.validation.robustness import member_flips

    def m(top: list[bool]) -> pd.DataFrame:
        return pd.DataFrame({"test": ["1", "1", "2", "2"], "member": [0, 1, 0, 1], "toppled": top})

    base = m([True, False, False, False])
    # tilt: test 1's members swap outcomes (P unchanged, yet fragile); haswell: the same as base
    flips = member_flips({"base": base, "tilt": m([False, True, False, False]), "haswell": base})
    assert flips == {"tilt": ["1"], "haswell": []}


def test_kernel_variants_run_validate_with_another_cpus_blas_kernels(
    tmp_path: Any, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``haswell`` / ``sandybridge``: the committed campaign in a process whose OpenBLAS uses an
    AVX2 (AVX) CPU's kernels and whose numba compiles for that CPU (the reference solver's kernel),
    in a store of its own; ``base`` in this process's environment."""
    import subprocess

    from pbr_xval.validation import robustness

    seen: dict[str, Any] = {}

    def fake_run(cmd: list[str], check: bool, env: dict[str, str] | None = None) -> None:
        out = tmp_path / cmd[cmd.index("--out") + 1]
        name = out.name
        seen[name] = ((env or {}).get("OPENBLAS_CORETYPE"), (env or {}).get("NUMBA_CPU_NAME"))
        out.mkdir(parents=True, exist_ok=True)
        oc = _oc([1, 0, 0, 1] if name == "base" else [1, 1, 0, 1]).rename(columns={"pred_e": "pred_mujoco"})
        oc.to_csv(out / "outcomes.csv", index=False)

    monkeypatch.setattr(subprocess, "run", fake_run)
    monkeypatch.delenv("OPENBLAS_CORETYPE", raising=False)
    monkeypatch.delenv("NUMBA_CPU_NAME", raising=False)
    rc = main(["camp", "--scenario", str(REPO / "examples/validation/sp1.toml"), "--engine", "mujoco",
               "--out", str(tmp_path / "o"), "--variants", "base,haswell,sandybridge"])  # fmt: skip
    assert rc == 0
    assert seen == {
        "base": (None, None),
        "haswell": ("Haswell", "haswell"),
        "sandybridge": ("Sandybridge", "sandybridge"),
    }
    assert robustness.KERNEL_VARIANTS == {
        "haswell": "Haswell",
        "sandybridge": "Sandybridge",
        "skylakex": "SkylakeX",
    }
    # skylakex: an AVX-512 CPU's kernels (what Zen 4 and Intel servers compute), numba's LLVM name for
    # it; refused before anything runs on a CPU without AVX-512 (its code would stop on an illegal
    # instruction)
    monkeypatch.setattr(robustness, "_has_avx512", lambda: True)
    env = robustness.kernel_env("skylakex")
    assert (env["OPENBLAS_CORETYPE"], env["NUMBA_CPU_NAME"]) == ("SkylakeX", "skylake-avx512")
    monkeypatch.setattr(robustness, "_has_avx512", lambda: False)
    with pytest.raises(SystemExit, match="avx512f"):
        robustness.kernel_env("skylakex")
    import json

    assert json.loads((tmp_path / "o" / "robustness.json").read_text())["fragile_tests"] == ["2"]


def test_exits_by_chance_matches_the_beta_binomial_for_a_fixed_ensemble() -> None:
    """Without the adaptive stop, a fresh ensemble of n members has k' ~ BetaBinomial(n, k + ½, n − k + ½)
    (p from the base run's posterior): the expected number of tests whose P leaves the base's Jeffreys
    interval is a finite sum (scipy.stats.betabinom), the independent reference for the Monte Carlo."""
    import numpy as np
    from scipy.stats import betabinom

    from pbr_xval.uncertainty import jeffreys_interval, p_topple
    from pbr_xval.validation.robustness import exits_by_chance

    counts = [(0, 4), (2, 4), (11, 16), (3, 8), (8, 8), (1, 12)]
    expected = 0.0
    for k, n in counts:
        lo, hi = jeffreys_interval(k, n)
        pmf = betabinom.pmf(np.arange(n + 1), n, k + 0.5, n - k + 0.5)
        expected += sum(w for j, w in enumerate(pmf) if not lo <= p_topple(j, n) <= hi)
    draws = 20000
    x = [exits_by_chance([c], members=c[1], half_width=None, draws=draws, seed=1) for c in counts]
    mean = float(sum(xi.mean() for xi in x))
    se = float(np.sqrt(sum(xi.var() for xi in x) / draws))
    assert abs(mean - expected) < 4 * se + 1e-9, (mean, expected, se)
    assert expected > 0.1  # the check can fail: these counts leave their intervals by chance


def test_exits_by_chance_adaptive_stops_like_validate() -> None:
    """A test decided by 4 agreeing members (4 of 4) has interval [0.57, 1]: a fresh run of the adaptive
    rule that again starts with 4 topples stops at P = 0.9, inside; one that does not goes on. The counts
    are whole numbers between 0 and the number of tests."""
    from pbr_xval.validation.robustness import exits_by_chance

    x = exits_by_chance([(4, 4), (0, 4), (8, 16)], draws=500, seed=0)
    assert x.dtype.kind == "i" and x.min() >= 0 and x.max() <= 3
    assert 0 < x.mean() < 1.5


def test_mass_variants_scale_the_scenarios_mass_by_round_off(tmp_path: Any) -> None:
    """``mass``: ten runs, mass × (1 + j·1e-12) for j = −5 … 5 without 0 (that is base); a scenario
    that gives a density instead has its density perturbed; one that gives neither is refused by name."""
    from pbr_xval.validation.robustness import mass_variants

    runs = mass_variants(REPO / "examples/validation/sp1.toml")  # [rock] mass = 353.8
    assert list(runs) == [
        "mass-5",
        "mass-4",
        "mass-3",
        "mass-2",
        "mass-1",
        "mass+1",
        "mass+2",
        "mass+3",
        "mass+4",
        "mass+5",
    ]
    for name, keys in runs.items():
        j = int(name[4:])
        m = keys["rock"]["mass"]
        assert m != 353.8 and abs(m / 353.8 - 1 - j * 1e-12) < 1e-15
    dens = tmp_path / "d.toml"
    dens.write_text('[rock]\nshape = "box"\ndensity = 2650.0\n')
    assert mass_variants(dens)["mass+2"] == {"rock": {"density": 2650.0 * (1 + 2e-12)}}
    bare = tmp_path / "b.toml"
    bare.write_text('[rock]\nshape = "box"\n')
    with pytest.raises(ValueError, match=r"b\.toml.*neither mass nor density"):
        mass_variants(bare)


def _guard_table() -> pd.DataFrame:
    # tests 1-6, observed 1 1 1 0 0 0; base predicts 1 1 0 0 1 0; tilt flips test 3, mass+1 test 5
    t = fragility_table(
        {
            "base": _oc6([1, 1, 0, 0, 1, 0]),
            "tilt": _oc6([1, 1, 1, 0, 1, 0]),
            "mass+1": _oc6([1, 1, 0, 0, 0, 0]),
        },
        "e",
    )
    return t


def _oc6(pred: list[int]) -> pd.DataFrame:
    return pd.DataFrame({"test": list("123456"), "observed": [1, 1, 1, 0, 0, 0], "pred_e": pred})


def test_guard_record_pins_the_robust_tests_and_bounds_f1_by_the_fragile_ones() -> None:
    from pbr_xval.validation.robustness import guard_record

    g = guard_record(
        _guard_table(), engine="e", specimen=1, scenario="s.toml", subset=False,
        variants={"tilt": "x"}, best_rule_f1=0.5, measured={"date": "d"},
    )  # fmt: skip
    assert g["fragile_tests"] == ["3", "5"] and g["fragile_by_variant"] == {"tilt": ["3"], "mass+1": ["5"]}
    assert g["robust_outcomes"] == {"1": 1, "2": 1, "4": 0, "6": 0}
    # base: TP 2 (1, 2), FP 1 (5), FN 1 (3) → F1 = 4 / 6
    assert g["confusion_base"] == {"tp": 2, "fp": 1, "fn": 1, "tn": 2}
    assert g["f1"]["base"] == pytest.approx(4 / 6)
    # robust TP 2; fragile 3 (toppled) and 5 (stood): worst 2·2/(4 + 1 + 1) = 2/3, best 2·3/6 = 1
    assert g["f1_range"] == pytest.approx([2 / 3, 1.0])
    assert g["beats_rules"] is True and g["measured"] == [{"date": "d"}]
    assert g["machine_flips"] == []  # one machine: none yet (a merge fills it in)


def test_merge_unites_fragile_tests_and_marks_robust_outcomes_that_moved_with_the_machine() -> None:
    """A test fragile in any file is fragile; one robust in both but predicted differently moved with
    the machine (``machine_flips``) and is fragile too; the F1 interval and ``beats_rules`` follow."""
    from pbr_xval.validation.robustness import guard_record, merge_guards

    new = guard_record(
        _guard_table(), engine="e", specimen=1, scenario="s.toml", subset=False,
        variants={"tilt": "x"}, best_rule_f1=0.7, measured={"date": "new"},
    )  # fmt: skip
    assert new["beats_rules"] is False  # worst case 2/3 < 0.7
    old = {
        "engine": "e", "specimen": 1, "tests": list("654321"), "fragile_tests": ["2"],
        "robust_outcomes": {"1": 1, "3": 0, "4": 0, "5": 1, "6": 1}, "variants": {"haswell": "y"},
        "measured": {"date": "old"},
    }  # fmt: skip
    m = merge_guards(new, old)
    assert m["fragile_tests"] == ["2", "3", "5", "6"] and m["machine_flips"] == ["6"]
    assert m["robust_outcomes"] == {"1": 1, "4": 0}
    # robust TP 1; fragile 2, 3 toppled, 5, 6 stood: worst 2/(2 + 2 + 2) = 1/3, best 2·3/(6 + 0) = 1
    assert m["f1_range"] == pytest.approx([1 / 3, 1.0])
    assert m["variants"] == {"tilt": "x", "haswell": "y"}
    assert m["measured"] == [{"date": "new"}, {"date": "old"}]
    assert m["f1"] == new["f1"] and m["confusion_base"] == new["confusion_base"]
    # an old file's record of a variant the new run did not run is kept (flips, F1, variants_run);
    # a variant both ran keeps the new run's
    old_full = {
        **old, "fragile_by_variant": {"haswell": ["2"], "tilt": ["2", "5"]}, "f1": {"base": 0.5, "haswell": 0.4, "tilt": 0.3},
        "variants_run": ["base", "haswell", "tilt"],
    }  # fmt: skip
    m2 = merge_guards(new, old_full)
    assert m2["fragile_by_variant"] == {**new["fragile_by_variant"], "haswell": ["2"]}
    assert m2["f1"] == {**new["f1"], "haswell": 0.4} and m2["f1"]["base"] == new["f1"]["base"]
    assert m2["variants_run"] == [*new["variants_run"], "haswell"]
    assert m["fragile_by_variant"] == new["fragile_by_variant"]  # an old file without per-variant records
    with pytest.raises(ValueError, match="specimen"):
        merge_guards(new, {**old, "specimen": 2})
    with pytest.raises(ValueError, match="same test set"):
        merge_guards(new, {**old, "tests": list("12345")})


def test_guard_and_mass_variants_through_the_command(tmp_path: Any, monkeypatch: pytest.MonkeyPatch) -> None:
    """``--variants base,mass --guard G --merge OLD``: eleven validate runs (base and mass±1…5, each on
    the scenario copied with its perturbed mass), then the guard file, merged; a bad merge file stops
    the command before any run."""
    import json
    import subprocess
    import tomllib

    masses: dict[str, float] = {}
    real_run = subprocess.run

    def fake_run(cmd: list[str], check: bool, env: dict[str, str] | None = None, **kw: Any) -> Any:
        if cmd[0] == "git":  # the provenance's commit
            return subprocess.CompletedProcess(cmd, 0, stdout="abc1234\n")
        if "validate" not in cmd:  # the provenance's machine description
            return real_run(cmd, check=check, env=env, **kw)
        out = Path(cmd[cmd.index("--out") + 1])
        scn = Path(cmd[cmd.index("--scenario") + 1])
        masses[out.name] = tomllib.loads(scn.read_text())["rock"]["mass"]
        out.mkdir(parents=True, exist_ok=True)
        pred = [1, 1, 0, 0, 1, 0] if out.name != "massplus3" else [1, 1, 0, 0, 0, 0]
        _oc6(pred).rename(columns={"pred_e": "pred_mujoco"}).to_csv(out / "outcomes.csv", index=False)
        pd.DataFrame(
            {"model": ["mujoco", "PGA rule", "PGV rule", "PGA-and-PGV rule"], "f1": [0.66, 0.5, 0.6, 0.55]}
        ).to_csv(out / "scores.csv", index=False)

    monkeypatch.setattr(subprocess, "run", fake_run)
    old = tmp_path / "old.json"
    old.write_text(json.dumps({"engine": "mujoco", "specimen": 1, "tests": list("123456"), "fragile_tests": ["1"],
                               "robust_outcomes": {"2": 1, "3": 0, "4": 0, "5": 1, "6": 0}, "measured": {"date": "old"}}))  # fmt: skip
    guard = tmp_path / "g.json"
    argv = ["camp", "--scenario", str(REPO / "examples/validation/sp1.toml"), "--engine", "mujoco",
            "--out", str(tmp_path / "o"), "--variants", "base,mass", "--guard", str(guard), "--merge", str(old)]  # fmt: skip
    assert main(argv) == 0
    assert len(masses) == 11 and masses["base"] == 353.8
    assert masses["massminus5"] == 353.8 * (1 - 5e-12) and masses["massplus3"] == 353.8 * (1 + 3e-12)
    g = json.loads(guard.read_text())
    assert g["engine"] == "mujoco" and g["fragile_tests"] == ["1", "5"]
    assert g["fragile_by_variant"]["mass+3"] == ["5"] and g["best_rule_f1"] == 0.6
    assert set(g["variants"]) == {"mass"} and [m["date"] for m in g["measured"]][1] == "old"
    assert "--variants base,mass" in g["measured"][0]["tool"] and g["measured"][0]["commit"] == "abc1234"
    # a merge file of another engine: refused before any run
    masses.clear()
    other = tmp_path / "other.json"
    other.write_text(json.dumps({"engine": "pybullet", "specimen": 1}))
    with pytest.raises(SystemExit):
        main([*argv[:-1], str(other)])
    assert masses == {}
    # --guard / --merge belong to the deterministic mode
    with pytest.raises(SystemExit):
        main(["camp", "--scenario", "s.toml", "--ensemble", "--out", "o", "--guard", str(guard)])


@pytest.mark.parametrize(
    "path", sorted((REPO / "examples/validation/robustness").glob("*_sp?.json")), ids=lambda p: p.stem
)
def test_committed_guard_files_are_what_the_tool_writes(path: Path) -> None:
    """Each committed F1 guard file is the tool's output (``--guard``, merged over machines), consistent
    in itself: every test either fragile or robust, never both; the F1 interval and ``beats_rules``
    recomputed from its own observed outcomes; the command that wrote it recorded. (The slow
    ``test_documented_f1_against_the_experiments`` then checks it against a fresh campaign.)"""
    import json

    g = json.loads(path.read_text())
    tests, fragile, robust = set(g["tests"]), set(g["fragile_tests"]), set(g["robust_outcomes"])
    assert len(g["tests"]) == len(tests) and fragile | robust == tests and not fragile & robust
    assert set(g["observed"]) == tests and set(g["observed"].values()) <= {0, 1}
    assert set(g["machine_flips"]) <= fragile
    for variant, flipped in g["fragile_by_variant"].items():
        assert set(flipped) <= fragile, variant
    lo, hi = f1_range(g["observed"], g["robust_outcomes"], g["fragile_tests"])
    assert g["f1_range"] == pytest.approx([lo, hi], abs=1e-12)
    assert g["f1_range"][0] - 1e-12 <= g["f1"]["base"] <= g["f1_range"][1] + 1e-12
    assert g["beats_rules"] == (lo > g["best_rule_f1"])
    assert "--guard" in g["measured"][0]["tool"] and g["engine"] in path.stem


def _ens_record(counts: dict[str, dict[str, tuple[int, int]]], specimen: int = 1) -> dict[str, Any]:
    """A minimal ``ensemble_robustness.json``: per variant, per test (k, n); P and the base interval
    from them as :func:`ensemble_summary` computes them."""
    from pbr_xval.uncertainty import jeffreys_interval, p_topple

    tests = list(counts["base"])
    per_test = {
        t: {
            "jeffreys95": list(jeffreys_interval(*counts["base"][t])),
            **{v: {"k": c[t][0], "n": c[t][1], "p": p_topple(*c[t])} for v, c in counts.items()},
        }
        for t in tests
    }
    return {
        "specimen": specimen, "tests": tests, "variants_run": list(counts), "per_test": per_test,
        "ensemble": {"members": 16, "half_width": 0.1, "batch": 4},
        "measured": {"date": "2026-11-26", "commit": "abc", "machine": {"cpu_model": "X", "cpu_family": 25}},
    }  # fmt: skip


def test_compare_ensemble_records_counts_interval_exits_and_the_variants_reproduced() -> None:
    """A test whose P here leaves the record's base Jeffreys interval is named; a variant of the
    record whose k of n this run reproduced on a test lists it; different test sets are refused."""
    from pbr_xval.uncertainty import jeffreys_interval, p_topple
    from pbr_xval.validation.robustness import compare_ensemble_records

    rec = _ens_record(
        {
            "base": {"1": (0, 4), "2": (8, 16), "3": (4, 4)},
            "haswell": {"1": (0, 4), "2": (9, 16), "3": (4, 4)},
        }
    )
    # here: test 1 as both variants, test 2 as the record's haswell run, test 3 toppled 0 of 4
    new = _ens_record({"base": {"1": (0, 4), "2": (9, 16), "3": (0, 4)}})
    c = compare_ensemble_records(new, rec)
    lo, hi = jeffreys_interval(4, 4)
    assert not lo <= p_topple(0, 4) <= hi  # 0.1 against [0.55, 1]: the exit is real
    assert c["outside_base_interval"] == ["3"]
    assert c["same_counts_as"] == {"base": ["1"], "haswell": ["1", "2"]}
    assert c["max_abs_dp"] == pytest.approx(p_topple(4, 4) - p_topple(0, 4))
    assert c["measured"]["machine"]["cpu_family"] == 25
    with pytest.raises(ValueError, match="same tests"):
        compare_ensemble_records(_ens_record({"base": {"1": (0, 4)}}), rec)


def test_compare_through_the_command_runs_the_records_tests_and_refuses_other_settings(
    tmp_path: Any, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``--ensemble --compare R.json``: without ``--tests`` the record's tests run; the comparison is
    written under ``compared``; a record of other ensemble settings or another specimen stops the
    command before any member runs."""
    import json

    import pbr_xval.validation.robustness as rob
    from pbr_xval.uncertainty import p_topple

    ran: list[list[str] | None] = []

    def fake_run(
        campaign: Path, specimen: int, scn: Path, folder: Path, *, tests: Any = None, **kw: Any
    ) -> Any:
        ran.append(tests)
        k = {"15": 0, "42": 3}
        rows = pd.DataFrame(
            [{"test": t, "observed": 1, "pga_m_s2": 1.0, "pgv_m_s": 0.1, "k": k[t], "n": 4,
              "p": p_topple(k[t], 4), "failed": 0} for t in tests]
        )  # fmt: skip
        members = pd.DataFrame(
            [{"test": t, "member": j, "toppled": int(j < k[t])} for t in tests for j in range(4)]
        )
        return rows, members

    monkeypatch.setattr(rob, "run_ensemble_variant", fake_run)
    monkeypatch.setattr(rob, "logistic_out_of_fold", lambda *a, **k: {"logistic(lnPGV)": [0.5, 0.5]})
    rec = tmp_path / "rec.json"
    rec.write_text(json.dumps(_ens_record({"base": {"15": (0, 4), "42": (4, 4)}})))
    out = tmp_path / "o"
    argv = ["camp", "--scenario", str(REPO / "examples/validation/sp1.toml"), "--ensemble", "--members", "16",
            "--half-width", "0.1", "--variants", "base", "--out", str(out), "--compare", str(rec)]  # fmt: skip
    assert main(argv) == 0
    assert ran == [["15", "42"]]
    c = json.loads((out / "ensemble_robustness.json").read_text())["compared"]
    assert c[0]["record"] == str(rec) and c[0]["same_counts_as"] == {"base": ["15"]}
    assert c[0]["outside_base_interval"] == []  # 3 of 4 (P 0.7) lies in 4 of 4's interval [0.55, 1]
    ran.clear()
    for bad in ({"members": 8}, {"specimen": 2}):
        r = _ens_record({"base": {"15": (0, 4), "42": (4, 4)}})
        r["ensemble"].update(bad) if "members" in bad else r.update(bad)
        rec.write_text(json.dumps(r))
        with pytest.raises(SystemExit):
            main(argv)
    assert ran == []
    with pytest.raises(SystemExit):  # --compare belongs to the ensemble mode
        main(["camp", "--scenario", "s.toml", "--engine", "mujoco", "--out", "o", "--compare", str(rec)])


@pytest.mark.parametrize(
    "path",
    sorted(
        p
        for p in (REPO / "examples/validation/robustness").glob("ensemble_sp?_*.json")
        if "compared" in p.read_text()
    ),
    ids=lambda p: p.stem,
)
def test_committed_machine_comparisons_recompute_from_the_two_records(path: Path) -> None:
    """Each committed ensemble record measured on another machine (``--compare``) holds the comparison
    that :func:`compare_ensemble_records` computes from its own per-test counts and the record it names
    (docs/validation.md, "On a second real CPU"): no test outside that record's base interval."""
    import json

    from pbr_xval.validation.robustness import compare_ensemble_records

    rec = json.loads(path.read_text())
    for c in rec["compared"]:
        other = json.loads((REPO / c["record"]).read_text())
        again = compare_ensemble_records(rec, other)
        assert c["measured"] == again["measured"] and c["same_counts_as"] == again["same_counts_as"]
        assert c["outside_base_interval"] == again["outside_base_interval"]
        assert c["max_abs_dp"] == pytest.approx(again["max_abs_dp"], abs=1e-12)
        assert c["outside_base_interval"] == []
    assert "--compare" in rec["measured"]["tool"] and rec["measured"]["machine"]["cpu_family"]
