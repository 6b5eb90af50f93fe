"""Campaign input: the shared format, the general CSV form, every bad-input case, baseline correction."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pbr_xval.validation.campaign import (
    Baseline,
    CampaignError,
    baseline_correct,
    load_campaign,
    read_general_csv,
    record_pgv,
)

from .conftest import SHAKE_TABLE, box_campaign


def _shared(folder: Path, outcomes: list[str] | None = None, drop: str | None = None) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    outcomes = outcomes or ["0", "1"]
    lines = ["test,date,motion,pga_g,pgv_over_pga_s,toppled_specimen1,toppled_specimen2"]
    for i, o in zip((7, 12), outcomes, strict=True):
        lines.append(f"{i},20210621,REC{i}.xlsx,0.1,0.05,{o},0")
    (folder / "experiments.csv").write_text("\n".join(lines) + "\n")
    arrays = {}
    for i in (7, 12):
        arrays[f"test{i:03d}_acc_g"] = (0.02 + 0.1 * np.sin(np.arange(800) / 40.0)).astype(np.float32)
        arrays[f"test{i:03d}_dt_s"] = np.array(1 / 800)
    if drop:
        arrays.pop(drop)
    np.savez(folder / "table_motions.npz", **arrays)
    return folder


def test_shared_format_synthetic(tmp_path: Path) -> None:
    d = _shared(tmp_path / "c")
    c = load_campaign(d, 1)
    assert c.form == "shared" and [t.test for t in c.tests] == ["7", "12"]
    assert [t.toppled for t in c.tests] == [False, True]
    acc, dt = c.tests[1].raw_acceleration()
    assert dt == pytest.approx(1 / 800)
    # g → m/s² with standard gravity (float32 storage: 1e-6 relative)
    assert acc[0] == pytest.approx(0.02 * 9.80665, rel=1e-6)
    assert c.tests[0].sheet == {"pga_g": 0.1, "pgv_over_pga_s": 0.05}


@pytest.mark.skipif(not SHAKE_TABLE.is_dir(), reason="shared shake-table data not present")
def test_shared_format_real_campaign() -> None:
    # counts from the data's README: 196 tests, 76 toppled SP1, 69 toppled SP2, 28 records
    for specimen, toppled in ((1, 76), (2, 69)):
        c = load_campaign(SHAKE_TABLE, specimen)
        assert len(c) == 196
        assert sum(t.toppled for t in c.tests) == toppled
        assert len({t.motion for t in c.tests}) == 28
    acc, dt = c.tests[0].raw_acceleration()
    assert dt == pytest.approx(1 / 800)
    assert 10.0 <= acc.size * dt <= 73.0  # README: motions last 10–73 s


def test_general_csv_form(tmp_path: Path) -> None:
    csv, observed = box_campaign(tmp_path / "c")
    c = read_general_csv(csv, 1)
    assert c.form == "csv" and len(c) == 6
    assert [int(t.toppled) for t in c.tests] == observed
    acc, dt = c.tests[2].raw_acceleration()
    assert dt == pytest.approx(0.005) and acc[0] == pytest.approx(6.0)
    # units are applied as stated: the same file read as g is 9.80665× larger
    text = csv.read_text().replace("m/s2", "g")
    g_csv = csv.with_name("g.csv")
    g_csv.write_text(text)
    acc_g, _ = read_general_csv(g_csv, 1).tests[2].raw_acceleration()
    assert acc_g[0] == pytest.approx(6.0 * 9.80665)
    assert c.select(["2", "4"]).tests[1].test == "4"
    assert len(c.select(limit=3)) == 3


def _one_line(exc: pytest.ExceptionInfo[CampaignError]) -> str:
    msg = str(exc.value)
    assert "\n" not in msg
    return msg


def test_missing_motion(tmp_path: Path) -> None:
    d = _shared(tmp_path / "c", drop="test012_acc_g")
    with pytest.raises(CampaignError) as e:
        load_campaign(d, 1)
    msg = _one_line(e)
    assert "table_motions.npz" in msg and "test 12" in msg and "test012_acc_g" in msg
    csv, _ = box_campaign(tmp_path / "g")
    (csv.parent / "step_8.txt").unlink()
    with pytest.raises(CampaignError) as e:
        load_campaign(csv, 1)
    msg = _one_line(e)
    assert "campaign.csv" in msg and "test 4" in msg and "not found" in msg


def test_non_binary_outcome(tmp_path: Path) -> None:
    d = _shared(tmp_path / "c", outcomes=["0", "2"])
    with pytest.raises(CampaignError) as e:
        load_campaign(d, 1)
    msg = _one_line(e)
    assert "experiments.csv" in msg and "test 12" in msg and "'2'" in msg and "0 or 1" in msg
    csv, _ = box_campaign(tmp_path / "g")
    csv.write_text(csv.read_text().replace("step_6.txt,m/s2,0.005,1", "step_6.txt,m/s2,0.005,maybe"))
    with pytest.raises(CampaignError) as e:
        load_campaign(csv, 1)
    assert "test 3" in _one_line(e) and "'maybe'" in str(e.value)


def test_mismatched_specimen(tmp_path: Path) -> None:
    d = _shared(tmp_path / "c")
    with pytest.raises(CampaignError) as e:
        load_campaign(d, 3)
    msg = _one_line(e)
    assert "toppled_specimen3" in msg and "specimens present: 1, 2" in msg
    csv, _ = box_campaign(tmp_path / "g")
    lines = csv.read_text().splitlines()
    lines[0] += ",specimen"
    lines[1:] = [ln + (",2" if k == 4 else ",1") for k, ln in enumerate(lines[1:], 1)]
    csv.write_text("\n".join(lines) + "\n")
    with pytest.raises(CampaignError) as e:
        load_campaign(csv, 1)
    msg = _one_line(e)
    assert "campaign.csv" in msg and "test 4" in msg and "specimen '2'" in msg


def test_empty_campaign(tmp_path: Path) -> None:
    csv = tmp_path / "empty.csv"
    csv.write_text("test,motion_file,units,toppled\n")
    with pytest.raises(CampaignError) as e:
        load_campaign(csv, 1)
    assert "empty.csv" in _one_line(e) and "no test" in str(e.value)
    d = tmp_path / "shared"
    d.mkdir()
    (d / "experiments.csv").write_text("test,motion,toppled_specimen1\n")
    np.savez(d / "table_motions.npz", x=np.zeros(2))
    with pytest.raises(CampaignError) as e:
        load_campaign(d, 1)
    assert "no test" in _one_line(e)


def test_other_bad_inputs(tmp_path: Path) -> None:
    with pytest.raises(CampaignError, match="not found"):
        load_campaign(tmp_path / "nowhere", 1)
    csv = tmp_path / "c.csv"
    csv.write_text("test,motion_file,toppled\n1,a.txt,1\n")
    with pytest.raises(CampaignError, match="missing column"):
        load_campaign(csv, 1)
    good, _ = box_campaign(tmp_path / "g")
    good.write_text(good.read_text().replace("m/s2", "furlongs", 1))
    with pytest.raises(CampaignError, match="units 'furlongs'"):
        load_campaign(good, 1)
    good, _ = box_campaign(tmp_path / "h")
    with pytest.raises(CampaignError, match="does not hold"):
        load_campaign(good, 1).select(["99"])


def test_baseline_correction_removes_offset_keeps_the_shaking() -> None:
    dt = 1 / 800
    t = np.arange(0, 40.0, dt)
    shake = 2.0 * np.sin(2 * np.pi * 1.5 * t) * np.exp(-(((t - 20) / 6) ** 2))
    raw = shake + 0.17 + 0.002 * t  # offset and drift, m/s²
    acc, dt2 = baseline_correct(raw, dt, Baseline(resample_hz=None))
    assert dt2 == dt
    # the 1.5 Hz content is far inside the 0.3–25 Hz band: amplitude kept within 1 %
    assert np.max(np.abs(acc)) == pytest.approx(2.0, rel=0.01)
    assert abs(np.mean(acc)) < 1e-3
    # velocity drift gone: the uncorrected record would end at ≈ 0.17·40 + 0.001·40² = 8.4 m/s
    assert abs(np.sum(acc) * dt) < 0.02
    acc4, dt4 = baseline_correct(raw, dt, Baseline())  # default: resampled to 200 Hz
    assert dt4 == pytest.approx(1 / 200) and acc4.size == pytest.approx(acc.size / 4, abs=1)
    assert np.max(np.abs(acc4)) == pytest.approx(2.0, rel=0.01)
    with pytest.raises(CampaignError, match="below the low-pass"):
        Baseline(highpass_hz=30.0, lowpass_hz=25.0)


def test_record_pgv_against_the_closed_form() -> None:
    """A sine a = A sin 2πt over one period: v = A (1 − cos 2πt) / 2π, peak A/π at t = ½ s (a sample at
    dt = 1 ms); the trapezoidal rule's error is O(dt²). A constant acceleration: v = a t exactly."""
    amp, dt = 3.0, 1e-3
    t = np.arange(1001) * dt
    assert record_pgv(amp * np.sin(2 * np.pi * t), dt) == pytest.approx(amp / np.pi, rel=1e-5)
    assert record_pgv(np.full(101, -2.0), 0.01) == pytest.approx(2.0, rel=1e-12)
