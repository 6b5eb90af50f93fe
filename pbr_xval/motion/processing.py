"""Record processing: resampling, baseline correction, filtering, two-component rotation, scaling.

Every step is explicit (nothing is applied unless asked) and recorded in the record's
``metadata["processing"]`` list, which the scene carries in its excitation description
(``Scene.info()["excitation"]``) and so in every trajectory's provenance.

* :func:`baseline_correct` — remove the mean, a linear trend or a least-squares polynomial
  (:mod:`pbr_xval.motion.portable`, the same bits on every CPU / ``numpy.polynomial``): raw lab
  records carry offsets and drifts.
* :func:`butterworth` — Butterworth high-, low- or band-pass (``scipy.signal.butter`` as
  second-order sections), zero-phase (``sosfiltfilt``) or causal (``sosfilt``).
* :func:`project_components` — two horizontal components H1, H2 with their directions,
  projected onto the shaking azimuth (the engines take one horizontal direction).
* :func:`record_from_spec` — a scenario's record table → the processed, scaled record.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from fractions import Fraction
from typing import Any, overload

import numpy as np
from scipy.signal import resample_poly

from . import portable
from .base import GroundMotion
from .intensity import peak_ground_acceleration, peak_ground_velocity
from .records import Record

__all__ = [
    "RecordSpecError",
    "baseline_correct",
    "butterworth",
    "project_components",
    "record_from_spec",
    "resample",
    "scale_to_pga",
    "scale_to_pgv",
    "synthetic_accelerogram",
]

_MAX_POLY = 1000  # largest up/down factor for which polyphase resampling is used


def resample(record: Record, dt: float) -> Record:
    """Resample a record onto a new uniform grid ``t0 + k·dt`` within its duration.

    * Upsampling (dt ≤ record.dt): the record's own piecewise-linear a(t) is
      evaluated on the new grid (no information is added or lost).
    * Downsampling: if dt/record.dt equals a fraction down/up with
      up, down ≤ 1000 (to 1e-9 relative), :func:`scipy.signal.resample_poly`
      applies its anti-alias FIR filter (Kaiser window, cut-off at the new
      Nyquist frequency); otherwise plain linear interpolation is used,
      *without* anti-aliasing — low-pass the record first in that case.

    Parameters
    ----------
    record : Record
    dt : float, s
        New time step, > 0.

    Returns
    -------
    Record
        Same provenance, ``metadata["resampled_from_dt"]`` set.
    """
    dt = float(dt)
    if not (math.isfinite(dt) and dt > 0):
        raise ValueError(f"dt must be a positive finite time step in s, got {dt!r}")
    n_new = math.floor((record.npts - 1) * record.dt / dt * (1 + 1e-12)) + 1
    if n_new < 2:
        raise ValueError(
            f"dt={dt!r} s leaves fewer than 2 samples in a record of {record.duration - record.t0} s"
        )
    ratio = dt / record.dt
    frac = Fraction(ratio).limit_denominator(_MAX_POLY)
    method = "linear"
    if ratio <= 1.0:
        acc = record.acceleration(record.t0 + dt * np.arange(n_new))
    elif abs(float(frac) - ratio) <= 1e-9 * ratio and max(frac.numerator, frac.denominator) <= _MAX_POLY:
        acc = resample_poly(record.acc, frac.denominator, frac.numerator)[:n_new]
        method = "resample_poly"
    else:
        acc = record.acceleration(record.t0 + dt * np.arange(n_new))
    return record.replace(acc, dt, resampled_from_dt=record.dt, resample_method=method)


def _scale(motion: GroundMotion, target: float, peak: float, what: str) -> GroundMotion:
    if not (math.isfinite(target) and target > 0):
        raise ValueError(f"target {what} must be a positive finite number, got {target!r}")
    if not peak > 0:
        raise ValueError(f"motion {motion.name!r} has zero {what}; cannot scale it to {target!r}")
    return motion.scaled(target / peak)


@overload
def scale_to_pga(motion: Record, target: float) -> Record: ...
@overload
def scale_to_pga(motion: GroundMotion, target: float) -> GroundMotion: ...
def scale_to_pga(motion: GroundMotion, target: float) -> GroundMotion:
    """Copy of ``motion`` scaled so that its PGA equals ``target`` (m/s²).

    Uses the exact ``pga`` of pulses/records, else a fine sampling
    (:func:`~pbr_xval.motion.intensity.peak_ground_acceleration`).
    """
    return _scale(motion, target, peak_ground_acceleration(motion), "PGA")


@overload
def scale_to_pgv(motion: Record, target: float) -> Record: ...
@overload
def scale_to_pgv(motion: GroundMotion, target: float) -> GroundMotion: ...
def scale_to_pgv(motion: GroundMotion, target: float) -> GroundMotion:
    """Copy of ``motion`` scaled so that its PGV equals ``target`` (m/s); exact ``pgv`` when available."""
    return _scale(motion, target, peak_ground_velocity(motion), "PGV")


# ----------------------------------------------------------------------- corrections
class RecordSpecError(ValueError):
    """A record key of a scenario cannot be applied; the message names the key."""


def _processed(record: Record, acc: np.ndarray, step: Mapping[str, object]) -> Record:
    steps = [*record.metadata.get("processing", []), step]
    return record.replace(acc, processing=steps)


def baseline_correct(record: Record, kind: str = "linear", order: int = 2) -> Record:
    """Subtract a baseline from ``record``: ``"mean"``, ``"linear"`` (least-squares line) or
    ``"polynomial"`` (least-squares polynomial of ``order`` in time); ``"none"`` returns it as is.

    Returns a new :class:`Record` (m/s²) with the step, the removed offset (m/s²) and, for a
    line, the removed slope (m/s³) appended to ``metadata["processing"]``.
    """

    a = np.asarray(record.acc, dtype=float)
    if kind == "none":
        return record
    if kind == "mean":
        out = portable.detrend(a, "constant")
        step: dict[str, object] = {"step": "baseline", "kind": "mean", "removed_mean_m_s2": float(a.mean())}
    elif kind == "linear":
        out = portable.detrend(a, "linear")
        icpt, slope_per_sample = portable.linear_fit(a)
        step = {
            "step": "baseline",
            "kind": "linear",
            "removed_offset_m_s2": float(icpt),
            "removed_slope_m_s3": float(slope_per_sample / record.dt),
        }
    elif kind == "polynomial":
        if not (isinstance(order, int) and 0 <= order <= 10):
            raise ValueError(f"baseline polynomial order must be an integer 0–10, got {order!r}")
        t = record.time - record.t0
        fit = np.polynomial.Polynomial.fit(t, a, order)
        out = a - fit(t)
        step = {
            "step": "baseline",
            "kind": "polynomial",
            "order": order,
            "removed_mean_m_s2": float(np.mean(fit(t))),
        }
    else:
        raise ValueError(f"baseline {kind!r}: expected one of none, mean, linear, polynomial")
    return _processed(record, out, step)


def butterworth(
    record: Record,
    highpass_hz: float | None = None,
    lowpass_hz: float | None = None,
    order: int = 4,
    zero_phase: bool = True,
) -> Record:
    """Butterworth filter of ``record``: high-pass (``highpass_hz`` only), low-pass
    (``lowpass_hz`` only) or band-pass (both), corners in Hz, ``order`` poles per corner.

    ``zero_phase`` filters forward and backward (:func:`pbr_xval.motion.portable.sosfiltfilt`,
    scipy's ``sosfiltfilt`` without its LAPACK solve, so the same bits on every CPU: no phase
    shift, magnitude response squared); otherwise causal (:func:`scipy.signal.sosfilt`).

    Raises
    ------
    ValueError
        a corner at or above the Nyquist frequency 1/(2·dt), or high-pass ≥ low-pass.
    """
    from scipy import signal

    if highpass_hz is None and lowpass_hz is None:
        return record
    nyq = 0.5 / record.dt
    for name, f in (("highpass_hz", highpass_hz), ("lowpass_hz", lowpass_hz)):
        if f is not None and not (0 < f < nyq):
            raise ValueError(
                f"{name} = {f} Hz must be between 0 and the Nyquist frequency {nyq:g} Hz of the record (dt = {record.dt:g} s)"
            )
    if highpass_hz is not None and lowpass_hz is not None:
        if highpass_hz >= lowpass_hz:
            raise ValueError(f"highpass_hz = {highpass_hz} must be below lowpass_hz = {lowpass_hz}")
        sos = signal.butter(order, [highpass_hz, lowpass_hz], "bandpass", fs=1.0 / record.dt, output="sos")
        kind = "bandpass"
    elif highpass_hz is not None:
        sos = signal.butter(order, highpass_hz, "highpass", fs=1.0 / record.dt, output="sos")
        kind = "highpass"
    else:
        sos = signal.butter(order, lowpass_hz, "lowpass", fs=1.0 / record.dt, output="sos")
        kind = "lowpass"
    a = np.asarray(record.acc, dtype=float)
    out = portable.sosfiltfilt(sos, a) if zero_phase else signal.sosfilt(sos, a)
    step = {
        "step": "filter",
        "kind": f"Butterworth {kind}",
        "highpass_hz": highpass_hz,
        "lowpass_hz": lowpass_hz,
        "order": order,
        "zero_phase": bool(zero_phase),
        "implementation": "scipy.signal.butter(output='sos') + "
        + ("pbr_xval.motion.portable.sosfiltfilt" if zero_phase else "sosfilt"),
    }
    return _processed(record, out, step)


def project_components(
    h1: Record, azimuth1_deg: float, h2: Record, azimuth2_deg: float, azimuth_deg: float
) -> Record:
    """Project two horizontal components onto the shaking azimuth.

    a(t) = a1(t)·cos(ψ − ψ1) + a2(t)·cos(ψ − ψ2), all angles in degrees from +x toward +y.
    Both components must share dt, t0 and their number of samples. The part perpendicular to
    ψ is not simulated (the engines shake along one horizontal direction); its PGA is recorded
    in ``metadata["processing"]`` so the loss is visible.
    """
    if abs(h1.dt - h2.dt) > 1e-9 * h1.dt or h1.t0 != h2.t0 or h1.npts != h2.npts:
        raise ValueError(
            f"the two components must share dt, t0 and length: H1 has dt {h1.dt!r} s, t0 {h1.t0!r} s, "
            f"{h1.npts} samples; H2 has dt {h2.dt!r} s, t0 {h2.t0!r} s, {h2.npts} samples"
        )
    r = math.radians
    c1, c2 = math.cos(r(azimuth_deg - azimuth1_deg)), math.cos(r(azimuth_deg - azimuth2_deg))
    s1, s2 = math.sin(r(azimuth_deg - azimuth1_deg)), math.sin(r(azimuth_deg - azimuth2_deg))
    along = c1 * h1.acc + c2 * h2.acc
    across = -s1 * h1.acc - s2 * h2.acc
    step = {
        "step": "rotation",
        "azimuth_deg": azimuth_deg,
        "components": [
            {"source": h1.source, "azimuth_deg": azimuth1_deg, "weight": c1, "pga_m_s2": h1.pga},
            {"source": h2.source, "azimuth_deg": azimuth2_deg, "weight": c2, "pga_m_s2": h2.pga},
        ],
        "dropped_perpendicular_pga_m_s2": float(np.max(np.abs(across))),
    }
    out = _processed(h1, along, step)
    out.name = f"{h1.name}+{h2.name}@{azimuth_deg:g}deg"
    return out


def _read_source(src: Any, resolve: Callable[[str], Any], key: str) -> Record:
    from .base import MotionFileError
    from .records import read_record

    path = resolve(src.path)
    fmt = src.format
    if fmt == "auto":
        fmt = {".at2": "at2", ".npz": "npz"}.get(path.suffix.lower(), "table")
    kw: dict[str, Any] = {}
    if fmt == "table":
        kw = {"dt": src.dt, "units": src.units, "column": src.column}
        kw["time_column"] = "auto" if src.time_column is None else src.time_column
    elif fmt == "npz":
        kw = {"array": src.array, "dt": src.dt, "dt_array": src.dt_array, "units": src.units}
    for k, v in (
        ("column", src.column),
        ("time_column", src.time_column),
        ("array", src.array),
        ("dt_array", src.dt_array),
    ):
        if v is not None and k not in kw:
            raise RecordSpecError(
                f"key '{key}.{k}': applies to {'a table' if 'column' in k else 'an npz archive'}, "
                f"not to a record in format {fmt!r}"
            )
    try:
        return _read_cached(path, fmt, kw, read_record)
    except MotionFileError as exc:
        raise RecordSpecError(f"key '{key}.path': {exc}") from None


#: records read, by (path, content SHA-256, format, reader arguments): an ensemble's members and a
#: campaign's reruns read one file many times in one process (parsing a table is ~30 ms)
_RECORDS: dict[tuple[Any, ...], Record] = {}


def _read_cached(path: Any, fmt: str, kw: dict[str, Any], read: Callable[..., Record]) -> Record:
    """``read(path, format=fmt, **kw)``, memoised on the file's content; every caller gets its own copy."""
    import copy

    from pbr_xval.hashing import file_sha256

    try:
        key = (str(path), file_sha256(path), fmt, repr(sorted(kw.items())))
    except OSError:  # a missing file: the reader's own error
        return read(path, format=fmt, **kw)
    rec = _RECORDS.get(key)
    if rec is None:
        rec = read(path, format=fmt, **kw)
        if len(_RECORDS) > 32:
            _RECORDS.clear()
        _RECORDS[key] = rec
    return copy.deepcopy(rec)


