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


# ---------------------------------------------------------------- lab tables, npz, corrections
from pathlib import Path  # noqa: E402

from pbr_xval.motion.processing import (  # noqa: E402
    baseline_correct,
    butterworth,
    project_components,
)
from pbr_xval.motion.records import read_npz, write_table  # noqa: E402

SHAKE = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "shake_table"


def test_table_with_header_names_time_column_and_semicolons(tmp_path):
    p = tmp_path / "lab.csv"
    t = 0.005 * np.arange(6)
    rows = "\n".join(
        f"{a};{ti:.3f};{b};{c}" for ti, a, b, c in zip(t, [1, 2, 3, 4, 5, 6], -t, 2 * t, strict=True)
    )
    p.write_text("# shake table run 12, channel map below\nax;time;ay;az\n" + rows + "\n")
    r = read_table(p, units="cm/s2", column="az", time_column="time")
    np.testing.assert_allclose(r.acc, 0.01 * 2 * t, rtol=1e-12)
    assert r.dt == pytest.approx(0.005) and r.metadata["columns"] == ["ax", "time", "ay", "az"]
    r2 = read_table(p, units="g", column=0, time_column="time")
    np.testing.assert_allclose(r2.acc, G_STANDARD * np.arange(1, 7), rtol=1e-14)
    with pytest.raises(
        MotionFileError, match=r"column = 'acc': no such column; the header names 'ax', 'time'"
    ):
        read_table(p, units="g", column="acc", time_column="time")
    with pytest.raises(MotionFileError, match="found 4 columns; expected 1 or 2"):
        read_table(p, units="g")
    q = tmp_path / "noheader.txt"
    q.write_text("0 1 2\n0.1 3 4\n")
    with pytest.raises(MotionFileError, match="no header row"):
        read_table(q, units="g", column="az")


def test_write_table_round_trip(tmp_path):
    r = Record(np.sin(np.arange(50) * 0.3), 0.01)
    p = write_table(r, tmp_path / "r.txt", units="g", comment="synthetic\nsecond line")
    back = read_table(p, units="g")
    np.testing.assert_allclose(back.acc, r.acc, rtol=1e-8, atol=1e-12)
    assert back.dt == pytest.approx(0.01, rel=1e-9)


def test_npz_reader_errors(tmp_path):
    p = tmp_path / "m.npz"
    np.savez(p, run1_acc=np.array([0.0, 0.1, -0.2]), run1_dt=np.array(0.01), bad=np.zeros((2, 2)))
    r = read_npz(p, array="run1_acc", dt_array="run1_dt", units="g")
    np.testing.assert_allclose(r.acc, G_STANDARD * np.array([0.0, 0.1, -0.2]))
    assert r.dt == 0.01 and read_record(p, array="run1_acc", dt=0.01, units="g").npts == 3
    with pytest.raises(MotionFileError, match="no array 'run2_acc'"):
        read_npz(p, array="run2_acc", dt=0.01)
    with pytest.raises(MotionFileError, match="holds 3 arrays; give array"):
        read_npz(p, dt=0.01)
    with pytest.raises(MotionFileError, match="no dt given"):
        read_npz(p, array="run1_acc")
    with pytest.raises(MotionFileError, match=r"shape \(2, 2\)"):
        read_npz(p, array="bad", dt=0.01)


def test_baselines_remove_exactly_what_they_fit():
    """An offset, a line and a parabola are removed exactly by mean, linear and polynomial(2)."""
    dt, n = 0.01, 501
    t = dt * np.arange(n)
    for kind, a, order in (
        ("mean", 0.3 + 0 * t, 2),
        ("linear", 0.3 - 0.2 * t, 2),
        ("polynomial", 0.3 - 0.2 * t + 0.05 * t**2, 2),
    ):
        out = baseline_correct(Record(a, dt), kind, order)
        assert np.max(np.abs(out.acc)) < 1e-12, kind
        assert out.metadata["processing"][-1]["kind"] == kind
    # a polynomial of order 1 leaves the parabola's residual (closed form: 0.05·(t² − LS line))
    a = 0.05 * t**2
    res = baseline_correct(Record(a, dt), "polynomial", 1).acc
    line = np.polyval(np.polyfit(t, a, 1), t)
    np.testing.assert_allclose(res, a - line, atol=1e-12)


