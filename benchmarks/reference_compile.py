"""Cold JIT compile of the ``reference`` engine, per compiled function (prints figures, asserts nothing).

Runs ``pbr_xval.conformance.check_rest("reference")`` in a subprocess with an empty
``NUMBA_CACHE_DIR`` (every kernel function compiled from scratch, as on a fresh install or in
CI's clean clone) and prints its wall and CPU seconds, the seconds spent holding numba's LLVM
lock, the number of compilations (dispatcher × signature, numba's own overloads included) and
the slowest compilations from numba's ``numba:compile`` events. The per-compilation seconds
are nested: a function's figure includes the callees first compiled inside it. Functions
compiled for more than one signature are listed with their signatures' differences (a second
layout of an array argument or a literal constant argument compiles the callee's whole call
tree again; ``reference/PERFORMANCE.md``, "Cold JIT compile").

With ``--modules`` it also prints, per compiled module (numba's code library of one
function and signature), the CPU seconds of LLVM's whole-module optimisation and of its code
generation and the module's instruction count: numba links the modules of a function's compiled
callees into the function's own and optimises and generates code for the whole again, so a
call tree's code is counted in every module above it (numba internals of 0.68; the counting
slows the run).

Run:  python benchmarks/reference_compile.py [--top N] [--modules]   (~75 s on the project's 2-core machine)
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile

_CHILD = r"""
import sys, time
from collections import defaultdict
from numba.core import event
from numba.core.registry import CPUDispatcher

top = int(sys.argv[1])
modules = sys.argv[2] == "1"
llvm_rows = []
if modules:
    # numba internals (numba 0.68): time the whole-module optimisation and the code generation
    # of each compiled library, and count its instructions first (outside the timed calls, but
    # inside the check_rest figure, which this counting inflates)
    from numba.core import codegen

    lib_cls = codegen.CPUCodeLibrary

    def _count(mod):
        return sum(len(list(b.instructions)) for f in mod.functions if not f.is_declaration for b in f.blocks)

    def _timed(kind, orig):
        def run(self, *a):
            n = _count(self._final_module) if kind == "opt" else 0
            t = time.process_time()
            orig(self, *a)
            llvm_rows.append((kind, self.name, time.process_time() - t, n))

        return run

    lib_cls._optimize_final_module = _timed("opt", lib_cls._optimize_final_module)
    lib_cls._finalize_final_module = _timed("codegen", lib_cls._finalize_final_module)
with event.install_recorder("numba:compile") as rec, event.install_recorder("numba:llvm_lock") as llv:
    w0, c0 = time.perf_counter(), time.process_time()
    from pbr_xval.conformance import check_rest

    check_rest("reference")
    wall, cpu = time.perf_counter() - w0, time.process_time() - c0
t_llvm, start = 0.0, None
for ts, ev in llv.buffer:
    if ev.is_start:
        start = ts
    elif start is not None:
        t_llvm += ts - start
        start = None
starts, rows = {}, []
for ts, ev in rec.buffer:
    key = (str(ev.data.get("dispatcher")), str(ev.data.get("args")))
    if ev.is_start:
        starts[key] = ts
    else:
        rows.append((ts - starts.pop(key, ts), key[0], key[1]))
rows.sort(reverse=True)
print(f"cold check_rest('reference'): {wall:.1f} s wall, {cpu:.1f} CPU s; LLVM lock held {t_llvm:.1f} s; "
      f"{len(rows)} compilations")
names = defaultdict(list)
for t, disp, _ in rows:
    names[disp.split("function ")[-1].split(" at ")[0]].append(t)
print(f"slowest {top} (s, nested; one figure per signature):")
for name in sorted(names, key=lambda n: -max(names[n]))[:top]:
    print(f"  {name:<32s} " + " + ".join(f"{t:.1f}" for t in sorted(names[name], reverse=True)))
if modules:
    per = defaultdict(lambda: [0.0, 0.0, 0])
    for kind, lib, t, n in llvm_rows:
        per[lib][0 if kind == "opt" else 1] += t
        per[lib][2] = max(per[lib][2], n)
    t_opt = sum(v[0] for v in per.values())
    t_gen = sum(v[1] for v in per.values())
    n_mod = sum(1 for row in llvm_rows if row[0] == "opt")
    print(f"{n_mod} compiled modules; whole-module optimisation {t_opt:.1f} CPU s, code generation "
          f"{t_gen:.1f} CPU s; the slowest {top} names (a name's signatures summed; instructions: its "
          f"largest module, which holds its compiled callees' code):")
    print(f"  {'function':<40s} {'opt s':>6s} {'codegen s':>9s} {'instructions':>12s}")
    for lib, (o, g, n) in sorted(per.items(), key=lambda kv: -(kv[1][0] + kv[1][1]))[:top]:
        print(f"  {lib[:40]:<40s} {o:6.2f} {g:9.2f} {n:12d}")
from pbr_xval.reference import cone, kernel, pivoting

print("reference functions compiled for more than one signature (argument: differences from the first):")
for mod in (kernel, cone, pivoting):
    for name, f in vars(mod).items():
        if isinstance(f, CPUDispatcher) and len(f.signatures) > 1:
            sigs = f.signatures
            diffs = sorted({(j, str(s[j])) for s in sigs[1:] for j in range(len(s)) if s[j] != sigs[0][j]})
            print(f"  {name}: {len(sigs)} signatures; {diffs}")
"""


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--top", type=int, default=12, help="how many of the slowest compilations to list")
    ap.add_argument(
        "--modules",
        action="store_true",
        help="also time the LLVM optimisation and code generation of each compiled module "
        "(numba internals; counting their instructions slows the run)",
    )
    args = ap.parse_args()
    from pbr_xval.machine import describe_machine

    print(f"(machine: {describe_machine()}; load average at start {os.getloadavg()})")
    with tempfile.TemporaryDirectory() as tmp:
        env = dict(os.environ, NUMBA_CACHE_DIR=tmp)
        subprocess.run(
            [sys.executable, "-c", _CHILD, str(args.top), "1" if args.modules else "0"], env=env, check=True
        )
    print(f"(load average at end {os.getloadavg()})")


if __name__ == "__main__":
    main()
