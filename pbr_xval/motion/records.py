"""Recorded (uniformly sampled) ground motions and their file formats.

Readers
-------
* :func:`read_at2` — PEER NGA ``.AT2`` files (units of g).
* :func:`read_table` — text tables: one column, time + acceleration, or many columns with a
  header row (columns chosen by name or index), separated by spaces, tabs, commas or semicolons.
* :func:`read_npz` — one array of a NumPy ``.npz`` archive (e.g. a lab's table motions).
* :func:`read_record` — dispatch by format name or file extension.

Units are stated by the caller, never guessed from a file (except AT2, which is g by format).
"""

from __future__ import annotations

import hashlib
import math
import re
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .base import GroundMotion, MotionFileError

__all__ = [
    "FORMATS",
    "G_STANDARD",
    "UNITS",
    "Record",
    "read_at2",
    "read_npz",
    "read_record",
    "read_table",
    "write_at2",
    "write_table",
]

Arr = NDArray[np.float64]

#: Standard gravity g0 = 9.80665 m/s² (exact, CGPM 1901); it defines the "g"
#: unit of PEER records, so g → m/s² conversion uses it, not a local g.
G_STANDARD = 9.80665

#: Conversion factors to m/s² for acceleration units accepted by :func:`read_table`.
UNITS: dict[str, float] = {"m/s2": 1.0, "g": G_STANDARD, "cm/s2": 0.01}

_NUMBER = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[EeDd][+-]?\d+)?")


def _number(token: str) -> float | None:
    """Parse a Fortran-style real (``1.2E-03``, ``-.12E-02``, ``1.2D-03``); None if not one."""
    if not _NUMBER.fullmatch(token):
        return None
    return float(token.replace("D", "E").replace("d", "e"))


