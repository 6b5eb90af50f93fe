from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pbr_xval.study.extremes import ExtremesConfig, build_cases, fine_base_box_mesh, run

CRASHY = str(Path(__file__).with_name("_crashy_engine.py"))


def test_fine_base_mesh_is_a_closed_box():
    m = fine_base_box_mesh()
    assert m.is_watertight
    assert np.isclose(m.volume, 0.4 * 0.4 * 1.2)
    assert int(np.sum(np.abs(m.vertices[:, 2]) < 1e-12)) > 1000


def test_cases_build(tmp_path):
    cases = build_cases(["size_50m", "mass_1e6kg", "offset_10km", "record_600s"], tmp_path)
    assert cases[0].a_ref == pytest.approx(5.638)
    assert cases[1].scenario.rock.mass == 1e6
    assert (tmp_path / "box_10km.obj").is_file() and (tmp_path / "noise_600s.txt").is_file()
    with pytest.raises(ValueError, match="unknown extremes case"):
        build_cases(["nope"], tmp_path)


def test_matrix_survives_a_crashing_engine():
    cfg = ExtremesConfig(cases=["mass_1kg", "friction_0.05"], timeout=60, max_workers=2)
    res = run(cfg, None, ["housner", f"{CRASHY}:SegfaultEngine"])
    df = res.tables["extremes_matrix"].set_index(["case", "engine"])
    assert df.loc[("mass_1kg", "housner"), "class"] == "ok", df
    assert df.loc[("friction_0.05", "housner"), "class"] == "not_applicable"  # no sliding in housner
    assert df.loc[("mass_1kg", "segfault"), "class"] == "crash"
    assert df.loc[("friction_0.05", "segfault"), "class"] == "crash"
    assert "SIGSEGV" in df.loc[("mass_1kg", "segfault"), "detail"]
    assert res.figures and res.figures[0].table == "extremes_matrix"
    assert res.headline["classes"]["crash"] == 2


@pytest.mark.slow
def test_full_matrix_real_engines():
    cfg = ExtremesConfig(cases="all", timeout=300)
    res = run(cfg, None, ["housner", "mujoco", "pybullet", "dart"])
    df = res.tables["extremes_matrix"]
    assert len(df) == 16 * 4
    assert not (df["class"].isin(["crash", "timeout"]) & (df["engine"] == "housner")).any()
