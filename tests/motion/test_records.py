"""Records: exact integration, AT2 and table readers, errors."""

from __future__ import annotations

import hashlib
import json

import numpy as np
import pytest

from pbr_xval.motion import G_STANDARD, MotionFileError, Record, read_at2, read_record, read_table, write_at2


# ---------------------------------------------------------------- Record
def test_constant_record_exact_integrals():
    c, dt, t0, n = 1.7, 0.01, 0.5, 101  # samples on [0.5, 1.5]
    r = Record(np.full(n, c), dt, t0)
    t = np.array([0.5, 0.5123, 0.987654, 1.5])
    np.testing.assert_allclose(r.acceleration(t), c, rtol=1e-14)
    np.testing.assert_allclose(r.velocity(t), c * (t - t0), rtol=1e-12)
    np.testing.assert_allclose(r.displacement(t), c * (t - t0) ** 2 / 2, rtol=1e-12)
    # outside: at rest before t0, a = 0 and v constant, d linear after the end
    assert r.acceleration(0.3) == 0.0 and r.velocity(0.3) == 0.0 and r.displacement(0.3) == 0.0
    assert r.acceleration(2.0) == 0.0
    assert r.velocity(2.0) == pytest.approx(c * 1.0)
    assert r.displacement(2.0) == pytest.approx(c / 2 + c * 0.5)


def test_linear_record_exact_integrals():
    k, dt, n = 3.0, 0.02, 51  # a = k t on [0, 1]; cubic d is reproduced exactly
    tk = dt * np.arange(n)
    r = Record(k * tk, dt)
    t = np.random.default_rng(1).uniform(0, 1, 200)
    np.testing.assert_allclose(r.acceleration(t), k * t, rtol=1e-12)
    np.testing.assert_allclose(r.velocity(t), k * t**2 / 2, rtol=1e-12)
    np.testing.assert_allclose(r.displacement(t), k * t**3 / 6, rtol=1e-11)


def test_piecewise_linear_interpolation_and_peaks():
    r = Record([0.0, 2.0, -1.0, 0.0], 0.5)
    assert r.acceleration(0.25) == pytest.approx(1.0)
    assert r.acceleration(0.75) == pytest.approx(0.5)
    assert r.acceleration(np.array([1.25])) == pytest.approx([-0.5])
    assert r.duration == 1.5 and r.npts == 4 and r.breakpoints == (0.0, 1.5)
    assert r.pga == 2.0
    t = np.linspace(0, 1.5, 300001)
    assert r.pgv == pytest.approx(np.max(np.abs(r.velocity(t))), rel=1e-9)


def test_record_validation_and_scaling():
    with pytest.raises(ValueError, match="dt"):
        Record([1.0, 2.0], 0.0)
    with pytest.raises(ValueError, match="at least 2"):
        Record([1.0], 0.1)
    r = Record([0.0, 1.0, 0.0], 0.1).scaled(-2.0)
    assert isinstance(r, Record)
    np.testing.assert_array_equal(r.acc, [0.0, -2.0, 0.0])
    json.dumps(r.describe())


# ---------------------------------------------------------------- AT2
AT2_WEST2 = """PEER NGA STRONG MOTION DATABASE RECORD
Imperial Valley-06, 10/15/1979, El Centro Array #6, 230
ACCELERATION TIME SERIES IN UNITS OF G
NPTS=     7, DT=   .0050 SEC
  .1000000E-02  -.2000000E-02   .3000000E-02   .4000000E-02  -.5000000E-02
  1.0D-03 -2.5E-03
"""

AT2_OLD = """PEER STRONG MOTION DATABASE RECORD. PROCESSING BY PACIFIC ENGINEERING.
IMPERIAL VALLEY 10/15/79 2316, EL CENTRO ARRAY #6, 230
ACCELERATION TIME HISTORY IN UNITS OF G
   7    .00500   NPTS, DT
 .10000E-02 -.20000E-02  .30000E-02  .40000E-02 -.50000E-02  .10000E-02 -.25000E-02
"""
EXPECTED_G = np.array([1e-3, -2e-3, 3e-3, 4e-3, -5e-3, 1e-3, -2.5e-3])


@pytest.mark.parametrize("text", [AT2_WEST2, AT2_OLD], ids=["nga_west2", "old_nga"])
def test_read_at2_header_variants(tmp_path, text):
    p = tmp_path / "RSN181.AT2"
    p.write_text(text)
    r = read_at2(p)
    assert r.npts == 7 and r.dt == 0.005
    np.testing.assert_allclose(r.acc, EXPECTED_G * 9.80665, rtol=1e-15)
    assert "El Centro Array #6".upper() in r.name.upper()
    d = r.describe()
    assert d["sha256"] == hashlib.sha256(p.read_bytes()).hexdigest()
    assert d["units"] == "g" and d["source"] == str(p)
    json.dumps(d)


def test_read_at2_lowercase_trailing_comma(tmp_path):
    p = tmp_path / "x.at2"
    p.write_text("a\nb\nACCELERATION TIME SERIES IN UNITS OF G\nnpts= 3, dt= 0.01 sec,\n1 2 3\n")
    r = read_record(p)  # auto: .at2 (lower case) -> AT2 reader
    assert r.npts == 3 and r.dt == 0.01 and r.acc[2] == pytest.approx(3 * G_STANDARD)


