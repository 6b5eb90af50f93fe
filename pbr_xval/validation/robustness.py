"""How close each shake-table outcome is to flipping: the campaign under tiny perturbations.

A rocking, impacting rock near its toppling level is chaotic: an input difference in the last bit
can flip its outcome. Such a difference arises between machines (different BLAS kernels, compilers
or libraries), so a test whose outcome flips under a perturbation *far below* any physical
uncertainty is *fragile*: its outcome on another machine is a coin flip, and a CI guard must not
depend on it. This module runs a campaign (``pbr-xval validate``, the same store and motions) once
as committed and once per perturbation, and reports per test whether any perturbation flipped the
outcome, per engine the fragile share, and the F1 over the variants.

Perturbations (each far below what is physically known about a rock on a table):

* ``tilt``: an initial rocking angle of 1e-9 rad (``initial.theta``);
* ``dt+1%`` / ``dt-1%``: the engine's time step × 1.01 / × 0.99 (``--set timestep=…``);
* ``mass``: the 11-run mass round-off ensemble — the campaign again with the rock's mass (or, for a
  scenario that gives a density, its density) × (1 + j·1e-12), j = −5 … 5 (j = 0 is ``base``; runs
  ``mass-5`` … ``mass+5``): for a rigid rock a change the equations almost scale out, yet it finds
  coin flips that the tilt and the BLAS builds do not (docs/validation.md, "Machine dependence");
* ``haswell`` / ``sandybridge`` / ``skylakex``: the committed campaign in a process whose OpenBLAS
  (and numba, for the reference solver) computes what another CPU family computes.

Usage (a developer tool; minutes per engine and specimen)::

    python -m pbr_xval.validation.robustness ../shared/data/shake_table --specimen 1 \\
        --scenario examples/validation/sp1.toml --engine pybullet --out runs/robust_sp1_pybullet

writes ``robustness.csv`` (per test: observed, each variant's prediction, ``fragile``) and
``robustness.json`` (fragile share, F1 per variant, the outcome of every test that is robust).

**CI guard files** (``examples/validation/robustness/<engine>_sp<N>.json``, read by
``tests/validation/test_validate.py::test_documented_f1_against_the_experiments``): ``--guard FILE``
writes one from this run — the fragile and robust tests, the F1 interval the fragile tests allow
(:func:`f1_range`), the base run's confusion counts, the best fitted rule's F1 and whether the
worst case still beats it, and where, when, on which CPU and by which command it was measured.
``--merge OLD.json`` (repeatable) unites it with guard files measured elsewhere (another machine,
earlier variants, :func:`merge_guards`): a test is fragile if it was fragile in any, and a test
robust in every file but with different outcomes is fragile too (it moved with the machine)::

    python -m pbr_xval.validation.robustness ../shared/data/shake_table --specimen 2 \
        --scenario examples/validation/sp2.toml --engine reference \
        --variants base,tilt,haswell,sandybridge,skylakex,mass --out runs/robust_sp2_reference \
        --merge examples/validation/robustness/reference_sp2.json \
        --guard examples/validation/robustness/reference_sp2.json

**Ensembles** (``--ensemble``, issue 22): the scenario's ``[uncertainty]`` ensemble of every test
(as ``pbr-xval validate --ensemble``, without the deterministic runs) once as committed and once per
perturbation of *every member*: ``tilt`` shifts the ``initial.theta`` distribution by 1e-9 rad
(each member's sampled seating tilt moves by 1e-9 rad), ``dt±1%`` scales the ``timestep``
distribution (each member's time step × 1.01 / × 0.99). Per test: P(topple) of each variant, the
base run's Jeffreys 95 % interval, whether a variant's P lies outside it; per variant: the largest
|ΔP|, Brier and F1 at P ≥ 0.5; and the intervals of Brier and F1 when each test's P may take any
value it took under a variant (:func:`ensemble_score_range`)::

    python -m pbr_xval.validation.robustness ../shared/data/shake_table --specimen 1 \\
        --scenario examples/validation/sp1.toml --ensemble --half-width 0.1 --tests 15,19,… \\
        --variants base,tilt,dt+1% --out runs/robust_sp1_ensemble

writes ``ensemble_robustness.csv`` (per test × variant: k, n, P) and ``ensemble_robustness.json``.
``--compare RECORD.json`` (repeatable; its tests unless ``--tests`` is given, the same ensemble
settings) checks this run's P per test against a record measured on another machine
(:func:`compare_ensemble_records`): the tests outside the record's base Jeffreys 95 % interval, and
which of the record's variants this machine reproduced count for count.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tomllib
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import tomli_w

from pbr_xval.atomic import write_text_atomic

__all__ = [
    "ENSEMBLE_VARIANTS",
    "KERNEL_VARIANTS",
    "VARIANTS",
    "check_comparable",
    "check_mergeable",
    "compare_ensemble_records",
    "ensemble_score_range",
    "ensemble_summary",
    "ensemble_variant_uncertainty",
    "f1_range",
    "fragility_table",
    "guard_record",
    "main",
    "mass_variants",
    "merge_guards",
    "run_ensemble_variant",
    "summarise",
]

#: variant name -> (scenario keys to set, engine settings to set as factors of the faithful dt)
VARIANTS: dict[str, tuple[dict[str, Any], dict[str, float]]] = {
    "base": ({}, {}),
    "tilt": ({"initial": {"theta": 1e-9}}, {}),
    "dt+1%": ({}, {"timestep": 1.01}),
    "dt-1%": ({}, {"timestep": 0.99}),
    "haswell": ({}, {}),
    "sandybridge": ({}, {}),
    "skylakex": ({}, {}),
}

#: what each variant (family) perturbs, as a guard file records it
VARIANT_DESCRIPTIONS: dict[str, str] = {
    "tilt": "initial.theta = 1e-9 rad",
    "dt+1%": "the engine's time step x 1.01",
    "dt-1%": "the engine's time step x 0.99",
    "haswell": "OPENBLAS_CORETYPE=Haswell and NUMBA_CPU_NAME=haswell: the BLAS kernels of an AVX2 CPU "
    "without AVX-512 (Intel Haswell-Skylake client, AMD Zen 1-3; any machine whose environment sets it) and "
    "numba's code for it (the reference solver's kernel)",
    "sandybridge": "OPENBLAS_CORETYPE=Sandybridge and NUMBA_CPU_NAME=sandybridge: an AVX-only CPU's kernels",
    "skylakex": "OPENBLAS_CORETYPE=SkylakeX and NUMBA_CPU_NAME=skylake-avx512: the BLAS kernels of an "
    "AVX-512 CPU (Intel Skylake-SP and later servers, AMD Zen 4 and Zen 5) and numba's code for it",
    "mass": "rock.mass (or rock.density) x (1 + j 1e-12), j = -5..5 (runs mass-5 .. mass+5; j = 0 is base): "
    "a test that toppled in some but not all 11 runs is fragile",
}

#: variants that run the committed campaign in a process whose OpenBLAS uses another CPU's kernels
#: (``OPENBLAS_CORETYPE``, read once when the library loads): the engines' scene set-up (the
#: principal axes from ``eigh``, rotations by matrix products) rounds differently on an AVX2 CPU
#: (Haswell kernels: Intel Haswell–Skylake client, AMD Zen 1–3 — and any machine whose environment
#: sets OPENBLAS_CORETYPE=Haswell, as the project's Zen 5 VM does), an AVX-only one (Sandybridge) or
#: an AVX-512 one (SkylakeX kernels: Intel Skylake-SP and later servers, AMD Zen 4 and Zen 5), so what CI sees on
#: another machine is run here. ``skylakex`` needs an AVX-512 CPU to run on.
KERNEL_VARIANTS: dict[str, str] = {"haswell": "Haswell", "sandybridge": "Sandybridge", "skylakex": "SkylakeX"}

#: numba's (LLVM's) name of each kernel variant's CPU, where it is not the variant's name
_NUMBA_CPU: dict[str, str] = {"skylakex": "skylake-avx512"}


def kernel_env(name: str) -> dict[str, str]:
    """The environment of a kernel variant's process: OpenBLAS's kernels of that CPU
    (``OPENBLAS_CORETYPE``) and numba's code generation for it (``NUMBA_CPU_NAME``: the reference
    solver's compiled kernel, which numba otherwise compiles for this machine's CPU; its on-disk
    cache keeps one build per CPU name). The other engines do not use numba."""
    if name == "skylakex" and not _has_avx512():
        raise SystemExit("robustness: the skylakex variant runs AVX-512 code; this CPU has no avx512f flag")
    return {
        **os.environ,
        "OPENBLAS_CORETYPE": KERNEL_VARIANTS[name],
        "NUMBA_CPU_NAME": _NUMBA_CPU.get(name, name),
    }


def _has_avx512() -> bool:
    """Whether this CPU reports the avx512f flag (Linux: /proc/cpuinfo; elsewhere assumed not)."""
    try:
        return " avx512f " in Path("/proc/cpuinfo").read_text().replace("\n", " ")
    except OSError:
        return False


def _variant_scenario(scenario: Path, keys: dict[str, Any], folder: Path) -> Path:
    """The scenario with ``keys`` merged in, written to ``folder`` (file paths made absolute)."""
    d = tomllib.loads(scenario.read_text())
    for table in ("rock", "pedestal"):
        t = d.get(table, {})
        if isinstance(t, dict) and "path" in t:
            t["path"] = str((scenario.parent / t["path"]).resolve())
    for k, v in keys.items():
        d.setdefault(k, {}).update(v)
    out = folder / scenario.name
    folder.mkdir(parents=True, exist_ok=True)
    write_text_atomic(out, tomli_w.dumps(d))
    return out


#: the mass round-off ensemble (variant ``mass``): relative step and the range of j (j = 0 is base)
MASS_STEP = 1e-12
MASS_J = range(-5, 6)


def mass_variants(scenario: Path) -> dict[str, dict[str, Any]]:
    """The runs of the ``mass`` variant: name (``mass-5`` … ``mass+5``, no j = 0) → the ``[rock]``
    keys to set, the scenario's ``rock.mass`` (kg) or else ``rock.density`` (kg/m³) × (1 + j·1e-12).

    Raises ``ValueError`` naming the scenario when it gives neither (a primitive rock's mass from
    its dimensions has nothing to perturb here)."""
    rock = tomllib.loads(scenario.read_text()).get("rock", {})
    key = "mass" if "mass" in rock else "density" if "density" in rock else None
    if key is None:
        raise ValueError(
            f"{scenario}: [rock] has neither mass nor density: found keys {sorted(rock)}; the mass variant "
            "perturbs one of them"
        )
    v0 = float(rock[key])
    return {f"mass{j:+d}": {"rock": {key: v0 * (1.0 + j * MASS_STEP)}} for j in MASS_J if j != 0}


def fragility_table(outcomes: dict[str, pd.DataFrame], engine: str) -> pd.DataFrame:
    """Per test: observed, each variant's prediction (0/1) and ``fragile`` (any variant differs)."""
    base = outcomes["base"].set_index("test")
    t = pd.DataFrame({"observed": base["observed"].astype(int)})
    for name, oc in outcomes.items():
        t[name] = oc.set_index("test")[f"pred_{engine}"].astype(int).reindex(t.index)
    preds = t[list(outcomes)]
    t["fragile"] = preds.nunique(axis=1) > 1
    return t