class Record(GroundMotion):
    """Uniformly sampled acceleration record.

    a(t) interpolates the samples piecewise-linearly on ``[t0, t0 + (n−1) dt]``
    and is 0 outside.  v and d are the exact integrals of that a(t) from 0
    (piecewise quadratic and cubic): cumulative v_k, d_k are precomputed at the
    samples and evaluated analytically in between.  After the last sample v
    stays at its final value and d grows linearly.

    Parameters
    ----------
    acc : (n,) float, m/s²
        Samples, n ≥ 2, finite.
    dt : float, s
        Sample spacing, > 0.
    t0 : float, s
        Time of the first sample, ≥ 0.
    name : str
        Label (e.g. station/component).
    source : str, optional
        Path of the file the record was read from.
    header : str
        Header text of the original file.
    units : str
        Units of the original file (data are always stored in m/s²).
    sha256 : str, optional
        SHA-256 hex digest of the source file.
    metadata : dict, optional
        Extra JSON-serialisable provenance.

    Notes
    -----
    :attr:`breakpoints` does not list every sample time (too many events for
    an ODE integrator); a(t) is continuous and only kinked at the samples, so
    a step bounded by ``dt`` resolves it.  Returned: 0, t0 (if > 0, where a may
    jump from 0 to ``acc[0]``) and :attr:`duration`.
    """

    def __init__(
        self,
        acc: ArrayLike,
        dt: float,
        t0: float = 0.0,
        *,
        name: str = "record",
        source: str | None = None,
        header: str = "",
        units: str = "m/s2",
        sha256: str | None = None,
        metadata: dict[str, Any] | None = None,
    ) -> None:
        a = np.array(acc, dtype=float)
        if a.ndim != 1:
            raise ValueError(f"acc must be a 1-D array of accelerations in m/s², got shape {np.shape(acc)}")
        if a.size < 2:
            raise ValueError(f"acc must hold at least 2 samples, got {a.size}")
        if not np.all(np.isfinite(a)):
            k = int(np.argmin(np.isfinite(a)))
            raise ValueError(f"acc must be finite; sample {k} is {a[k]!r}")
        dt, t0 = float(dt), float(t0)
        if not (math.isfinite(dt) and dt > 0):
            raise ValueError(f"dt must be a positive finite time step in s, got {dt!r}")
        if not (math.isfinite(t0) and t0 >= 0):
            raise ValueError(f"t0 must be a finite time >= 0 s, got {t0!r}")
        a.flags.writeable = False
        self._acc, self.dt, self.t0 = a, dt, t0
        self.name, self.source, self.header, self.units, self.sha256 = name, source, header, units, sha256
        self.metadata = dict(metadata or {})
        da = np.diff(a)
        self._v = np.concatenate([[0.0], np.cumsum(dt * (a[:-1] + a[1:]) / 2)])
        self._d = np.concatenate([[0.0], np.cumsum(self._v[:-1] * dt + dt**2 * (2 * a[:-1] + a[1:]) / 6)])
        self._da = da

    # -- data ------------------------------------------------------------
    @property
    def acc(self) -> Arr:
        """(n,) float, m/s²: the samples (read-only)."""
        return self._acc

    @property
    def npts(self) -> int:
        """int: number of samples."""
        return int(self._acc.size)

    @property
    def time(self) -> Arr:
        """(n,) float, s: sample times t0 + k dt."""
        return self.t0 + self.dt * np.arange(self.npts, dtype=np.float64)

    @property
    def duration(self) -> float:
        """float, s: time of the last sample, t0 + (n − 1) dt."""
        return self.t0 + (self.npts - 1) * self.dt

    @property
    def breakpoints(self) -> tuple[float, ...]:
        """tuple of float, s: 0, the record's start t0 and its end."""
        return tuple(sorted({0.0, self.t0, self.duration}))

    @property
    def pga(self) -> float:
        """float, m/s²: exact peak |a| (attained at a sample)."""
        return float(np.max(np.abs(self._acc)))

    @property
    def pgv(self) -> float:
        """float, m/s: exact peak |v| (samples, plus interior extrema where a changes sign)."""
        a0, a1, v0 = self._acc[:-1], self._acc[1:], self._v[:-1]
        cross = a0 * a1 < 0
        s = -a0[cross] * self.dt / (a1[cross] - a0[cross])
        v_ext = v0[cross] + a0[cross] * s / 2
        return float(max(np.max(np.abs(self._v)), np.max(np.abs(v_ext), initial=0.0)))

    # -- kernels ---------------------------------------------------------
    def _locate(self, t: Arr) -> tuple[NDArray[np.intp], Arr]:
        k = np.clip(np.floor((t - self.t0) / self.dt), 0, self.npts - 2).astype(np.intp)
        s = np.clip(t - (self.t0 + k * self.dt), 0.0, self.dt)
        return k, s

    def _acceleration(self, t: Arr) -> Arr:
        k, s = self._locate(t)
        a = self._acc[k] + self._da[k] * (s / self.dt)
        return np.where((t >= self.t0) & (t <= self.duration), a, 0.0)

    def _velocity(self, t: Arr) -> Arr:
        k, s = self._locate(t)
        v = self._v[k] + self._acc[k] * s + self._da[k] * s**2 / (2 * self.dt)
        return np.where(t >= self.t0, v, 0.0)

    def _displacement(self, t: Arr) -> Arr:
        k, s = self._locate(t)
        d = self._d[k] + self._v[k] * s + self._acc[k] * s**2 / 2 + self._da[k] * s**3 / (6 * self.dt)
        d = d + self._v[-1] * np.maximum(t - self.duration, 0.0)
        return np.where(t >= self.t0, d, 0.0)

    # -- misc ------------------------------------------------------------
    def scaled(self, factor: float) -> Record:
        """Return a new :class:`Record` with samples multiplied by ``factor`` (dimensionless)."""
        factor = float(factor)
        if not math.isfinite(factor):
            raise ValueError(f"factor must be a finite number, got {factor!r}")
        return self.replace(self._acc * factor, scale_factor=self.metadata.get("scale_factor", 1.0) * factor)

    def replace(self, acc: ArrayLike, dt: float | None = None, **metadata: Any) -> Record:
        """New record with other samples (and optionally dt), same provenance plus ``metadata``."""
        return Record(
            acc, self.dt if dt is None else dt, self.t0, name=self.name, source=self.source, header=self.header,
            units=self.units, sha256=self.sha256, metadata={**self.metadata, **metadata},
        )  # fmt: skip

    def describe(self) -> dict[str, Any]:
        """Parameters and provenance as a JSON-serialisable dict (dt s, PGA m/s², source, processing)."""
        return {
            "type": "Record",
            "name": self.name,
            "npts": self.npts,
            "dt": self.dt,
            "t0": self.t0,
            "duration": self.duration,
            "source": self.source,
            "sha256": self.sha256,
            "units": self.units,
            "header": self.header,
            "metadata": self.metadata,
        }


