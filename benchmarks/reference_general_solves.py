"""Issue 23, ninth pass: the resting solves the compiled active-set solve fails, per campaign test.

Runs the reference on the selected shake-table tests (the scene of
``benchmarks/reference_campaign.py``) and records every resting solve whose first try
(``kernel.active_set_solve`` from the engine's guess) fails, with what the engine then does:
the retry (``kernel.active_set_retry``) or the general solver (the cone solver, and its 16-facet
pyramid fallback when the cone iteration does not converge). Each failed solve is classed as

* ``unreachable``: b's component outside A's range (what no contact force can produce) exceeds
  the first try's tolerance 1e-9 |b| + cons_tol — the velocity stabilisation's doing when
  b − stab's component is within it (printed);
* ``stale slip``: otherwise, when the guess has impending-slip contacts (status 3);
* ``other``.

Prints per test the NumPy (general) steps, the failed first tries by class, how many the retry
answers and the cone fallbacks; ``--save FILE`` writes the recorded problems (pickle of dicts:
A, b, status, slide, tdir, stab, cons_tol, mu_s, f, fallback), which is how
``tests/reference/data/general_resting_problems.npz`` was made (at 496ed66, before the retry:
run with the old ``reference/`` to record what the general solver answered).

Run:  python benchmarks/reference_general_solves.py --specimen 1 --tests 160 593 595 632
"""

from __future__ import annotations

import argparse
import os
import pickle
import tempfile
from pathlib import Path
from typing import Any

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import numpy as np  # noqa: E402

from pbr_xval.reference import dynamics, kernel  # noqa: E402
from pbr_xval.runner import run_scene  # noqa: E402
from pbr_xval.scenario import load_scenario  # noqa: E402
from pbr_xval.validation.campaign import Baseline, load_campaign  # noqa: E402
from pbr_xval.validation.execution import prepare_motions  # noqa: E402

HERE = Path(__file__).resolve().parent
SHARED = HERE.parent.parent / "shared" / "data" / "shake_table"
TAIL_S = 3.0


def _scene(scn: Any, motion: Any) -> Any:
    """The scene of ``reference_campaign._scene`` (stop on topple and at rest): the same runs."""
    from reference_campaign import _scene as campaign_scene  # benchmarks/ is on sys.path[0]

    return campaign_scene(scn, motion)


def _outside(A: np.ndarray, x: np.ndarray) -> float:
    """Largest component of x outside A's range (SVD rank at 1e-10 of the largest value)."""
    u, s, _ = np.linalg.svd(A)
    un = u[:, int((s > 1e-10 * s[0]).sum()) :]
    return float(np.abs(un @ (un.T @ x)).max()) if un.size else 0.0


def _classify(r: dict[str, Any]) -> str:
    tol = 1e-9 * float(np.abs(r["b"]).max()) + r["cons_tol"]
    if _outside(r["A"], r["b"]) > tol:
        return "unreachable"
    return "stale slip" if (r["status"] == 3).any() else "other"


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--specimen", type=int, default=1)
    ap.add_argument("--tests", nargs="+", default=["160", "593", "595", "632"])
    ap.add_argument("--save", type=Path, default=None, help="pickle the recorded problems here")
    args = ap.parse_args()

    rec: list[dict[str, Any]] = []
    solve = dynamics.RigidBodySolver._solve_resting
    has_retry = hasattr(kernel, "active_set_retry")

    def recording(self: Any, A: np.ndarray, b: np.ndarray, c: Any, diag: bool, cons_tol: float) -> np.ndarray:
        # the guess as _solve_resting makes it
        k = c.idx.size
        status, tdir, mu = self._resting_guess(c)
        ok = kernel.active_set_solve(A, b, status, mu, cons_tol, k + 2, tdir, c.slide)[0]
        fallbacks = self.stats.cone_fallbacks
        full = self.stats.full_solves
        f = solve(self, A, b, c, diag, cons_tol)
        if not ok:
            rec.append(
                {
                    "A": A.copy(), "b": b.copy(), "status": status.copy(), "slide": c.slide.copy(),
                    "tdir": tdir, "stab": c.stab.copy(), "cons_tol": cons_tol, "mu_s": self.mu_s,
                    "f": f.copy(), "fallback": self.stats.cone_fallbacks > fallbacks,
                    "general": self.stats.full_solves > full,
                }
            )  # fmt: skip
        return f

    dynamics.RigidBodySolver._solve_resting = recording  # type: ignore[method-assign]
    scn = load_scenario(HERE.parent / "examples" / "validation" / f"sp{args.specimen}.toml")
    camp = load_campaign(SHARED, specimen=args.specimen).select(tests=args.tests)
    saved: dict[str, list[dict[str, Any]]] = {}
    print(f"(retry {'present' if has_retry else 'absent'}: kernel from {Path(kernel.__file__).parent})")
    with tempfile.TemporaryDirectory() as tmp:
        motions = prepare_motions(camp, Baseline(), Path(tmp))
        for t in args.tests:
            rec.clear()
            tr = run_scene(_scene(scn, motions[t]), "reference")
            classes = [_classify(r) for r in rec]
            counts = {c: classes.count(c) for c in ("unreachable", "stale slip", "other")}
            stab_only = sum(
                _outside(r["A"], r["b"] - r["stab"]) <= 1e-9 * float(np.abs(r["b"]).max()) + r["cons_tol"]
                for r, c in zip(rec, classes, strict=True)
                if c == "unreachable"
            )
            retried = sum(not r["general"] for r in rec)
            print(
                f"SP{args.specimen} test {t}: NumPy steps {tr.diagnostics['general_steps']}, failed first "
                f"tries {len(rec)} {counts} (unreachable within tolerance without stab: {stab_only}), "
                f"answered by the retry {retried}, cone fallbacks {sum(r['fallback'] for r in rec)}"
            )
            saved[t] = list(rec)
    if args.save:
        with open(args.save, "wb") as fh:
            pickle.dump(saved, fh)


if __name__ == "__main__":
    main()