def _f1(obs: pd.Series, pred: pd.Series) -> float:
    """F1 as validate scores it (:func:`pbr_xval.validation.metrics.score`)."""
    from pbr_xval.validation.metrics import score

    return float(score(obs.to_numpy() == 1, pred.to_numpy() == 1).f1)


def summarise(table: pd.DataFrame, variants: list[str]) -> dict[str, Any]:
    """Fragile share, F1 per variant, and the robust tests' outcomes (what a CI guard may pin)."""
    robust = table[~table["fragile"]]
    return {
        "tests": len(table),
        "fragile": int(table["fragile"].sum()),
        "fragile_share": float(table["fragile"].mean()),
        "fragile_tests": [str(i) for i in table.index[table["fragile"]]],
        "f1": {v: _f1(table["observed"], table[v]) for v in variants},
        "robust_outcomes": {str(i): int(v) for i, v in robust["base"].items()},
    }


def _cli() -> str:
    """The ``pbr-xval`` script of this interpreter's environment."""
    exe = Path(sys.executable).parent / "pbr-xval"
    return str(exe) if exe.is_file() else (shutil.which("pbr-xval") or "pbr-xval")


def f1_range(observed: dict[str, int], robust: dict[str, int], fragile: list[str]) -> tuple[float, float]:
    """(lowest, highest) F1 over every outcome the fragile tests may take, robust ones fixed.

    The tolerance of a CI guard derived from the fragile share: with the robust outcomes pinned,
    F1 can only move as far as the fragile tests allow. Lowest: every fragile test predicted
    wrong; highest: every one right (F1 = 2TP / (2TP + FP + FN) is monotone in each).
    """
    tp = sum(1 for t, o in robust.items() if o == 1 and observed[t] == 1)
    fp = sum(1 for t, o in robust.items() if o == 1 and observed[t] == 0)
    fn = sum(1 for t, o in robust.items() if o == 0 and observed[t] == 1)
    pos = sum(1 for t in fragile if observed[t] == 1)
    neg = len(fragile) - pos

    def f1(a: int, b: int, c: int) -> float:
        return 2 * a / (2 * a + b + c) if a else 0.0

    return f1(tp, fp + neg, fn + pos), f1(tp + pos, fp, fn)