# ---------------------------------------------------------------------------
# PEER .AT2
# ---------------------------------------------------------------------------
_KW_NPTS = re.compile(r"NPTS\s*=\s*([^\s,]+)", re.IGNORECASE)
_KW_DT = re.compile(r"DT\s*=\s*([^\s,]+)", re.IGNORECASE)
_AT2_FORMATS = "'NPTS= <n>, DT= <dt> SEC' (NGA-West2) or '<n> <dt> [NPTS, DT]' (old NGA)"


def _read_text(path: Path) -> tuple[list[str], str]:
    raw = path.read_bytes()
    return raw.decode("latin-1").splitlines(), hashlib.sha256(raw).hexdigest()


def _parse_at2_line4(path: Path, line: str) -> tuple[int, float]:
    m_n, m_dt = _KW_NPTS.search(line), _KW_DT.search(line)
    if m_n or m_dt:
        if not (m_n and m_dt):
            raise MotionFileError(
                f"found {line.strip()!r}; expected both NPTS and DT, as {_AT2_FORMATS}", path, 4
            )
        tok_n, tok_dt = m_n.group(1), m_dt.group(1)
    else:
        toks = re.split(r"[\s,]+", line.strip())
        if len(toks) < 2:
            raise MotionFileError(f"found {line.strip()!r}; expected {_AT2_FORMATS}", path, 4)
        tok_n, tok_dt = toks[0], toks[1]
    n, dt = _number(tok_n), _number(tok_dt)
    if n is None or dt is None:
        raise MotionFileError(f"found {line.strip()!r}; expected {_AT2_FORMATS}", path, 4)
    if not float(n).is_integer() or n <= 0:
        raise MotionFileError(f"NPTS = {tok_n!r}; expected a positive integer", path, 4)
    if not (math.isfinite(dt) and dt > 0):
        raise MotionFileError(f"DT = {tok_dt!r}; expected a positive time step in s", path, 4)
    return int(n), dt


def _parse_values(path: Path, lines: list[str], first: int) -> tuple[Arr, list[int]]:
    """Numbers from lines[first:]; returns values and the 1-based line of each."""
    values: list[float] = []
    where: list[int] = []
    for i in range(first, len(lines)):
        for tok in re.split(r"[\s,]+", lines[i].strip()):
            if not tok:
                continue
            x = _number(tok)
            if x is None or not math.isfinite(x):
                raise MotionFileError(f"found non-numeric value {tok!r}; expected a real number", path, i + 1)
            values.append(x)
            where.append(i + 1)
    return np.asarray(values, dtype=float), where


def read_at2(path: str | Path) -> Record:
    """Read a PEER NGA ``.AT2`` acceleration file.

    Header: 4 lines (title; event/station/component; units; NPTS and DT).  Line 4
    is either NGA-West2 ``NPTS=  5590, DT=   .0050 SEC`` (any case/spacing, keys
    in any order) or old NGA ``5590   0.0050  NPTS, DT``.  Data: any number of
    values per line, Fortran reals (``-.1234E-02``, ``1.2D-03``).

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    Record
        Acceleration converted from g to m/s² with :data:`G_STANDARD`;
        ``name`` is header line 2, ``units`` is ``"g"``.

    Raises
    ------
    MotionFileError
        Truncated header, bad line 4, NPTS ≤ 0, DT ≤ 0, a non-numeric value,
        non-g units on line 3, or a value count different from NPTS.
    """
    path = Path(path)
    lines, digest = _read_text(path)
    if len(lines) < 4:
        raise MotionFileError(
            f"truncated header: found {len(lines)} line(s); expected at least 4 header lines", path
        )
    units_m = re.search(r"UNITS\s+OF\s+(\S+)", lines[2], re.IGNORECASE)
    if units_m and units_m.group(1).upper() != "G":
        raise MotionFileError(
            f"found units {units_m.group(1)!r}; expected acceleration in units of G", path, 3
        )
    npts, dt = _parse_at2_line4(path, lines[3])
    values, _ = _parse_values(path, lines, 4)
    if values.size < npts:
        raise MotionFileError(
            f"truncated data: header declares NPTS={npts} but only {values.size} values were found", path
        )
    if values.size > npts:
        raise MotionFileError(f"header declares NPTS={npts} but {values.size} values were found", path)
    if npts < 2:
        raise MotionFileError(f"NPTS={npts}; expected at least 2 samples", path, 4)
    return Record(
        values * G_STANDARD, dt, name=lines[1].strip(), source=str(path),
        header="\n".join(lines[:4]), units="g", sha256=digest,
    )  # fmt: skip


