"""The record pipeline gives the same bits on every x86-64 CPU (pbr_xval.motion.portable).

OpenBLAS picks its kernels by CPU; ``OPENBLAS_CORETYPE`` forces one, so one machine can run the
kernels of another: SkylakeX (AVX-512), Haswell / Zen (AVX2), Sandybridge (AVX), Prescott (SSE3).
scipy's detrend and sosfiltfilt go through LAPACK and give different last bits under different
kernels (measured below, the probe's own check); the portable functions must not.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest
from scipy import signal

from pbr_xval.motion import portable

# a record like a table accelerometer's: band-limited noise, an offset and a slow drift, 800 Hz
PROBE = r"""
import hashlib, json, sys
import numpy as np
from scipy import signal
from pbr_xval.motion import portable
from pbr_xval.validation.campaign import Baseline, baseline_correct
from pbr_xval.motion.records import Record
from pbr_xval.motion.processing import baseline_correct as bc, butterworth

rng = np.random.default_rng(7)
n = 16000
x = np.cumsum(rng.normal(size=n)) * 1e-3 + rng.normal(size=n) * 0.3 + 0.17 + 1e-4 * np.arange(n)
h = lambda a: hashlib.sha256(np.ascontiguousarray(a, dtype=np.float64).tobytes()).hexdigest()
sos = signal.butter(4, [0.3, 25], "bandpass", fs=800.0, output="sos")
acc, dt = baseline_correct(x, 1 / 800, Baseline())
rec = butterworth(bc(Record(x, 1 / 800), "linear"), highpass_hz=0.3, lowpass_hz=25.0)
out = {
    "validate": h(acc),
    "records": h(rec.acc),
    "scipy_detrend": h(signal.detrend(x)),
    "scipy_zi": h(signal.sosfilt_zi(sos)),
}
print(json.dumps(out))
"""

CORETYPES = ["Haswell", "Sandybridge", "Prescott"]  # every x86-64 CPU CI may have runs these


def _probe(coretype: str | None) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_CORETYPE"}
    if coretype:
        env["OPENBLAS_CORETYPE"] = coretype
    res = subprocess.run([sys.executable, "-c", PROBE], env=env, capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr
    return dict(json.loads(res.stdout.strip().splitlines()[-1]))


def test_portable_equals_scipy_within_rounding() -> None:
    rng = np.random.default_rng(3)
    x = rng.normal(size=5000) + 0.2 + 1e-3 * np.arange(5000)
    d = portable.detrend(x)
    assert np.max(np.abs(d - signal.detrend(x))) < 1e-12
    assert np.max(np.abs(portable.detrend(x, "constant") - signal.detrend(x, type="constant"))) < 1e-12
    for sos in (
        signal.butter(4, [0.3, 25], "bandpass", fs=800.0, output="sos"),
        signal.butter(3, 10.0, "lowpass", fs=200.0, output="sos"),  # one first-order section
        signal.butter(2, 0.1, "highpass", fs=100.0, output="sos"),
    ):
        assert np.allclose(portable.sosfilt_zi(sos), signal.sosfilt_zi(sos), rtol=1e-9, atol=1e-12)
        y, ref = portable.sosfiltfilt(sos, d), signal.sosfiltfilt(sos, d)
        assert np.max(np.abs(y - ref)) <= 1e-9 * np.max(np.abs(ref))
    c, s = portable.linear_fit(3.0 + 0.5 * np.arange(11))
    assert (c, s) == (3.0, 0.5)
    with pytest.raises(ValueError, match="zero-phase filtering needs more than"):
        portable.sosfiltfilt(signal.butter(4, 0.3, "highpass", fs=800.0, output="sos"), np.ones(10))


@pytest.mark.slow
def test_record_pipeline_is_the_same_under_every_blas_kernel() -> None:
    """Both record pipelines (validate's table correction and a scenario's record processing)."""
    here = _probe(None)
    runs = {c: _probe(c) for c in CORETYPES}
    # the probe can tell kernels apart: scipy's LAPACK-based steps differ between them
    assert len({r["scipy_detrend"] for r in runs.values()} | {r["scipy_zi"] for r in runs.values()}) > 2
    for c, r in runs.items():
        assert r["validate"] == here["validate"], c
        assert r["records"] == here["records"], c
