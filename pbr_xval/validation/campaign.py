"""Shake-table campaigns: tests, each a recorded table motion and an observed outcome.

Two input forms, both checked in full before any simulation runs (one-line errors naming the
file and the test):

* the **shared format** — a directory holding ``experiments.csv`` (one row per test: ``test``,
  ``motion``, ``pga_g``, ``pgv_over_pga_s``, ``toppled_specimen1``, ``toppled_specimen2``, …)
  and ``table_motions.npz`` (``testNNN_acc_g`` in g and ``testNNN_dt_s`` in s);
* the **general CSV form** — one row per test with columns ``test``, ``motion_file`` (relative
  to the CSV), ``units`` (``g``, ``m/s2`` or ``cm/s2``), ``toppled`` (0/1) and optionally
  ``dt`` (s, for a one-column file), ``motion`` (earthquake record name, used to group tests
  for cross-validation; default: the motion file's name) and ``specimen``.

Recorded table accelerations carry an offset and noise; :func:`baseline_correct` removes them
with an explicit, recorded procedure (scipy.signal), applied identically to every test.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "Baseline",
    "Campaign",
    "CampaignError",
    "Test",
    "baseline_correct",
    "load_campaign",
    "read_general_csv",
    "read_shared",
    "record_pgv",
]

G_STANDARD = 9.80665  # m/s² per g (the unit of lab records)
UNITS = {"g": G_STANDARD, "m/s2": 1.0, "cm/s2": 0.01}
SHARED_CSV = "experiments.csv"
SHARED_NPZ = "table_motions.npz"


class CampaignError(ValueError):
    """Bad campaign input; the message names the file, the test and what was expected."""


@dataclass(frozen=True)
class Baseline:
    """Baseline correction and filtering applied to every table record (all explicit).

    Attributes
    ----------
    detrend : {"linear", "constant", "none"}
        Detrend applied first (removes the recorder's offset): :func:`pbr_xval.motion.portable.detrend`,
        the operation of :func:`scipy.signal.detrend` computed the same way on every CPU.
    highpass_hz : float or None
        Corner of a zero-phase Butterworth high-pass (Hz); removes the drift a shake table
        cannot reproduce (its stroke is finite). None: no high-pass.
    lowpass_hz : float or None
        Corner of a zero-phase Butterworth low-pass (Hz); removes sensor noise. None: none.
    order : int
        Butterworth order (applied forward and backward: effective order 2·order).
    resample_hz : float or None
        Sampling rate the corrected record is resampled to (:func:`scipy.signal.resample_poly`,
        anti-aliased) when it is an integer fraction of the original rate; None keeps the
        original. 200 Hz keeps 8 samples per cycle at the 25 Hz low-pass corner and makes each
        simulation read a quarter of the 800 Hz samples.
    """

    detrend: str = "linear"
    highpass_hz: float | None = 0.3
    lowpass_hz: float | None = 25.0
    order: int = 4
    resample_hz: float | None = 200.0

    def __post_init__(self) -> None:
        if self.detrend not in ("linear", "constant", "none"):
            raise CampaignError(f"baseline detrend {self.detrend!r}: expected linear, constant or none")
        for name in ("highpass_hz", "lowpass_hz", "resample_hz"):
            v = getattr(self, name)
            if v is not None and not (math.isfinite(v) and v > 0):
                raise CampaignError(f"baseline {name} = {v!r}: expected a positive frequency in Hz")
        if self.highpass_hz and self.lowpass_hz and self.highpass_hz >= self.lowpass_hz:
            raise CampaignError(
                f"baseline band {self.highpass_hz}–{self.lowpass_hz} Hz: the high-pass corner must be "
                "below the low-pass corner"
            )

    def describe(self) -> str:
        parts = [f"detrend {self.detrend}"]
        if self.highpass_hz:
            parts.append(f"high-pass {self.highpass_hz:g} Hz")
        if self.lowpass_hz:
            parts.append(f"low-pass {self.lowpass_hz:g} Hz")
        if self.highpass_hz or self.lowpass_hz:
            parts.append(f"Butterworth order {self.order}, zero phase (sosfiltfilt)")
        if self.resample_hz:
            parts.append(f"resampled to {self.resample_hz:g} Hz (resample_poly) when the rate divides")
        return ", ".join(parts)

    def to_dict(self) -> dict[str, Any]:
        return {
            "detrend": self.detrend,
            "highpass_hz": self.highpass_hz,
            "lowpass_hz": self.lowpass_hz,
            "order": self.order,
            "resample_hz": self.resample_hz,
        }


def baseline_correct(
    acc: NDArray[np.floating], dt: float, baseline: Baseline
) -> tuple[NDArray[np.float64], float]:
    """Apply ``baseline`` to one record.

    Parameters
    ----------
    acc : (n,) float, m/s²
    dt : float, s
    baseline : Baseline

    Returns
    -------
    acc : (m,) float64, m/s² — corrected (and resampled when ``baseline.resample_hz`` divides 1/dt)
    dt : float, s — its sample interval
    """
    from scipy import signal

    from pbr_xval.motion import portable

    a = np.asarray(acc, dtype=np.float64)
    if baseline.detrend != "none":
        a = portable.detrend(a, baseline.detrend)
    fs = 1.0 / dt
    nyq = fs / 2
    hp = baseline.highpass_hz
    lp = baseline.lowpass_hz if baseline.lowpass_hz is not None and baseline.lowpass_hz < nyq else None
    if hp and lp:
        sos = signal.butter(baseline.order, [hp, lp], "bandpass", fs=fs, output="sos")
    elif hp:
        sos = signal.butter(baseline.order, hp, "highpass", fs=fs, output="sos")
    elif lp:
        sos = signal.butter(baseline.order, lp, "lowpass", fs=fs, output="sos")
    else:
        sos = None
    if sos is not None:
        a = portable.sosfiltfilt(sos, a)  # scipy's algorithm without LAPACK: the same bits on every CPU
    if baseline.resample_hz:
        ratio = fs / baseline.resample_hz
        down = round(ratio)
        if down > 1 and abs(ratio - down) <= 1e-9 * ratio:
            a = np.asarray(signal.resample_poly(a, 1, down), dtype=np.float64)
            dt = dt * down
    return a, float(dt)


def record_pgv(acc: NDArray[np.floating], dt: float) -> float:
    """Peak |v| (m/s) of a corrected record ``acc`` ((n,) m/s², sample interval ``dt`` s): the velocity
    integrated by the trapezoidal rule from v = 0 and taken at the samples — the PGV ``validate``
    reports for each test (:func:`pbr_xval.validation.execution.prepare_motions`)."""
    a = np.asarray(acc, dtype=np.float64)
    v = np.concatenate([[0.0], np.cumsum(dt * (a[:-1] + a[1:]) / 2)])
    return float(np.max(np.abs(v)))


@dataclass
class Test:
    """One shake-table test.

    Attributes
    ----------
    test : str
        Test identifier (the lab's test number).
    motion : str
        Earthquake record the table reproduced (the grouping key for cross-validation).
    toppled : bool
        Observed outcome.
    source : str
        Where the motion comes from (file, or ``npz:key``), for messages.
    sheet : dict
        Lab-sheet intensity measures when given (``pga_g``, ``pgv_over_pga_s``).
    """

    test: str
    motion: str
    toppled: bool
    source: str
    units: str
    dt: float | None
    sheet: dict[str, float] = field(default_factory=dict)
    _loader: Any = field(default=None, repr=False)

    def raw_acceleration(self) -> tuple[NDArray[np.float64], float]:
        """(acc (n,) m/s² as recorded, dt s)."""
        return self._loader()


@dataclass
class Campaign:
    """A validated campaign for one specimen."""

    path: Path
    form: str  # "shared" or "csv"
    specimen: int
    tests: list[Test]

    def __len__(self) -> int:
        return len(self.tests)

    def select(self, tests: Sequence[str] | None = None, limit: int | None = None) -> Campaign:
        """A sub-campaign: the named tests (in campaign order), then the first ``limit``."""
        out = list(self.tests)
        if tests:
            known = {t.test for t in out}
            missing = [t for t in tests if t not in known]
            if missing:
                raise CampaignError(
                    f"{self.path}: --tests names test(s) {', '.join(missing)} that the campaign does not hold"
                )
            want = set(tests)
            out = [t for t in out if t.test in want]
        if limit is not None:
            out = out[: max(0, int(limit))]
        if not out:
            raise CampaignError(f"{self.path}: the selection holds no test (expected at least one)")
        return Campaign(self.path, self.form, self.specimen, out)


def _outcome(value: str, where: str) -> bool:
    v = str(value).strip().lower()
    if v in ("1", "1.0", "true", "yes"):
        return True
    if v in ("0", "0.0", "false", "no"):
        return False
    raise CampaignError(f"{where}: outcome {value!r} is not binary (expected 0 or 1)")


def _read_rows(path: Path) -> tuple[list[str], list[dict[str, str]]]:
    try:
        with open(path, newline="", encoding="utf-8-sig") as fh:
            reader = csv.DictReader(fh)
            rows = [r for r in reader if any((v or "").strip() for v in r.values())]
            cols = [c.strip() for c in (reader.fieldnames or [])]
    except OSError as exc:
        raise CampaignError(f"{path}: cannot read campaign file ({exc.strerror})") from None
    rows = [{(k or "").strip(): (v or "").strip() for k, v in r.items()} for r in rows]
    return cols, rows


def _test_id(raw: str) -> str:
    try:
        f = float(raw)
        return str(int(f)) if f.is_integer() else raw
    except ValueError:
        return raw


def read_shared(directory: str | Path, specimen: int) -> Campaign:
    """Read the shared format (``experiments.csv`` + ``table_motions.npz``) for ``specimen``."""
    d = Path(directory)
    csv_path, npz_path = d / SHARED_CSV, d / SHARED_NPZ
    for p in (csv_path, npz_path):
        if not p.is_file():
            raise CampaignError(
                f"{p}: file not found (the shared format needs {SHARED_CSV} and {SHARED_NPZ})"
            )
    cols, rows = _read_rows(csv_path)
    outcome_col = f"toppled_specimen{specimen}"
    for need in ("test", "motion"):
        if need not in cols:
            raise CampaignError(f"{csv_path}: no column {need!r} (found {', '.join(cols)})")
    if outcome_col not in cols:
        have = sorted(c.removeprefix("toppled_specimen") for c in cols if c.startswith("toppled_specimen"))
        raise CampaignError(
            f"{csv_path}: no column {outcome_col!r}: specimen {specimen} is not in this campaign "
            f"(specimens present: {', '.join(have) or 'none'})"
        )
    if not rows:
        raise CampaignError(f"{csv_path}: the campaign holds no test (expected at least one row)")
    try:
        npz = np.load(npz_path)
        keys = set(npz.files)
    except Exception as exc:
        raise CampaignError(f"{npz_path}: cannot read ({exc})") from None
    tests: list[Test] = []
    seen: set[str] = set()
    for i, r in enumerate(rows, 2):
        tid = _test_id(r["test"])
        where = f"{csv_path}: line {i}, test {tid}"
        if not tid:
            raise CampaignError(f"{csv_path}: line {i}: empty test number")
        if tid in seen:
            raise CampaignError(f"{where}: duplicate test number")
        seen.add(tid)
        try:
            key = f"test{int(tid):03d}"
        except ValueError:
            raise CampaignError(f"{where}: test {tid!r} is not a number (expected NNN)") from None
        acc_key, dt_key = f"{key}_acc_g", f"{key}_dt_s"
        if acc_key not in keys or dt_key not in keys:
            raise CampaignError(f"{npz_path}: test {tid}: no table motion ({acc_key} / {dt_key} missing)")
        sheet = {}
        for c in ("pga_g", "pgv_over_pga_s"):
            if r.get(c):
                try:
                    sheet[c] = float(r[c])
                except ValueError:
                    raise CampaignError(f"{where}: {c} = {r[c]!r} is not a number") from None

        def loader(acc_key: str = acc_key, dt_key: str = dt_key) -> tuple[NDArray[np.float64], float]:
            with np.load(npz_path) as z:
                return np.asarray(z[acc_key], dtype=np.float64) * G_STANDARD, float(z[dt_key])

        tests.append(
            Test(
                test=tid, motion=r["motion"] or f"test{tid}", toppled=_outcome(r[outcome_col], where),
                source=f"{npz_path.name}:{acc_key}", units="g", dt=None, sheet=sheet, _loader=loader,
            )
        )  # fmt: skip
    _check_motions(tests, npz_path, npz)
    return Campaign(d, "shared", specimen, tests)


def _check_motions(tests: list[Test], npz_path: Path, npz: Any) -> None:
    for t in tests:
        key = t.source.split(":", 1)[1]
        a = npz[key]
        dt = float(npz[key.replace("_acc_g", "_dt_s")])
        if a.ndim != 1 or a.size < 2:
            raise CampaignError(
                f"{npz_path}: test {t.test}: motion {key} has shape {a.shape} (expected (n,), n ≥ 2)"
            )
        if not np.all(np.isfinite(a)):
            raise CampaignError(f"{npz_path}: test {t.test}: motion {key} holds NaN or infinity")
        if not (math.isfinite(dt) and dt > 0):
            raise CampaignError(
                f"{npz_path}: test {t.test}: sample interval {dt!r} (expected a positive dt in s)"
            )


GENERAL_COLUMNS = ("test", "motion_file", "units", "toppled")


def read_general_csv(path: str | Path, specimen: int) -> Campaign:
    """Read the general CSV form (see the module docstring); motion files are checked and read now."""
    from pbr_xval.motion.base import MotionFileError
    from pbr_xval.motion.records import read_record

    path = Path(path)
    cols, rows = _read_rows(path)
    missing = [c for c in GENERAL_COLUMNS if c not in cols]
    if missing:
        raise CampaignError(
            f"{path}: missing column(s) {', '.join(missing)} (expected {', '.join(GENERAL_COLUMNS)}; "
            f"optional dt, motion, specimen; found {', '.join(cols) or 'none'})"
        )
    if not rows:
        raise CampaignError(f"{path}: the campaign holds no test (expected at least one row)")
    tests: list[Test] = []
    seen: set[str] = set()
    for i, r in enumerate(rows, 2):
        tid = _test_id(r["test"])
        where = f"{path}: line {i}, test {tid}"
        if not tid:
            raise CampaignError(f"{path}: line {i}: empty test identifier")
        if tid in seen:
            raise CampaignError(f"{where}: duplicate test identifier")
        seen.add(tid)
        toppled = _outcome(r["toppled"], where)
        if "specimen" in cols and r.get("specimen"):
            if _test_id(r["specimen"]) != str(specimen):
                raise CampaignError(
                    f"{where}: specimen {r['specimen']!r} does not match --specimen {specimen} "
                    "(one campaign file per specimen)"
                )
        units = r["units"]
        if units not in UNITS:
            raise CampaignError(f"{where}: units {units!r} (expected one of {', '.join(UNITS)})")
        dt = None
        if r.get("dt"):
            try:
                dt = float(r["dt"])
            except ValueError:
                raise CampaignError(f"{where}: dt {r['dt']!r} is not a number (s)") from None
            if not (math.isfinite(dt) and dt > 0):
                raise CampaignError(f"{where}: dt {r['dt']!r} (expected a positive sample interval in s)")
        if not r["motion_file"]:
            raise CampaignError(f"{where}: no motion file given")
        mf = Path(r["motion_file"])
        mf = mf if mf.is_absolute() else path.parent / mf
        if not mf.is_file():
            raise CampaignError(f"{where}: motion file not found: {mf}")
        try:
            rec = read_record(mf) if mf.suffix.lower() == ".at2" else read_record(mf, dt=dt, units=units)
        except (MotionFileError, ValueError) as exc:
            raise CampaignError(f"{where}: motion file {mf}: {exc}") from None
        if rec.t0 != 0.0:
            raise CampaignError(f"{where}: motion file {mf} starts at t = {rec.t0} s (expected 0)")
        acc, rdt = np.asarray(rec.acc, dtype=np.float64), float(rec.dt)

        def loader(acc: NDArray[np.float64] = acc, rdt: float = rdt) -> tuple[NDArray[np.float64], float]:
            return acc, rdt

        tests.append(
            Test(
                test=tid, motion=r.get("motion") or mf.stem, toppled=toppled, source=str(mf),
                units=units, dt=rdt, _loader=loader,
            )
        )  # fmt: skip
    return Campaign(path, "csv", specimen, tests)


def load_campaign(path: str | Path, specimen: int) -> Campaign:
    """A directory → the shared format; a ``.csv`` file → the general form."""
    p = Path(path)
    if specimen < 1:
        raise CampaignError(f"specimen {specimen}: expected a positive specimen number")
    if p.is_dir():
        return read_shared(p, specimen)
    if p.is_file():
        return read_general_csv(p, specimen)
    raise CampaignError(
        f"{p}: not found (expected a directory with {SHARED_CSV} and {SHARED_NPZ}, or a campaign CSV file)"
    )
