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

Run:  python benchmarks/reference_compile.py [--top N]     (~75 s on the project's 2-core machine)
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
    args = ap.parse_args()
    print(f"(machine: {os.cpu_count()} CPUs; load average at start {os.getloadavg()})")
    with tempfile.TemporaryDirectory() as tmp:
        env = dict(os.environ, NUMBA_CACHE_DIR=tmp)
        subprocess.run([sys.executable, "-c", _CHILD, str(args.top)], env=env, check=True)
    print(f"(load average at end {os.getloadavg()})")


if __name__ == "__main__":
    main()