def write_at2(record: Record, path: str | Path, header: str | None = None) -> Path:
    """Write a record as an NGA-West2 style ``.AT2`` file (units g, 5 values/line, ``%15.7E``).

    Parameters
    ----------
    record : Record
        Must start at t0 = 0 (the format has no start-time field).
    path : str or Path
    header : str, optional
        Text of header line 2 (event/station/component); default ``record.name``.

    Returns
    -------
    Path
        The written file.
    """
    if record.t0 != 0.0:
        raise ValueError(f"AT2 has no start-time field; record.t0 must be 0 s, got {record.t0!r}")
    header = record.name if header is None else header
    if "\n" in header or "\r" in header:
        raise ValueError("header must be a single line (it becomes line 2 of the AT2 file)")
    g = record.acc / G_STANDARD
    rows = ["".join(f"{x:15.7E}" for x in g[i : i + 5]) for i in range(0, g.size, 5)]
    text = [
        "PEER NGA STRONG MOTION DATABASE RECORD",
        header,
        "ACCELERATION TIME SERIES IN UNITS OF G",
        f"NPTS= {record.npts:7d}, DT= {record.dt!r} SEC",
        *rows,
    ]
    path = Path(path)
    path.write_text("\n".join(text) + "\n", encoding="ascii", errors="replace")
    return path


# ---------------------------------------------------------------------------
# plain tables
# ---------------------------------------------------------------------------
def _column_index(
    which: int | str, names: list[str], ncols: int, path: Path, key: str, header_line: int | None
) -> int:
    if isinstance(which, str):
        if not names:
            raise MotionFileError(
                f"{key} = {which!r} names a column but the file has no header row of column names; "
                "give a 0-based column index",
                path,
            )
        if which not in names:
            raise MotionFileError(
                f"{key} = {which!r}: no such column; the header names {', '.join(map(repr, names))}",
                path,
                header_line,
            )
        return names.index(which)
    if not (0 <= int(which) < ncols):
        raise MotionFileError(f"{key} = {which} requested but the file has {ncols} column(s)", path)
    return int(which)