#: the empirical threshold rules of ``validate``'s scores (out of fold by record): a guard records the
#: best one's F1 and whether the engine's worst case beats it
RULES = ("PGA rule", "PGV rule", "PGA-and-PGV rule")


def guard_record(
    table: pd.DataFrame,
    *,
    engine: str,
    specimen: int,
    scenario: str,
    subset: bool,
    variants: dict[str, str],
    best_rule_f1: float,
    measured: dict[str, Any],
) -> dict[str, Any]:
    """A CI guard file's content from one :func:`fragility_table` (its ``base`` column the run as
    committed): the tests, the fragile ones (any variant flipped them), the robust tests' outcomes,
    F1 per variant, the interval the fragile tests allow (:func:`f1_range`), the base run's
    confusion counts, the best fitted rule's F1 (``best_rule_f1``) and ``beats_rules`` (the
    interval's low end above it). ``variants``: family name → what it perturbs; ``measured``: the
    provenance (:func:`_provenance`)."""
    cols = [c for c in table.columns if c not in ("observed", "fragile")]
    tests = [str(t) for t in table.index]
    observed = {str(t): int(o) for t, o in table["observed"].items()}
    fragile = [str(t) for t in table.index[table["fragile"]]]
    robust = {str(t): int(v) for t, v in table.loc[~table["fragile"], "base"].items()}
    from pbr_xval.validation.metrics import score

    lo, hi = f1_range(observed, robust, fragile)
    base = score(table["observed"].to_numpy() == 1, table["base"].to_numpy() == 1)
    return {
        "engine": engine,
        "specimen": int(specimen),
        "scenario": scenario,
        "subset": bool(subset),
        "tests": tests,
        "observed": observed,
        "variants": dict(variants),
        "variants_run": cols,
        "fragile_tests": fragile,
        "fragile_share": len(fragile) / len(tests),
        "fragile_by_variant": {
            c: [str(t) for t in table.index[table[c] != table["base"]]] for c in cols if c != "base"
        },
        "f1": {c: _f1(table["observed"], table[c]) for c in cols},
        "f1_range": [lo, hi],
        "confusion_base": {"tp": base.tp, "fp": base.fp, "fn": base.fn, "tn": base.tn},
        "best_rule_f1": float(best_rule_f1),
        "beats_rules": bool(lo > best_rule_f1),
        "robust_outcomes": robust,
        # outcomes that differed between machines: none until another machine's file is merged in
        "machine_flips": [],
        "measured": [measured],
    }


def _same_tests(a: Sequence[Any], b: Sequence[Any]) -> bool:
    """Whether two test lists hold the same test names (order and int/str spelling aside)."""
    return sorted(str(t) for t in a) == sorted(str(t) for t in b)


def check_mergeable(
    old: dict[str, Any], engine: str, specimen: int, tests: Sequence[str] | None = None
) -> None:
    """Raise ``ValueError`` (one line) unless the guard file ``old`` is of ``engine``, ``specimen``
    and (when given) the same test set: what :func:`merge_guards` unites, checked by the command
    before any simulation runs."""
    if old.get("engine") != engine or int(old.get("specimen", -1)) != int(specimen):
        raise ValueError(
            f"engine {old.get('engine')!r}, specimen {old.get('specimen')!r} in the old guard; expected "
            f"{engine!r}, {specimen}"
        )
    if tests is not None and not _same_tests(old.get("tests", []), tests):
        raise ValueError(
            f"the old guard has {len(old.get('tests', []))} tests, this run {len(tests)}: expected the same test set"
        )


def merge_guards(new: dict[str, Any], *old: dict[str, Any]) -> dict[str, Any]:
    """``new`` (:func:`guard_record`) united with guard files measured elsewhere (``old``: another
    machine, other variants, earlier code of the same results).

    A test is fragile if it is fragile in any file; a test robust in every file but with different
    outcomes is fragile too (its outcome moved with the machine: ``machine_flips``). The robust
    outcomes, F1 interval and ``beats_rules`` are recomputed; the confusion counts, rule F1 and
    base F1 stay ``new``'s (this machine's run); ``variants`` and ``measured`` collect every file's,
    and a variant that ``new`` did not run keeps its flips (``fragile_by_variant``), F1 and place in
    ``variants_run`` from the first file that ran it (each against that file's own base run), so a
    run of one more variant (``--variants base,sandybridge --merge OLD``) adds to the record
    instead of replacing it. Raises ``ValueError`` when the files are of different engines,
    specimens or test sets."""
    out = dict(new)
    fragile = set(new["fragile_tests"])
    robust = dict(new["robust_outcomes"])
    machine_flips: set[str] = set(new.get("machine_flips", []))
    variants = dict(new["variants"])
    measured = list(new["measured"])
    by_variant = dict(new.get("fragile_by_variant", {}))
    f1s = dict(new.get("f1", {}))
    run = list(new.get("variants_run", []))
    for o in old:
        check_mergeable(o, new["engine"], int(new["specimen"]), new["tests"])
        fragile |= set(o["fragile_tests"])
        machine_flips |= set(o.get("machine_flips", []))
        for t, v in o["robust_outcomes"].items():
            if t in robust and robust[t] != int(v):
                machine_flips.add(t)
        for k, v in o.get("variants", {}).items():
            variants.setdefault(k, v)
        for k, flips in o.get("fragile_by_variant", {}).items():
            if k not in by_variant:
                by_variant[k] = list(flips)
                if k in o.get("f1", {}):
                    f1s[k] = o["f1"][k]
                if k not in run:
                    run.append(k)
        m = o.get("measured", [])
        measured.extend(m if isinstance(m, list) else [m])
    fragile |= machine_flips
    order = [str(t) for t in new["tests"]]
    observed = {str(t): int(v) for t, v in new["observed"].items()}
    robust = {t: robust[t] for t in order if t not in fragile}
    lo, hi = f1_range(observed, robust, [t for t in order if t in fragile])
    out.update(
        fragile_tests=[t for t in order if t in fragile],
        fragile_share=len(fragile) / len(order),
        machine_flips=[t for t in order if t in machine_flips],
        robust_outcomes=robust,
        f1_range=[lo, hi],
        beats_rules=bool(lo > float(new["best_rule_f1"])),
        variants=variants,
        variants_run=run,
        fragile_by_variant=by_variant,
        f1=f1s,
        measured=measured,
    )
    return out


