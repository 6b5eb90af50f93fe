from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
import pytest

from pbr_xval.study.extremes import ExtremesConfig, build_cases, fine_base_box_mesh, run

CRASHY = str(Path(__file__).with_name("_crashy_engine.py"))
EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


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
    cfg = ExtremesConfig(cases=["size_5cm", "friction_0.05"], timeout=60, max_workers=2)
    res = run(cfg, None, ["housner", f"{CRASHY}:SegfaultEngine"])
    df = res.tables["extremes_matrix"].set_index(["case", "engine"])
    assert df.loc[("size_5cm", "housner"), "class"] == "ok", df
    assert df.loc[("friction_0.05", "housner"), "class"] == "not_applicable"  # no sliding in housner
    assert df.loc[("size_5cm", "segfault"), "class"] == "crash"
    assert df.loc[("friction_0.05", "segfault"), "class"] == "crash"
    assert "SIGSEGV" in df.loc[("size_5cm", "segfault"), "detail"]
    assert res.figures and res.figures[0].table == "extremes_matrix"
    assert res.headline["classes"]["crash"] == 2


def _quick_cases() -> list[str]:
    study = tomllib.loads((EXAMPLES / "studies" / "extremes.toml").read_text())["study"][0]
    return list(study["quick"]["cases"])


def test_quick_matrix_real_engines():
    """The example study's quick case list through the real engines (measured 74 s for 5 × 5
    cells on the loaded 2-core machine; 4 engines here). Every cell is classified; nothing crashes
    or times out; the cases every engine handles are ``ok`` (measured), the sliding case is not
    applicable to the analytical engine."""
    cases = _quick_cases()
    engines = ["housner", "mujoco", "pybullet", "dart"]
    res = run(ExtremesConfig(cases=cases, timeout=300, max_workers=2), None, engines)
    df = res.tables["extremes_matrix"]
    assert len(df) == len(cases) * len(engines)
    assert not df["class"].isin(["crash", "timeout"]).any(), df
    cls = df.set_index(["case", "engine"])["class"]
    for case in ("slender_2deg", "size_50m", "offset_10km"):
        for engine in engines:
            assert cls[(case, engine)] == "ok", (
                case,
                engine,
                df.set_index(["case", "engine"]).loc[(case, engine)].to_dict(),
            )
    assert cls[("friction_0.05", "housner")] == "not_applicable"
    assert all(cls[("friction_0.05", e)] == "ok" for e in engines[1:])


@pytest.mark.optional_study
def test_full_matrix_real_engines():
    # all 16 cases × 4 engines: 81 s with one worker on a quiet machine, 260 s with two on the
    # loaded one; guards no claim beyond the quick matrix above (optional: PBR_XVAL_SLOW=1)
    cfg = ExtremesConfig(cases="all", timeout=300, max_workers=2)
    res = run(cfg, None, ["housner", "mujoco", "pybullet", "dart"])
    df = res.tables["extremes_matrix"]
    assert len(df) == 16 * 4
    assert not (df["class"].isin(["crash", "timeout"]) & (df["engine"] == "housner")).any()