def test_butterworth_band_pass_matches_the_closed_form_gain_and_keeps_phase():
    """Sines at 0.05, 2 and 60 Hz through a 0.5–20 Hz order-4 band-pass: the zero-phase gain is
    |H|² with |H|² = 1/(1 + (f/f_c)^±8) per corner (closed form), the 2 Hz sine keeps its phase."""
    dt = 1 / 400
    t = dt * np.arange(int(60 / dt))
    parts = {f: np.sin(2 * np.pi * f * t) for f in (0.05, 2.0, 60.0)}
    rec = Record(sum(parts.values()), dt)
    out = butterworth(rec, 0.5, 20.0, order=4, zero_phase=True)
    mid = slice(len(t) // 4, 3 * len(t) // 4)
    freqs = list(parts)

    def fit(y):  # least-squares sine and cosine amplitudes at the three frequencies (mid window)
        cols = [g(2 * np.pi * f * t[mid]) for f in freqs for g in (np.sin, np.cos)]
        return np.linalg.lstsq(np.column_stack(cols), y[mid], rcond=None)[0].reshape(-1, 2)

    coef = fit(out.acc)
    for f, (s_amp, c_amp) in zip(freqs, coef, strict=True):
        gain = 1 / (1 + (0.5 / f) ** 8) / (1 + (f / 20.0) ** 8)
        assert s_amp == pytest.approx(gain, abs=2e-3), f
        assert abs(c_amp) < 2e-3, f  # zero phase: no quadrature part
    # causal filtering lags: a quadrature part appears at 2 Hz
    assert abs(fit(butterworth(rec, 0.5, 20.0, order=4, zero_phase=False).acc)[1, 1]) > 0.05
    assert out.metadata["processing"][-1]["zero_phase"] is True
    with pytest.raises(ValueError, match="Nyquist"):
        butterworth(rec, 0.5, 250.0)


def test_two_components_recover_a_motion_along_any_direction():
    """A motion a(t) along ψ0 = 50° recorded as H1 = a cos ψ0 (0°), H2 = a sin ψ0 (90°) is recovered
    along 50° exactly, with nothing perpendicular; along 20° it is a·cos 30°."""
    dt = 0.01
    a = np.sin(np.linspace(0, 20, 400)) * np.exp(-np.linspace(0, 3, 400))
    psi0 = np.radians(50.0)
    h1, h2 = Record(a * np.cos(psi0), dt, name="H1"), Record(a * np.sin(psi0), dt, name="H2")
    along = project_components(h1, 0.0, h2, 90.0, 50.0)
    np.testing.assert_allclose(along.acc, a, atol=1e-14)
    assert along.metadata["processing"][-1]["dropped_perpendicular_pga_m_s2"] < 1e-14
    np.testing.assert_allclose(
        project_components(h1, 0.0, h2, 90.0, 20.0).acc, a * np.cos(np.radians(30)), atol=1e-14
    )
    with pytest.raises(ValueError, match="share dt"):
        project_components(h1, 0.0, Record(a, 0.02), 90.0, 0.0)


@pytest.mark.skipif(not SHAKE.is_dir(), reason=f"shake-table data not found at {SHAKE}")
def test_shake_table_records_corrected_match_the_lab_sheet_pga():
    """The 196 raw table records (800 Hz, g, with a ~0.017 g offset) overstate the lab sheet's PGA
    (measured: median ratio 1.136, mean |ln ratio| 0.19); mean removal + a zero-phase 0.1–25 Hz
    order-4 band-pass brings them onto it (measured: median 1.0085, mean |ln ratio| 0.057)."""
    import csv

    with (SHAKE / "experiments.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    raw, cor = [], []
    for r in rows:
        k = f"test{int(r['test']):03d}"
        rec = read_npz(SHAKE / "table_motions.npz", array=f"{k}_acc_g", dt_array=f"{k}_dt_s", units="g")
        sheet = float(r["pga_g"]) * G_STANDARD
        raw.append(rec.pga / sheet)
        cor.append(butterworth(baseline_correct(rec, "mean"), 0.1, 25.0, 4, True).pga / sheet)
    raw_err, cor_err = np.mean(np.abs(np.log(raw))), np.mean(np.abs(np.log(cor)))
    assert np.median(cor) == pytest.approx(1.0, abs=0.02)
    assert cor_err < 0.08 and cor_err < 0.5 * raw_err


def test_record_scenario_keys_two_components_corrections_and_provenance(tmp_path):
    """A lab table (header, time column, cm/s², offset) as H1 at 0° and H2 at 90°, shaken along
    30°: the scene's motion is cos 30°·H1 + sin 30°·H2 after mean removal, recorded step by step."""
    from pbr_xval.scenario import ScenarioError, scenario_from_dict
    from pbr_xval.scene import compile_scene

    dt = 0.01
    t = dt * np.arange(300)
    a1 = 80.0 * np.sin(2 * np.pi * t) * np.exp(-t)  # cm/s²
    a2 = 50.0 * np.sin(2 * np.pi * 1.5 * t)
    (tmp_path / "lab.csv").write_text(
        "time,h1,h2\n"
        + "\n".join(f"{ti:.2f},{x + 3.0:.9f},{y - 2.0:.9f}" for ti, x, y in zip(t, a1, a2, strict=True))
    )
    exc = {
        "type": "record",
        "path": "lab.csv",
        "units": "cm/s2",
        "time_column": "time",
        "column": "h1",
        "component_azimuth_deg": 0.0,
        "second": {
            "path": "lab.csv",
            "units": "cm/s2",
            "time_column": "time",
            "column": "h2",
            "component_azimuth_deg": 90.0,
        },
        "baseline": "mean",
        "azimuth_deg": 30.0,
    }
    data = {
        "name": "lab",
        "duration": 3.0,
        "rock": {"shape": "box", "half_extents": [0.2, 0.2, 0.6], "density": 2400.0},
        "excitation": exc,
    }
    scene = compile_scene(scenario_from_dict(data, source=tmp_path / "s.toml"))
    rec = scene.excitation.horizontal
    c, s = np.cos(np.radians(30)), np.sin(np.radians(30))
    expected = 0.01 * (c * (a1 - a1.mean()) + s * (a2 - a2.mean()))
    np.testing.assert_allclose(rec.acc, expected, atol=1e-9)
    steps = scene.info()["excitation"]["horizontal"]["metadata"]["processing"]
    assert [st["step"] for st in steps] == ["baseline", "rotation"]
    assert steps[0]["removed_mean_m_s2"] == pytest.approx(0.03 + 0.01 * a1.mean(), rel=1e-6)
    # units are stated, never guessed; a missing one names its key
    del data["excitation"]["second"]["units"]
    with pytest.raises(ScenarioError, match=r"key 'excitation\.second\.units': (Value error, )?missing"):
        scenario_from_dict(data)
    data["excitation"]["second"]["units"] = "cm/s2"
    data["excitation"]["second"]["column"] = "h3"
    with pytest.raises(
        ScenarioError, match=r"key 'excitation\.second\.path': .*column = 'h3': no such column"
    ):
        compile_scene(scenario_from_dict(data, source=tmp_path / "s.toml"))


# ---------------------------------------------------------------- the example sample record
EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def test_example_sample_record_files_agree_and_are_baseline_corrected():
    """The committed AT2 (g) and text table (cm/s²) hold the same record, the one the generator
    makes; its final velocity and displacement vanish by an independent trapezoidal integration
    (measured: |v_end| 1e-15 m/s, |d_end| 1e-7 m against a peak displacement of 0.16 m)."""
    from scipy.integrate import cumulative_trapezoid

    from pbr_xval.motion.processing import synthetic_accelerogram

    at2 = read_record(EXAMPLES / "records" / "synthetic_accelerogram.AT2")
    txt = read_record(
        EXAMPLES / "records" / "synthetic_accelerogram.txt",
        units="cm/s2",
        time_column="time_s",
        column="acc_cm_s2",
    )
    gen = synthetic_accelerogram(seed=2026)
    assert at2.npts == txt.npts == gen.npts == 1001 and at2.dt == txt.dt == gen.dt == 0.01
    np.testing.assert_allclose(at2.acc, gen.acc, atol=1e-7 * G_STANDARD)  # AT2 prints 8 significant digits
    np.testing.assert_allclose(txt.acc, gen.acc, atol=1e-10)
    assert gen.pga == pytest.approx(0.3 * G_STANDARD, rel=1e-12)
    v = cumulative_trapezoid(at2.acc, dx=at2.dt, initial=0.0)
    d = cumulative_trapezoid(v, dx=at2.dt, initial=0.0)
    assert abs(v[-1]) < 1e-5 and abs(d[-1]) < 1e-4 * np.max(np.abs(d))


def test_example_record_scenario_compiles_at_its_target_pga():
    from pbr_xval.scenario import load_scenario
    from pbr_xval.scene import compile_scene

    scn = load_scenario(EXAMPLES / "records" / "record_scenario.toml")
    scene = compile_scene(scn)
    assert scene.excitation.horizontal.pga == pytest.approx(4.0, rel=1e-12)
    assert scene.info()["excitation"]["horizontal"]["units"] == "g"


def test_example_record_below_the_uplift_bound_does_not_rock_the_rock():
    """Scaled to 90 % of the quasi-static uplift bound (geometry: g·ρ/h_G along ±x), the sample
    record leaves the example rock on its base in PyBullet: no tilt beyond contact noise
    (measured: max tilt 2.1e-4 rad at 0.9× — contact compliance — against 2.9e-2 rad at 1.3×)."""
    pytest.importorskip("pybullet")
    from pbr_xval.runner import run_scenario
    from pbr_xval.scenario import load_scenario
    from pbr_xval.scene import compile_scene

    scn = load_scenario(EXAMPLES / "records" / "record_scenario.toml")
    bound = compile_scene(scn).rock.stability.shaking_bound(0.0, scn.gravity)
    traj = run_scenario(scn.with_value("excitation.target_pga", 0.9 * bound), "pybullet", {})
    assert traj.ok and not traj.toppled
    assert float(np.max(traj.tilt())) < 1e-3
    steps = traj.scene_info["excitation"]["horizontal"]
    assert steps["units"] == "g" and steps["metadata"]["scale_factor"] > 0