# --------------------------------------------------------------------------- ensembles (issue 22)
#: ensemble variant -> what it does to every member (the ``[uncertainty]`` key it moves)
ENSEMBLE_VARIANTS: dict[str, str] = {
    "base": "as committed",
    "tilt": "initial.theta distribution shifted by 1e-9 rad (every member's seating tilt + 1e-9 rad)",
    "dt+1%": "timestep distribution × 1.01 (every member's time step × 1.01)",
    "dt-1%": "timestep distribution × 0.99 (every member's time step × 0.99)",
    "haswell": "as committed, OpenBLAS forced to its Haswell kernels (OPENBLAS_CORETYPE=Haswell: an AVX2 CPU's; numba compiling for haswell)",
}
_TILT = 1e-9
_DT_FACTOR = {"dt+1%": 1.01, "dt-1%": 0.99}


def ensemble_variant_uncertainty(table: dict[str, Any], variant: str) -> dict[str, Any]:
    """The ``[uncertainty]`` table of ``variant``: a copy with one distribution moved.

    ``tilt``: the ``initial.theta`` distribution shifted by 1e-9 rad (a normal's mean and bounds, a
    uniform's ends, a choice's values), so that member *i*'s tilt is its base value + 1e-9 rad;
    ``dt±1%``: the ``timestep`` distribution scaled by 1.01 / 0.99 (every member's time step).
    Raises ``ValueError`` when the table does not make that key uncertain.
    """
    import copy

    out = copy.deepcopy(table)
    if variant in ("base", "haswell"):
        return out
    key = "initial.theta" if variant == "tilt" else "timestep"
    if variant not in ENSEMBLE_VARIANTS:
        raise ValueError(f"variant {variant!r}: expected one of {', '.join(ENSEMBLE_VARIANTS)}")
    d = out.get(key)
    if not isinstance(d, dict):
        raise ValueError(f"[uncertainty] has no {key!r} distribution for the {variant!r} variant to move")

    def move(x: float) -> float:
        return x + _TILT if variant == "tilt" else x * _DT_FACTOR[variant]

    fields = {"uniform": ("low", "high"), "normal": ("mean", "low", "high"), "lognormal": ("median",)}
    if d.get("dist") == "choice":
        d["values"] = [move(float(v)) for v in d["values"]]
    elif d.get("dist") in fields:
        for f in fields[d["dist"]]:
            if f in d:
                d[f] = move(float(d[f]))
        if d["dist"] == "normal" and variant != "tilt":
            d["sd"] = float(d["sd"]) * _DT_FACTOR[variant]
    else:
        raise ValueError(f"[uncertainty].{key}: distribution {d.get('dist')!r} not supported")
    return out


def _ensemble_variant_scenario(scenario: Path, variant: str, folder: Path) -> Path:
    """The scenario with its ``[uncertainty]`` table moved by ``variant``, written to ``folder``."""
    d = tomllib.loads(scenario.read_text())
    table = ensemble_variant_uncertainty(d.get("uncertainty", {}), variant)
    moved = _variant_scenario(scenario, {}, folder)
    d2 = tomllib.loads(moved.read_text())
    d2["uncertainty"] = table
    write_text_atomic(moved, tomli_w.dumps(d2))
    return moved