def test_at2_round_trip(tmp_path):
    rng = np.random.default_rng(7)
    acc = rng.normal(0, 2.0, 1003) * np.logspace(-3, 0, 1003)
    r = Record(acc, 0.0123456789, name="Synthetic, station X, HNE")
    p = write_at2(r, tmp_path / "syn.AT2")
    lines = p.read_text().splitlines()
    assert len(lines[4].split()) == 5 and len(lines[4]) == 75
    back = read_at2(p)
    assert back.dt == r.dt  # exact
    assert back.npts == r.npts and back.name == r.name
    np.testing.assert_allclose(back.acc, acc, rtol=1e-7)  # %15.7E = 8 significant digits


def _write(tmp_path, name, text):
    p = tmp_path / name
    p.write_text(text)
    return p


HDR = "TITLE\nSTATION\nACCELERATION TIME SERIES IN UNITS OF G\n"


@pytest.mark.parametrize(
    ("body", "facts"),
    [
        ("TITLE\nSTATION\n", ["2 line", "4 header lines"]),
        (HDR + "NPTS=  6, DT= .01 SEC\n1 2 3\n4 5\n", ["NPTS=6", "5 values", "truncated"]),
        (HDR + "NPTS=  4, DT= .01 SEC\n1 2 3\n4 5\n", ["NPTS=4", "5 values"]),
        (HDR + "NPTS=  5, DT= .01 SEC\n1 2 3\n4 x5y\n", ["line 6", "'x5y'"]),
        (HDR + "NPTS=  5, DT= 0.0 SEC\n1 2 3 4 5\n", ["line 4", "DT", "positive"]),
        (HDR + "NPTS=  5, DT= -0.01 SEC\n1 2 3 4 5\n", ["line 4", "DT"]),
        (HDR + "NPTS=  0, DT= 0.01 SEC\n", ["line 4", "NPTS", "positive integer"]),
        (HDR + "NPTS=  -5, DT= 0.01 SEC\n", ["line 4", "NPTS"]),
        (HDR + "hello world\n1 2\n", ["line 4", "'hello world'", "NPTS= <n>, DT= <dt>"]),
        (HDR + "NPTS= 5\n1 2 3 4 5\n", ["line 4", "DT"]),
        ("T\nS\nVELOCITY TIME SERIES IN UNITS OF CM/SEC\nNPTS= 2, DT= .01 SEC\n1 2\n", ["line 3", "CM/SEC"]),
    ],
    ids=["short_header", "too_few", "too_many", "token", "dt_zero", "dt_neg", "npts_zero", "npts_neg",
         "bad_line4", "missing_dt", "velocity_units"],
)  # fmt: skip
def test_at2_errors(tmp_path, body, facts):
    p = _write(tmp_path, "bad_record.AT2", body)
    with pytest.raises(MotionFileError) as exc:
        read_at2(p)
    msg = str(exc.value)
    assert "bad_record.AT2" in msg
    for fact in facts:
        assert fact in msg, (fact, msg)


# ---------------------------------------------------------------- tables
def test_table_one_column_with_dt(tmp_path):
    p = _write(tmp_path, "a.txt", "# acceleration in m/s2\n0.0\n1.5  # peak\n% matlab comment\n-0.5\n")
    r = read_table(p, dt=0.02)
    np.testing.assert_array_equal(r.acc, [0.0, 1.5, -0.5])
    assert r.dt == 0.02 and r.t0 == 0.0 and r.units == "m/s2"


def test_table_two_columns_dt_from_file(tmp_path):
    t = 0.25 + 0.005 * np.arange(50)
    a = np.sin(t)
    p = tmp_path / "two.csv"
    p.write_text("time,acc\n" + "\n".join(f"{ti:.6f}, {ai:.9e}" for ti, ai in zip(t, a, strict=True)))
    r = read_record(p)
    assert r.dt == pytest.approx(0.005, rel=1e-12) and r.t0 == pytest.approx(0.25)
    np.testing.assert_allclose(r.acc, a, rtol=1e-8)
    assert read_table(p, dt=0.005).npts == 50  # agreeing dt is accepted
    with pytest.raises(MotionFileError, match=r"two\.csv.*dt=0\.01"):
        read_table(p, dt=0.01)


def test_table_nonuniform_time(tmp_path):
    p = _write(tmp_path, "nu.txt", "# t a\n0.0 1\n0.1 2\n0.2 3\n0.31 4\n0.4 5\n")
    with pytest.raises(MotionFileError) as exc:
        read_table(p)
    msg = str(exc.value)
    assert "nu.txt" in msg and "line 5" in msg and "non-uniform" in msg


def test_table_missing_dt(tmp_path):
    p = _write(tmp_path, "one.txt", "1\n2\n3\n")
    with pytest.raises(MotionFileError, match=r"one\.txt.*dt"):
        read_table(p)


@pytest.mark.parametrize(("units", "factor"), [("m/s2", 1.0), ("g", 9.80665), ("cm/s2", 0.01)])
def test_table_units(tmp_path, units, factor):
    p = _write(tmp_path, "u.txt", "1.0\n-2.0\n")
    r = read_table(p, dt=0.01, units=units)
    np.testing.assert_allclose(r.acc, np.array([1.0, -2.0]) * factor, rtol=1e-15)
    assert r.units == units


def test_table_errors(tmp_path):
    p = _write(tmp_path, "tok.txt", "0 1\n0.1 abc\n")
    with pytest.raises(MotionFileError, match=r"tok\.txt, line 2.*'abc'"):
        read_table(p)
    p = _write(tmp_path, "ragged.txt", "0 1\n0.1 2 3\n")
    with pytest.raises(MotionFileError, match=r"ragged\.txt, line 2.*3 columns"):
        read_table(p)
    with pytest.raises(ValueError, match="units"):
        read_table(p, dt=0.1, units="ft/s2")
