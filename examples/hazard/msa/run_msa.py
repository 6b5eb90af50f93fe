"""A multiple-stripe analysis from end to end: synthetic records × scale factors → sweep → fragility.

    python examples/hazard/msa/run_msa.py OUT          # 60 Housner runs, ~260 core-seconds

1. Six synthetic accelerograms (band-passed white noise, Butterworth order 2 around f₀ = 0.6–3 Hz,
   a build-up/decay envelope, 10 s at dt = 0.01 s, normalised to PGA = 1 m/s², seed 1) are written
   as plain tables into OUT/records.
2. OUT/msa.toml: one slender block (0.3 × 0.3 × 1.2 m, μ = 2) × the records scaled by
   0.5, 1, 1.5, 2, 2.5, 3, 3.5, 4, 5, 6 (the stripes: PGA = scale in m/s²), engine ``housner``.
3. ``pbr-xval sweep`` into OUT/results, then ``pbr-xval fragility`` with SA(0.3 s), SA(1 s),
   SA(2 s) into OUT/fragility (fits.csv, im_comparison.csv, fragility.csv, NRML).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from scipy.signal import butter, sosfilt

CATALOG = """name = "msa"
seed = 3
duration = "auto"
tail = 2.0
engines = ["housner"]
chunk_size = 16

[settings.housner]
rtol = 1e-7
atol = 1e-9

[[rock]]
id = "slender"
shape = "box"
half_extents = [0.15, 0.15, 0.6]
density = 2500.0
friction = 2.0

[motions.records]
folder = "records"
pattern = "*.txt"
format = "table"
units = "m/s2"
dt = 0.01
scale = [0.5, 1, 1.5, 2, 2.5, 3, 3.5, 4, 5, 6]
"""


def write_records(folder: Path) -> None:
    rng = np.random.default_rng(1)
    folder.mkdir(parents=True, exist_ok=True)
    dt, n = 0.01, 1000
    t = np.arange(n) * dt
    env = np.minimum((t / 2) ** 2 * np.exp(-(t - 2) / 1.5), 1) * np.exp(-np.maximum(t - 4, 0) / 2)
    for i, f0 in enumerate([0.8, 1.2, 2.0, 3.0, 1.5, 0.6]):
        sos = butter(2, [0.3 * f0, 2 * f0], btype="band", fs=1 / dt, output="sos")
        a = sosfilt(sos, rng.standard_normal(n)) * env
        np.savetxt(folder / f"syn{i}.txt", a / np.abs(a).max())


def main(out: Path) -> int:
    from pbr_xval.cli.catalog_impl import sweep_command
    from pbr_xval.cli.hazard_impl import fragility_command

    write_records(out / "records")
    (out / "msa.toml").write_text(CATALOG)
    code = sweep_command(out / "msa.toml", out / "results", executor="inline")
    if code:
        return code
    return fragility_command(out / "results", out / "msa.toml", [0.3, 1.0, 2.0], out=out / "fragility")


if __name__ == "__main__":
    sys.exit(main(Path(sys.argv[1] if len(sys.argv) > 1 else "results/msa")))