def record_from_spec(
    spec: Any, resolve: Callable[[str], Any], *, azimuth_deg: float | None, key: str = "excitation"
) -> Record:
    """The record a scenario's ``type = "record"`` table describes, processed and scaled.

    Order: read each component (units converted to m/s²) → baseline correction → Butterworth
    filter → projection of two components onto the shaking azimuth (or of one component whose
    ``component_azimuth_deg`` differs from it) → ``target_pga`` / ``target_pgv`` → ``scale`` ×
    ``sign``. ``azimuth_deg`` is None for a vertical component.

    Raises
    ------
    RecordSpecError
        naming the scenario key (e.g. ``excitation.second.path``).
    """

    def prep(src: Any, k: str) -> Record:
        rec = _read_source(src, resolve, k)
        try:
            rec = baseline_correct(rec, spec.baseline, spec.baseline_order)
            rec = butterworth(rec, spec.highpass_hz, spec.lowpass_hz, spec.filter_order, spec.zero_phase)
        except ValueError as exc:
            raise RecordSpecError(f"key '{key}': {exc}") from None
        return rec

    if azimuth_deg is None and (spec.second is not None or spec.component_azimuth_deg is not None):
        raise RecordSpecError(f"key '{key}.second': a vertical record has one component and no azimuth")
    m = prep(spec, key)
    if spec.second is not None and azimuth_deg is not None:  # (None with a second component raised above)
        h2 = prep(spec.second, f"{key}.second")
        try:
            m = project_components(
                m, spec.component_azimuth_deg, h2, spec.second.component_azimuth_deg, azimuth_deg
            )
        except ValueError as exc:
            raise RecordSpecError(f"key '{key}.second': {exc}") from None
    elif spec.component_azimuth_deg is not None and azimuth_deg is not None:
        w = math.cos(math.radians(azimuth_deg - spec.component_azimuth_deg))
        m = _processed(
            m,
            w * m.acc,
            {
                "step": "rotation",
                "azimuth_deg": azimuth_deg,
                "components": [{"source": m.source, "azimuth_deg": spec.component_azimuth_deg, "weight": w}],
            },
        )
    try:
        if spec.target_pga is not None:
            m = scale_to_pga(m, spec.target_pga)
        elif spec.target_pgv is not None:
            m = scale_to_pgv(m, spec.target_pgv)
    except ValueError as exc:
        raise RecordSpecError(f"key '{key}': {exc}") from None
    factor = spec.scale * spec.sign
    if factor != 1.0:
        m = m.scaled(factor)
    return m