def run_ensemble_variant(
    campaign: Path,
    specimen: int,
    scenario: Path,
    out: Path,
    *,
    tests: list[str] | None = None,
    members: int | None = None,
    half_width: float | None = 0.1,
    batch: int = 4,
    workers: int = 2,
    progress: bool = False,
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """The scenario's ensemble of every test, as ``pbr-xval validate --ensemble`` runs it (the same
    baseline correction, engines, settings and store layout under ``out``; no deterministic runs).

    Returns (one row per test, campaign order: ``test``, ``observed``, ``pga_m_s2``, ``pgv_m_s``
    (the lab sheet's), ``k`` toppled of ``n`` members that ran, ``p`` = (k + ½) / (n + 1) (the
    Jeffreys posterior mean, as ``validate --ensemble``; NaN when none ran),
    ``failed`` member runs; one row per test × member, as ``ensemble_members.csv``).
    """
    import math

    from pbr_xval.scenario import load_scenario
    from pbr_xval.uncertainty import ensemble_spec, p_topple
    from pbr_xval.validation.campaign import Baseline, load_campaign
    from pbr_xval.validation.ensemble import ensemble_counts, run_campaign_ensemble
    from pbr_xval.validation.execution import prepare_motions

    camp = load_campaign(campaign, specimen).select(tests)
    base = Baseline(
        detrend="linear", highpass_hz=0.3, lowpass_hz=25.0, resample_hz=200.0
    )  # validate's defaults
    motions = prepare_motions(camp, base, out / "motions")
    scn = load_scenario(scenario)
    spec = ensemble_spec(scn)
    if spec is None:
        raise ValueError(f"{scenario}: no [uncertainty] table")
    engines, _ = spec.mixture(None)
    df, _summary = run_campaign_ensemble(
        camp, motions, scn, spec, out, members=members, engines=engines, settings={e: {} for e in engines},
        workers=workers, progress=progress, half_width=half_width, batch=batch,
    )  # fmt: skip
    names = [t.test for t in camp.tests]
    k, n_ok, n_bad = ensemble_counts(df, names)
    g = 9.80665
    rows = []
    for j, t in enumerate(camp.tests):
        pga = float(t.sheet.get("pga_g", math.nan)) * g
        rows.append(
            {
                "test": t.test, "observed": int(t.toppled), "pga_m_s2": pga,
                "pgv_m_s": pga * float(t.sheet.get("pgv_over_pga_s", math.nan)),
                "k": int(k[j]), "n": int(n_ok[j]), "p": p_topple(int(k[j]), int(n_ok[j])),
                "failed": int(n_bad[j]),
            }
        )  # fmt: skip
    return pd.DataFrame(rows), df


def ensemble_score_range(
    observed: dict[str, int], p_ranges: dict[str, tuple[float, float]]
) -> dict[str, tuple[float, float]]:
    """(lowest, highest) Brier and F1 at P ≥ 0.5 when each test's P may lie anywhere in ``p_ranges[test]``.

    The ensemble's analogue of :func:`f1_range`. Brier is a mean of per-test terms (P − o)², so its
    bounds are the means of each term's smallest and largest value over the test's range; F1
    depends on each test's side of 0.5 only, so a test whose range straddles 0.5 is *fragile* and
    :func:`f1_range` applies to the others' fixed sides.
    """
    tests = sorted(p_ranges)
    lo_terms, hi_terms, robust, fragile = [], [], {}, []
    for t in tests:
        a, b = p_ranges[t]
        o = observed[t]
        lo_terms.append(0.0 if a <= o <= b else min((a - o) ** 2, (b - o) ** 2))
        hi_terms.append(max((a - o) ** 2, (b - o) ** 2))
        if (a >= 0.5) == (b >= 0.5):
            robust[t] = int(a >= 0.5)
        else:
            fragile.append(t)
    n = len(tests)
    return {
        "brier": (sum(lo_terms) / n, sum(hi_terms) / n),
        "f1": f1_range({t: observed[t] for t in tests}, robust, fragile),
    }


def member_flips(members: dict[str, pd.DataFrame]) -> dict[str, list[str]]:
    """Per variant (not base): the tests with a member whose outcome differs from the base run's."""
    base = members["base"].set_index(["test", "member"])["toppled"]
    out = {}
    for v, m in members.items():
        if v == "base":
            continue
        other = m.set_index(["test", "member"])["toppled"]
        common = base.index.intersection(other.index)
        diff = base.loc[common] != other.loc[common]
        out[v] = sorted({str(t) for t, _m in diff[diff].index})
    return out


def ensemble_summary(
    results: dict[str, pd.DataFrame],
    *,
    baselines: dict[str, np.ndarray] | None = None,
    members: dict[str, pd.DataFrame] | None = None,
) -> dict[str, Any]:
    """Per test and variant (k, n, P), the base run's Jeffreys 95 % interval, the tests whose P left it,
    the largest |ΔP|, each variant's Brier and F1, and :func:`ensemble_score_range` twice:
    ``*_range_measured`` with each test's P anywhere between the values the variants gave it, and
    ``*_range`` (what a guard allows) with every *fragile* test (a member's outcome flipped under a
    variant, ``members`` given, or its P moved) and every *undecided* one (0 < k < n in the base run:
    its members sit near their threshold) anywhere in the base run's Jeffreys 95 % interval.

    ``results``: variant → :func:`run_ensemble_variant` rows ("base" first); ``baselines``: model →
    P per test (the base rows' order), e.g. the out-of-fold logistic baselines, scored alongside;
    ``members``: variant → its member rows (``ensemble_members.csv``).
    """
    from pbr_xval.uncertainty import jeffreys_interval
    from pbr_xval.validation.scores import probabilistic_scores

    base = results["base"].set_index("test")
    tests = [str(t) for t in base.index]
    observed = {t: int(base.loc[t, "observed"]) for t in tests}
    per_test: dict[str, Any] = {}
    outside: dict[str, list[str]] = {v: [] for v in results if v != "base"}
    max_dp: dict[str, float] = {v: 0.0 for v in results if v != "base"}
    for t in tests:
        k, n = int(base.loc[t, "k"]), int(base.loc[t, "n"])
        lo, hi = jeffreys_interval(k, n)
        row: dict[str, Any] = {"observed": observed[t], "jeffreys95": [lo, hi]}
        for v, r in results.items():
            rv = r.set_index("test").loc[t]
            row[v] = {"k": int(rv["k"]), "n": int(rv["n"]), "p": float(rv["p"])}
            if v != "base":
                if not lo <= float(rv["p"]) <= hi:
                    outside[v].append(t)
                max_dp[v] = max(max_dp[v], abs(float(rv["p"]) - float(base.loc[t, "p"])))
        per_test[t] = row
    obs = np.array([observed[t] for t in tests])
    scores = {}
    for v, r in results.items():
        pv = r.set_index("test").loc[tests, "p"].to_numpy(float)
        s = probabilistic_scores(obs, pv)
        scores[v] = {k: float(s[k]) for k in ("brier", "log_loss", "auc", "f1")}
    measured = {
        t: (min(per_test[t][v]["p"] for v in results), max(per_test[t][v]["p"] for v in results))
        for t in tests
    }
    flips = member_flips(members) if members else {}
    fragile = sorted(
        {t for ts in flips.values() for t in ts} | {t for t in tests if measured[t][0] != measured[t][1]}
    )
    undecided = [t for t in tests if 0 < per_test[t]["base"]["k"] < per_test[t]["base"]["n"]]
    # the guard's interval: fragile or undecided tests anywhere in the base run's Jeffreys 95 % interval
    # (the stated one), every other test at the values measured
    free = set(fragile) | set(undecided)
    guarded = {t: (tuple(per_test[t]["jeffreys95"]) if t in free else measured[t]) for t in tests}
    rng_m = ensemble_score_range(observed, measured)
    rng = ensemble_score_range(observed, guarded)
    out: dict[str, Any] = {
        "tests": tests,
        "variants_run": list(results),
        "variants": {v: ENSEMBLE_VARIANTS[v] for v in results},
        "outside_base_interval": outside,
        "max_abs_dp": max_dp,
        "scores": scores,
        "member_flips": flips,
        "fragile_tests": fragile,
        "undecided_tests": undecided,
        "brier_range_measured": list(rng_m["brier"]),
        "f1_range_measured": list(rng_m["f1"]),
        "brier_range": list(rng["brier"]),
        "f1_range": list(rng["f1"]),
        "member_runs": {v: int(r["n"].sum() + r["failed"].sum()) for v, r in results.items()},
        "per_test": per_test,
    }
    if baselines:
        bs = {
            m: float(probabilistic_scores(obs, np.asarray(p, float))["brier"]) for m, p in baselines.items()
        }
        best = min(bs, key=lambda m: bs[m])
        out["baselines_brier"] = bs
        out["best_baseline"] = best
        out["margin_vs_best_baseline"] = {v: 1.0 - scores[v]["brier"] / bs[best] for v in results}
        out["margin_worst_case_measured"] = 1.0 - rng_m["brier"][1] / bs[best]
        out["margin_worst_case"] = 1.0 - rng["brier"][1] / bs[best]
    return out


def check_comparable(
    record: dict[str, Any], specimen: int, ensemble: dict[str, Any], tests: Sequence[str] | None
) -> None:
    """Raise ``ValueError`` (one line) unless the ensemble robustness record ``record`` (an
    ``ensemble_robustness.json``) is of ``specimen``, with the same ensemble settings (``members``,
    ``half_width``, ``batch``) and, when ``tests`` is given, the same tests — what
    :func:`compare_ensemble_records` compares, checked before any simulation runs."""
    if int(record.get("specimen", -1)) != int(specimen):
        raise ValueError(f"specimen {record.get('specimen')!r} in the record; expected {specimen}")
    rec_ens = record.get("ensemble", {})
    for k in ("members", "half_width", "batch"):
        if rec_ens.get(k) != ensemble.get(k):
            raise ValueError(
                f"ensemble {k} {rec_ens.get(k)!r} in the record, {ensemble.get(k)!r} in this run"
            )
    if tests is not None and not _same_tests(record.get("tests", []), tests):
        raise ValueError(
            f"the record has {len(record.get('tests', []))} tests, this run {len(tests)}: expected the same tests"
        )


def compare_ensemble_records(new: dict[str, Any], record: dict[str, Any]) -> dict[str, Any]:
    """This run's base ensemble (``new``: :func:`ensemble_summary`) against a record measured elsewhere
    (``record``: an ``ensemble_robustness.json`` of another machine, or of earlier code).

    Issue 22's "an ensemble's P(topple) is the same on any machine within its stated interval",
    checked on a real second machine: the tests whose P here lies outside the record's base Jeffreys
    95 % interval, the largest |ΔP| against the record's base, and per variant of the record the tests
    whose k of n here equals that variant's (a record's ``haswell`` variant imitates another CPU's
    BLAS; equal counts on every test say that the imitation was this machine). Returns a dict with
    ``measured`` (the record's provenance), ``outside_base_interval``, ``max_abs_dp`` and
    ``same_counts_as`` (variant → tests). Raises ``ValueError`` when the test sets differ.
    """
    tests = [str(t) for t in new["tests"]]
    if not _same_tests(tests, record["tests"]):
        raise ValueError(
            f"the record has {len(record['tests'])} tests, this run {len(tests)}: expected the same tests"
        )
    outside, max_dp = [], 0.0
    same: dict[str, list[str]] = {v: [] for v in record["variants_run"]}
    for t in tests:
        here = new["per_test"][t]["base"]
        there = record["per_test"][t]
        lo, hi = there["jeffreys95"]
        if not lo <= here["p"] <= hi:
            outside.append(t)
        max_dp = max(max_dp, abs(here["p"] - there["base"]["p"]))
        for v in same:
            if (here["k"], here["n"]) == (there[v]["k"], there[v]["n"]):
                same[v].append(t)
    return {
        "measured": record.get("measured", {}),
        "outside_base_interval": outside,
        "max_abs_dp": max_dp,
        "same_counts_as": same,
    }


def exits_by_chance(
    counts: Sequence[tuple[int, int]],
    *,
    members: int = 16,
    batch: int = 4,
    half_width: float | None = 0.1,
    draws: int = 2000,
    seed: int = 0,
) -> np.ndarray:
    """How many tests' P would leave the base run's Jeffreys 95 % interval by Monte-Carlo noise alone.

    The null hypothesis of "is P(topple) the same on any machine within its stated interval": no machine
    effect at all, and a second run that draws *fresh* members (independent Bernoulli outcomes with the
    test's true probability p, p drawn from the base run's posterior Beta(k + ½, n − k + ½)) under the same
    adaptive rule as ``validate --ensemble`` (batches of ``batch`` up to ``members``, stopping on
    :func:`pbr_xval.catalog.predict.stop_rule` with ``half_width``; ``None``: always ``members``). A real
    perturbation (a tilt of 1e-9 rad, other BLAS kernels) keeps the design's members and flips only the
    chaotic ones, so it should leave the interval no more often than this.

    counts : per test the base run's (k, n). Returns (draws,) int: per Monte-Carlo repetition, the number
    of tests whose second P = (k' + ½) / (n' + 1) lies outside the base's interval.
    """
    from pbr_xval.catalog.predict import Estimate, stop_rule
    from pbr_xval.uncertainty import jeffreys_interval, p_topple

    table: dict[tuple[int, int], tuple[float, float, float, bool]] = {}
    for n in range(members + 1):
        for k in range(n + 1):
            lo, hi = jeffreys_interval(k, n) if n else (0.0, 1.0)
            est = Estimate(k=k, n=n, p=p_topple(k, n), lo=lo, hi=hi)
            table[k, n] = (est.p, lo, hi, n >= members or stop_rule(est, half_width) is not None)
    rng = np.random.default_rng(seed)
    out = np.zeros(draws, dtype=int)
    for k0, n0 in counts:
        _, lo, hi, _ = table[k0, n0]
        ps = rng.beta(k0 + 0.5, n0 - k0 + 0.5, size=draws)
        for i, p in enumerate(ps):
            k = n = 0
            while True:
                step = min(batch, members - n) if half_width is not None else members
                k += int(rng.binomial(step, p))
                n += step
                pk, _, _, stop = table[k, n]
                if stop:
                    break
            out[i] += not lo <= pk <= hi
    return out


def logistic_out_of_fold(
    campaign: Path, specimen: int, tests: list[str], folds: int = 4
) -> dict[str, np.ndarray]:
    """The out-of-fold logistic baselines fitted on *every* test of the campaign (folds by record,
    as validate), their P on ``tests`` (in that order) — no simulation needed."""
    from pbr_xval.validation.campaign import load_campaign
    from pbr_xval.validation.metrics import group_folds
    from pbr_xval.validation.scores import logistic_baselines

    camp = load_campaign(campaign, specimen)
    g = 9.80665
    pga = np.array([float(t.sheet["pga_g"]) * g for t in camp.tests])
    pgv = pga * np.array([float(t.sheet["pgv_over_pga_s"]) for t in camp.tests])
    obs = np.array([int(t.toppled) for t in camp.tests])
    fold = group_folds([t.motion for t in camp.tests], folds)
    lb = logistic_baselines(pga, pgv, obs, fold)
    idx = {t.test: i for i, t in enumerate(camp.tests)}
    sel = [idx[t] for t in tests]
    return {m: p[sel] for m, p in lb.items()}


def _provenance() -> dict[str, Any]:
    """Date, machine, load and commit of a measurement (the runs may have been resumed from a store)."""
    import datetime

    from pbr_xval.machine import machine_info

    try:
        commit = subprocess.run(
            ["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True, check=True,
            cwd=Path(__file__).resolve().parent,
        ).stdout.strip()  # fmt: skip
    except (OSError, subprocess.CalledProcessError):
        commit = "unknown"
    return {
        "date": datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC"),
        "machine": machine_info(),
        "load_1_5_15": [round(x, 2) for x in os.getloadavg()],
        "commit": commit,
        "tool": "python -m pbr_xval.validation.robustness --ensemble",
    }


def _haswell_base(a: argparse.Namespace, folder: Path) -> None:
    """The base ensemble in a process whose OpenBLAS uses its Haswell kernels (written to ``folder``)."""
    cmd = [sys.executable, "-m", "pbr_xval.validation.robustness", str(a.campaign), "--specimen", str(a.specimen),
           "--scenario", str(a.scenario), "--ensemble", "--variants", "base", "--batch", str(a.batch),
           "--workers", str(a.workers), "--out", str(folder)]  # fmt: skip
    if a.members is not None:
        cmd += ["--members", str(a.members)]
    if a.half_width is not None:
        cmd += ["--half-width", str(a.half_width)]
    if a.tests:
        cmd += ["--tests", a.tests]
    subprocess.run(cmd, check=True, env=kernel_env("haswell"))


def _ensemble_main(
    a: argparse.Namespace,
    names: list[str],
    records: Sequence[tuple[Path, dict[str, Any]]] = (),
    tool: str | None = None,
) -> int:
    """``--ensemble``: every variant's ensemble, then ``ensemble_robustness.{csv,json}``; with
    ``records`` (``--compare``: path, record), each compared with this run's base
    (:func:`compare_ensemble_records`, under ``compared``)."""
    import time

    tests = [t.strip() for t in a.tests.split(",") if t.strip()] if a.tests else None
    results: dict[str, pd.DataFrame] = {}
    walls: dict[str, float] = {}
    member_rows: dict[str, pd.DataFrame] = {}
    for name in names:
        folder = a.out / name.replace("%", "pct").replace("+", "plus").replace("-", "minus")
        print(f"robustness: ensemble {name} ({ENSEMBLE_VARIANTS[name]})", flush=True)
        t0 = time.perf_counter()
        if name == "haswell":  # OpenBLAS reads its core type once, at load: a process of its own
            _haswell_base(a, folder)
            t = pd.read_csv(folder / "ensemble_robustness.csv", dtype={"test": str})
            results[name] = t[t["variant"] == "base"].drop(columns="variant").reset_index(drop=True)
            members = pd.read_csv(folder / "base" / "ensemble_members.csv", dtype={"test": str})
        else:
            scn = a.scenario if name == "base" else _ensemble_variant_scenario(a.scenario, name, folder)
            results[name], members = run_ensemble_variant(
                Path(a.campaign), a.specimen, scn, folder, tests=tests, members=a.members,
                half_width=a.half_width, batch=a.batch, workers=a.workers, progress=False,
            )  # fmt: skip
            write_text_atomic(folder / "ensemble_members.csv", members.to_csv(index=False))
        walls[name] = round(time.perf_counter() - t0, 1)
        member_rows[name] = members.astype({"test": str})
    order = [str(t) for t in results["base"]["test"]]
    summary = {
        "specimen": a.specimen,
        "scenario": str(a.scenario),
        "ensemble": {"members": a.members, "half_width": a.half_width, "batch": a.batch},
        **ensemble_summary(
            results, baselines=logistic_out_of_fold(Path(a.campaign), a.specimen, order), members=member_rows
        ),
        # wall times of this invocation (a run resumed from its store costs nothing): not a cost figure
        "wall_s_this_invocation": walls,
        "measured": {**_provenance(), **({"tool": tool} if tool else {})},
    }
    if records:
        summary["compared"] = [
            {"record": str(f), **compare_ensemble_records(summary, rec)} for f, rec in records
        ]
    table = pd.concat([r.assign(variant=v) for v, r in results.items()], ignore_index=True)
    write_text_atomic(a.out / "ensemble_robustness.csv", table.to_csv(index=False))
    write_text_atomic(a.out / "ensemble_robustness.json", json.dumps(summary, indent=1))
    for v in names[1:]:
        print(
            f"robustness ensemble SP{a.specimen} {v}: {len(summary['outside_base_interval'][v])}/{len(order)} tests "
            f"outside the base run's Jeffreys 95 % interval; max |ΔP| {summary['max_abs_dp'][v]:.3f}"
        )
    for v, s in summary["scores"].items():
        print(f"robustness ensemble SP{a.specimen} {v}: Brier {s['brier']:.4f}  F1 {s['f1']:.4f}")
    from pbr_xval.machine import describe_machine

    for c in summary.get("compared", []):
        where = ", ".join(
            str(x) for x in (describe_machine(c["measured"].get("machine", {})), c["measured"].get("date"),
                             c["measured"].get("commit")) if x
        )  # fmt: skip
        same = "; ".join(f"{v} {len(ts)}/{len(order)}" for v, ts in c["same_counts_as"].items())
        print(
            f"robustness ensemble SP{a.specimen} base vs {c['record']} ({where}): "
            f"{len(c['outside_base_interval'])}/{len(order)} tests outside its base Jeffreys 95 % interval, "
            f"max |ΔP| {c['max_abs_dp']:.3f}; k of n equal to its {same}"
        )
    print(
        f"Brier range {summary['brier_range'][0]:.4f}–{summary['brier_range'][1]:.4f}, F1 range "
        f"{summary['f1_range'][0]:.4f}–{summary['f1_range'][1]:.4f}; best baseline {summary['best_baseline']} "
        f"Brier {summary['baselines_brier'][summary['best_baseline']]:.4f}"
    )
    return 0


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(
        prog="python -m pbr_xval.validation.robustness", description=__doc__.split("\n")[0]
    )
    p.add_argument("campaign")
    p.add_argument("--specimen", type=int, default=1)
    p.add_argument("--scenario", type=Path, required=True)
    p.add_argument("--engine", default=None, help="the engine (deterministic mode)")
    p.add_argument("--ensemble", action="store_true", help="the scenario's [uncertainty] ensemble instead")
    p.add_argument("--members", type=int, default=None, help="--ensemble: members per test (at most)")
    p.add_argument("--half-width", type=float, default=None, help="--ensemble: adaptive, as validate")
    p.add_argument("--batch", type=int, default=4, help="--ensemble: members per adaptive batch")
    p.add_argument("--out", type=Path, required=True)
    p.add_argument("--tests", default=None)
    p.add_argument("--variants", default=",".join(v for v in VARIANTS if v not in KERNEL_VARIANTS))
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--guard", type=Path, default=None, help="write a CI guard file (deterministic mode)")
    p.add_argument(
        "--merge",
        action="append",
        default=None,
        help="a guard file measured elsewhere to unite with --guard's",
    )
    p.add_argument(
        "--compare",
        action="append",
        type=Path,
        default=None,
        help="--ensemble: an ensemble_robustness.json measured elsewhere; this run's P per test against its intervals",
    )
    a = p.parse_args(argv)
    from pbr_xval.engine import get_engine

    names = [v.strip() for v in a.variants.split(",") if v.strip()]
    if a.ensemble:
        if a.guard is not None or a.merge:
            p.error(
                "--guard and --merge write deterministic guard files; --ensemble writes ensemble_robustness.json"
            )
        unknown = sorted(set(names) - set(ENSEMBLE_VARIANTS))
        if unknown or not names or names[0] != "base":
            p.error(f"--variants: {unknown or 'base not first'}: expected 'base' first, then any of "
                    f"{', '.join(ENSEMBLE_VARIANTS)}")  # fmt: skip
        # every record to compare with, checked before any simulation; without --tests, its tests
        records: list[tuple[Path, dict[str, Any]]] = []
        for f in a.compare or []:
            try:
                rec = json.loads(f.read_text())
                # re-read per record: without --tests the first record's tests become this run's
                tests = [t.strip() for t in a.tests.split(",") if t.strip()] if a.tests else None
                check_comparable(
                    rec,
                    a.specimen,
                    {"members": a.members, "half_width": a.half_width, "batch": a.batch},
                    tests,
                )
            except (OSError, ValueError, KeyError, TypeError) as exc:
                p.error(f"--compare {f}: {exc}")
            if not a.tests:
                a.tests = ",".join(str(t) for t in rec["tests"])
            records.append((f, rec))
        tool = "python -m pbr_xval.validation.robustness " + " ".join(
            str(x) for x in (argv if argv is not None else sys.argv[1:])
        )
        return _ensemble_main(a, names, records, tool)
    if a.compare:
        p.error("--compare compares ensemble records (--ensemble); deterministic runs use --merge")
    if a.engine is None:
        p.error("--engine is required (or --ensemble)")
    unknown = sorted(set(names) - set(VARIANTS) - {"mass"})
    if unknown or "base" not in names:
        p.error(
            f"--variants: {unknown or 'base missing'}: expected 'base' and any of {', '.join([*VARIANTS, 'mass'])}"
        )
    faithful = get_engine(a.engine).profiles()["faithful"]
    if "timestep" not in faithful and any(VARIANTS[n][1] for n in names if n in VARIANTS):
        p.error(f"--variants: engine {a.engine!r} has no time step to perturb")
    dt0 = float(faithful.get("timestep", 0.0))
    # every check before any simulation: the mass to perturb, the guard files to merge, the kernel
    # variants' environments (its own store each: the chunk keys do not name the BLAS kernels)
    runs: dict[str, tuple[dict[str, Any], dict[str, float]]] = {}
    for name in names:
        if name == "mass":
            try:
                runs.update({k: (keys, {}) for k, keys in mass_variants(a.scenario).items()})
            except (OSError, ValueError) as exc:
                p.error(f"--variants mass: {exc}")
        else:
            runs[name] = VARIANTS[name]
    old: list[dict[str, Any]] = []
    for f in a.merge or []:
        try:
            g = json.loads(Path(f).read_text())
        except (OSError, ValueError) as exc:
            p.error(f"--merge {f}: {exc}")
        try:
            check_mergeable(g, a.engine, a.specimen)
        except ValueError as exc:
            p.error(f"--merge {f}: {exc}")
        old.append(g)
    envs = {name: kernel_env(name) for name in names if name in KERNEL_VARIANTS}
    outcomes: dict[str, pd.DataFrame] = {}
    for name, (keys, factors) in runs.items():
        folder = a.out / name.replace("%", "pct").replace("+", "plus").replace("-", "minus")
        scn = _variant_scenario(a.scenario, keys, folder) if keys else a.scenario
        cmd = [_cli(), "validate", a.campaign, "--specimen", str(a.specimen),
               "--scenario", str(scn), "--engine", a.engine, "--out", str(folder), "--workers", str(a.workers)]  # fmt: skip
        for k, f in factors.items():
            cmd += ["--set", f"{k}={dt0 * f!r}"]
        if a.tests:
            cmd += ["--tests", a.tests]
        env = envs.get(name)
        print(f"robustness: {a.engine} {name}: {' '.join(cmd[1:])}", flush=True)
        subprocess.run(cmd, check=True, env=env)
        outcomes[name] = pd.read_csv(folder / "outcomes.csv", dtype={"test": str})
    table = fragility_table(outcomes, a.engine)
    summary = {
        "engine": a.engine,
        "specimen": a.specimen,
        "scenario": str(a.scenario),
        **summarise(table, list(runs)),
    }
    write_text_atomic(a.out / "robustness.csv", table.to_csv())
    write_text_atomic(a.out / "robustness.json", json.dumps(summary, indent=1))
    f1 = ", ".join(f"{k} {v:.4f}" for k, v in summary["f1"].items())
    print(
        f"robustness {a.engine} SP{a.specimen}: {summary['fragile']}/{summary['tests']} tests fragile "
        f"({100 * summary['fragile_share']:.1f} %); F1 {f1}"
    )
    if a.guard is not None:
        base_scores = pd.read_csv(a.out / "base" / "scores.csv").set_index("model")
        rules = [r for r in RULES if r in base_scores.index]
        prov = _provenance()
        prov["tool"] = "python -m pbr_xval.validation.robustness " + " ".join(
            str(x) for x in (argv if argv is not None else sys.argv[1:])
        )
        guard = guard_record(
            table, engine=a.engine, specimen=a.specimen, scenario=str(a.scenario), subset=bool(a.tests),
            variants={n: VARIANT_DESCRIPTIONS[n] for n in names if n != "base"},
            best_rule_f1=float(base_scores.loc[rules, "f1"].max()) if rules else float("nan"), measured=prov,
        )  # fmt: skip
        if old:
            guard = merge_guards(guard, *old)
        write_text_atomic(a.guard, json.dumps(guard, indent=1) + "\n")
        print(
            f"guard {a.guard}: {len(guard['fragile_tests'])}/{len(guard['tests'])} fragile, F1 interval "
            f"{guard['f1_range'][0]:.3f}-{guard['f1_range'][1]:.3f}, best rule {guard['best_rule_f1']:.3f}, "
            f"beats the rules: {guard['beats_rules']}"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