def read_table(
    path: str | Path,
    dt: float | None = None,
    units: str = "m/s2",
    column: int | str | None = None,
    time_column: int | str | None = "auto",
) -> Record:
    """Read a text table of acceleration.

    Text after ``#`` or ``%`` is a comment; values are separated by whitespace, commas and/or
    semicolons. A first row of only non-numeric tokens is taken as the column names.
    Layouts:

    * one column: acceleration; ``dt`` is required.
    * two columns (``column=None``): time (s), acceleration.  dt is read from
      the time column, which must be uniform within 1e-6 relative; if ``dt``
      is also given it must agree with it.  t0 is the first time (≥ 0).
    * ``column=j`` (0-based index, or a header name): the acceleration column. With
      ``time_column="auto"``, column 0 is time when j > 0; with j == 0 ``dt`` is required.
    * ``time_column`` (index or header name): the time column; ``None``: no time column
      (``dt`` required).

    Parameters
    ----------
    path : str or Path
    dt : float, s, optional
    units : {"m/s2", "g", "cm/s2"}
        Units of the acceleration column ("g" uses :data:`G_STANDARD`).
    column : int or str, optional
    time_column : int, str, None or "auto"

    Returns
    -------
    Record
        Acceleration in m/s², ``units`` records the file's units; ``metadata`` holds the
        column chosen, the time column and the header names.

    Raises
    ------
    MotionFileError
        Non-numeric value, ragged rows, fewer than 2 samples, missing dt, an unknown column
        name, non-uniform or non-increasing time, dt disagreeing with the file.
    ValueError
        Unknown ``units`` or invalid ``dt`` argument.
    """
    if units not in UNITS:
        raise ValueError(f"units must be one of {sorted(UNITS)}, got {units!r}")
    if dt is not None and not (math.isfinite(dt) and dt > 0):
        raise ValueError(f"dt must be a positive finite time step in s, got {dt!r}")
    path = Path(path)
    lines, digest = _read_text(path)
    rows: list[list[float]] = []
    rowline: list[int] = []
    names: list[str] = []
    header_line: int | None = None
    comments: list[str] = []
    for i, line in enumerate(lines, 1):
        m = re.search(r"[#%]", line)
        body, comment = (line[: m.start()], line[m.end() :]) if m else (line, "")
        if comment.strip():
            comments.append(comment.strip())
        toks = [t for t in re.split(r"[\s,;]+", body.strip()) if t]
        if not toks:
            continue
        vals = [_number(t) for t in toks]
        if not rows and not names and all(v is None for v in vals):
            names, header_line = toks, i
            continue
        for t, v in zip(toks, vals, strict=True):
            if v is None or not math.isfinite(v):
                raise MotionFileError(f"found non-numeric value {t!r}; expected a real number", path, i)
        if rows and len(vals) != len(rows[0]):
            raise MotionFileError(
                f"found {len(vals)} columns; expected {len(rows[0])} as on line {rowline[0]}", path, i
            )
        rows.append(vals)  # type: ignore[arg-type]
        rowline.append(i)
    if len(rows) < 2:
        raise MotionFileError(f"found {len(rows)} data row(s); expected at least 2 samples", path)
    data = np.asarray(rows, dtype=float)
    ncols = data.shape[1]
    if names and len(names) != ncols:
        raise MotionFileError(
            f"the header row has {len(names)} names but the data have {ncols} columns", path, header_line
        )
    if column is None:
        if ncols > 2:
            raise MotionFileError(
                f"found {ncols} columns; expected 1 or 2 (give column = <header name or index> to choose one)",
                path,
            )
        column = ncols - 1
    col = _column_index(column, names, ncols, path, "column", header_line)
    if time_column == "auto":
        tcol: int | None = 0 if col > 0 else None
    elif time_column is None:
        tcol = None
    else:
        tcol = _column_index(time_column, names, ncols, path, "time_column", header_line)
        if tcol == col:
            raise MotionFileError(f"time_column and column are the same column ({col})", path)
    t0 = 0.0
    if tcol is None:
        if dt is None:
            raise MotionFileError(
                "no time column and no dt given; give dt (s) for a table without a time column", path
            )
        step = dt
    else:
        t = data[:, tcol]
        steps = np.diff(t)
        step = (t[-1] - t[0]) / (t.size - 1)
        if not step > 0:
            raise MotionFileError(
                f"time column runs from {t[0]} to {t[-1]} s; expected increasing times", path
            )
        bad = np.flatnonzero(np.abs(steps - step) > 1e-6 * step)
        if bad.size:
            # the first step that differs from the typical (median) step is where the file goes wrong;
            # the mean step would flag the first row of any record with one gap
            typical = float(np.median(steps))
            off = np.flatnonzero(np.abs(steps - typical) > 1e-6 * abs(typical))
            j = int(off[0] if off.size else bad[0]) + 1
            raise MotionFileError(
                f"non-uniform time step: t={float(t[j])!r} s after t={float(t[j - 1])!r} s "
                f"(step {float(steps[j - 1]):.6g} s); expected uniform dt={typical:.6g} s within 1e-6 relative",
                path, rowline[j],
            )  # fmt: skip
        if dt is not None and abs(dt - step) > 1e-6 * step:
            raise MotionFileError(f"time column has dt={float(step)!r} s but dt={dt!r} s was given", path)
        if t[0] < 0:
            raise MotionFileError(
                f"time column starts at {float(t[0])!r} s; expected a start time >= 0", path, rowline[0]
            )
        t0 = float(t[0])
    return Record(
        data[:, col] * UNITS[units], step, t0, name=path.stem, source=str(path),
        header="\n".join([" ".join(names), *comments]).strip(), units=units, sha256=digest,
        metadata={"column": col, "time_column": tcol, "columns": names},
    )  # fmt: skip