# ----------------------------------------------------------------------- sample record
def synthetic_accelerogram(
    seed: int = 0,
    duration: float = 10.0,
    dt: float = 0.01,
    pga: float = 0.3 * 9.80665,
    band_hz: tuple[float, float] = (0.3, 8.0),
    name: str = "pbr-xval synthetic accelerogram",
) -> Record:
    """A deterministic, baseline-corrected synthetic accelerogram (m/s²), for examples and tests.

    Gaussian white noise (``numpy.random.default_rng(seed)``) → zero-phase Butterworth band-pass
    ``band_hz`` (order 4) → Saragoni–Hart envelope (t/t_p)^2·exp(2(1 − t/t_p)), t_p = 0.25 ×
    ``duration`` → baseline correction: two smooth envelope-shaped terms are subtracted so that the
    final velocity and displacement of the record (its exact piecewise-linear integrals) are both
    0 → scaled to ``pga``. Samples at t = k·dt, k = 0 … duration/dt.
    """
    from scipy import signal

    n = round(duration / dt) + 1
    t = dt * np.arange(n)
    rng = np.random.default_rng(seed)
    w = rng.normal(size=n)
    sos = signal.butter(4, list(band_hz), "bandpass", fs=1.0 / dt, output="sos")
    x = signal.sosfiltfilt(sos, w)
    tp = 0.25 * duration
    env = (t / tp) ** 2 * np.exp(2.0 * (1.0 - t / tp))
    a = x * env

    # exact end values of v and d of the piecewise-linear a(t) (Record's integration), linear in a
    def ends(acc: np.ndarray) -> np.ndarray:
        r = Record(acc, dt)
        return np.array([r.velocity(r.duration), r.displacement(r.duration)])

    basis = [env * np.sin(np.pi * t / duration), env * np.sin(np.pi * t / duration) * (t / duration)]
    m = np.column_stack([ends(b) for b in basis])
    coef = np.linalg.solve(m, ends(a))
    a = a - coef[0] * basis[0] - coef[1] * basis[1]
    a *= pga / np.max(np.abs(a))
    return Record(
        a, dt, name=name,
        metadata={"generator": "pbr_xval.motion.processing.synthetic_accelerogram", "seed": seed,
                  "duration_s": duration, "band_hz": list(band_hz), "pga_m_s2": pga},
    )  # fmt: skip
