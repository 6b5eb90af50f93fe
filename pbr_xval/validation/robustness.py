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
* ``dt+1%`` / ``dt-1%``: the engine's time step × 1.01 / × 0.99 (``--set timestep=…``).

Usage (a developer tool; minutes per engine and specimen)::

    python -m pbr_xval.validation.robustness ../shared/data/shake_table --specimen 1 \\
        --scenario examples/validation/sp1.toml --engine pybullet --out runs/robust_sp1_pybullet

writes ``robustness.csv`` (per test: observed, each variant's prediction, ``fragile``) and
``robustness.json`` (fragile share, F1 per variant, the outcome of every test that is robust).
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path
from typing import Any

import pandas as pd
import tomli_w

from pbr_xval.atomic import write_text_atomic

__all__ = ["VARIANTS", "f1_range", "fragility_table", "main", "summarise"]

#: variant name -> (scenario keys to set, engine settings to set as factors of the faithful dt)
VARIANTS: dict[str, tuple[dict[str, Any], dict[str, float]]] = {
    "base": ({}, {}),
    "tilt": ({"initial": {"theta": 1e-9}}, {}),
    "dt+1%": ({}, {"timestep": 1.01}),
    "dt-1%": ({}, {"timestep": 0.99}),
}


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


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(
        prog="python -m pbr_xval.validation.robustness", description=__doc__.split("\n")[0]
    )
    p.add_argument("campaign")
    p.add_argument("--specimen", type=int, default=1)
    p.add_argument("--scenario", type=Path, required=True)
    p.add_argument("--engine", required=True)
    p.add_argument("--out", type=Path, required=True)
    p.add_argument("--tests", default=None)
    p.add_argument("--variants", default=",".join(VARIANTS))
    p.add_argument("--workers", type=int, default=2)
    a = p.parse_args(argv)
    from pbr_xval.engine import get_engine

    names = [v.strip() for v in a.variants.split(",") if v.strip()]
    unknown = sorted(set(names) - set(VARIANTS))
    if unknown or "base" not in names:
        p.error(f"--variants: {unknown or 'base missing'}: expected 'base' and any of {', '.join(VARIANTS)}")
    faithful = get_engine(a.engine).profiles()["faithful"]
    if "timestep" not in faithful and any(VARIANTS[n][1] for n in names):
        p.error(f"--variants: engine {a.engine!r} has no time step to perturb")
    dt0 = float(faithful.get("timestep", 0.0))
    outcomes: dict[str, pd.DataFrame] = {}
    for name in names:
        keys, factors = VARIANTS[name]
        folder = a.out / name.replace("%", "pct").replace("+", "plus").replace("-", "minus")
        scn = _variant_scenario(a.scenario, keys, folder) if keys else a.scenario
        cmd = [_cli(), "validate", a.campaign, "--specimen", str(a.specimen),
               "--scenario", str(scn), "--engine", a.engine, "--out", str(folder), "--workers", str(a.workers)]  # fmt: skip
        for k, f in factors.items():
            cmd += ["--set", f"{k}={dt0 * f!r}"]
        if a.tests:
            cmd += ["--tests", a.tests]
        print(f"robustness: {a.engine} {name}: {' '.join(cmd[1:])}", flush=True)
        subprocess.run(cmd, check=True)
        outcomes[name] = pd.read_csv(folder / "outcomes.csv", dtype={"test": str})
    table = fragility_table(outcomes, a.engine)
    summary = {
        "engine": a.engine,
        "specimen": a.specimen,
        "scenario": str(a.scenario),
        **summarise(table, names),
    }
    write_text_atomic(a.out / "robustness.csv", table.to_csv())
    write_text_atomic(a.out / "robustness.json", json.dumps(summary, indent=1))
    f1 = ", ".join(f"{k} {v:.4f}" for k, v in summary["f1"].items())
    print(
        f"robustness {a.engine} SP{a.specimen}: {summary['fragile']}/{summary['tests']} tests fragile "
        f"({100 * summary['fragile_share']:.1f} %); F1 {f1}"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