def write_table(record: Record, path: str | Path, units: str = "g", comment: str = "") -> Path:
    """Write ``record`` as a text table with a header row ``time_s acc_<units>`` (``%.9g``).

    ``comment`` lines are written first, each prefixed with ``#``. Read it back with
    ``read_table(path, units=units)``.
    """
    if units not in UNITS:
        raise ValueError(f"units must be one of {sorted(UNITS)}, got {units!r}")
    lines = [f"# {c}" for c in comment.splitlines()] + [f"time_s acc_{units.replace('/', '_')}"]
    lines += [f"{t:.6f} {a:.9g}" for t, a in zip(record.time, record.acc / UNITS[units], strict=True)]
    path = Path(path)
    path.write_text("\n".join(lines) + "\n", encoding="ascii")
    return path


def read_npz(
    path: str | Path,
    array: str | None = None,
    dt: float | None = None,
    dt_array: str | None = None,
    units: str = "m/s2",
) -> Record:
    """Read one acceleration array of a NumPy ``.npz`` archive.

    Parameters
    ----------
    array : name of the (n,) acceleration array; may be omitted when the archive holds one array.
    dt : sample interval (s), or ``dt_array``: the name of a scalar array holding it.
    units : {"m/s2", "g", "cm/s2"}

    Raises
    ------
    MotionFileError
        Unknown array names, a non-1-D or non-finite array, a missing or bad dt.
    """
    if units not in UNITS:
        raise ValueError(f"units must be one of {sorted(UNITS)}, got {units!r}")
    path = Path(path)
    raw = path.read_bytes()
    try:
        with np.load(path, allow_pickle=False) as z:
            keys = list(z.files)
            if array is None:
                if len(keys) != 1:
                    raise MotionFileError(
                        f"holds {len(keys)} arrays; give array = <name> (e.g. {keys[:3]!r})", path
                    )
                array = keys[0]
            if array not in keys:
                near = [k for k in keys if k.split("_")[0] == array.split("_")[0]][:4] or keys[:4]
                raise MotionFileError(f"no array {array!r}; arrays include {near!r}", path)
            a = np.asarray(z[array], dtype=np.float64)
            if dt_array is not None:
                if dt_array not in keys:
                    raise MotionFileError(f"no array {dt_array!r} (dt_array) in the archive", path)
                dtv = np.asarray(z[dt_array], dtype=np.float64)
                if dtv.size != 1:
                    raise MotionFileError(
                        f"dt_array {dt_array!r} has {dtv.size} values; expected one (s)", path
                    )
                if dt is not None and abs(float(dtv.reshape(-1)[0]) - dt) > 1e-9 * dt:
                    raise MotionFileError(
                        f"dt_array {dt_array!r} holds {float(dtv.reshape(-1)[0])!r} s but dt = {dt!r} s was given",
                        path,
                    )
                dt = float(dtv.reshape(-1)[0])
    except (OSError, ValueError) as exc:
        if isinstance(exc, MotionFileError):
            raise
        raise MotionFileError(f"cannot be read as a NumPy .npz archive ({exc})", path) from None
    if dt is None:
        raise MotionFileError("no dt given; give dt (s) or dt_array (the array holding dt)", path)
    if a.ndim != 1 or a.size < 2:
        raise MotionFileError(f"array {array!r} has shape {a.shape}; expected (n,) with n >= 2", path)
    if not np.all(np.isfinite(a)):
        raise MotionFileError(f"array {array!r} holds NaN or infinity", path)
    return Record(
        a * UNITS[units], dt, name=f"{path.stem}:{array}", source=str(path), units=units,
        sha256=hashlib.sha256(raw).hexdigest(), metadata={"array": array},
    )  # fmt: skip


FORMATS: dict[str, Callable[..., Record]] = {"at2": read_at2, "table": read_table, "npz": read_npz}


def read_record(path: str | Path, format: str = "auto", **kw: Any) -> Record:
    """Read a record, choosing the reader by ``format`` (``"at2"``, ``"table"``, ``"npz"`` or ``"auto"``).

    ``"auto"`` picks ``at2`` for a ``.at2`` extension (any case), ``npz`` for ``.npz``, else ``table``.
    Extra keywords go to the reader (e.g. ``dt``, ``units`` for tables).
    """
    if format == "auto":
        suffix = Path(path).suffix.lower()
        format = {".at2": "at2", ".npz": "npz"}.get(suffix, "table")
    if format not in FORMATS:
        raise ValueError(f"format must be 'auto' or one of {sorted(FORMATS)}, got {format!r}")
    return FORMATS[format](path, **kw)
