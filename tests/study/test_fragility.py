"""Fragility study on the seed's curved-base block (H = 14.73, r = 3.62, h = 3.38 m), sawtooth PGV × T."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

from pbr_xval.scenario import load_scenario
from pbr_xval.study import fragility_map as fragility

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "echo_cliff_like_sawtooth.toml"
GRID = {"x_values": [0.5, 2.5, 6.0], "y_values": [1.0, 2.0, 3.0]}


def _scenario():
    return load_scenario(EXAMPLE).with_value("duration", 8.0)


def test_curved_base_self_agreement_and_map() -> None:
    cfg = fragility.FragilityConfig(**GRID)
    res = fragility.run(cfg, _scenario(), ["curved_base", "no_such_engine"])
    cells = res.tables["fragility_cells"]
    cb = cells[cells["engine"] == "curved_base"]
    assert len(cb) == 9 and (cb["status"] == "ok").all()
    # toppling at large PGV, not at small PGV
    assert cb[cb["x"] == 6.0]["toppled"].any()
    assert not cb[cb["x"] == 0.5]["toppled"].any()
    assert (cb.loc[cb["toppled"], "peak_com_disp_m"] == 5.0).all()
    assert (cb["peak_com_disp_m"] <= 5.0).all()
    # (the reference's agreement with itself is 1 by construction: not asserted)
    assert (cells[cells["engine"] == "no_such_engine"]["status"] == "skipped").all()
    assert any("no_such_engine" in n for n in res.notes)
    assert res.figures[0].table == "fragility_cells"


def test_variants_and_pool() -> None:
    """Two variants (r) on a 1 × 2 grid through a 2-process pool give the in-process numbers."""
    cfg = fragility.FragilityConfig(
        x_values=[6.0], y_values=[1.0, 2.0], variants=[{"rock.r": 3.62}, {"rock.r": 7.24}], max_workers=2
    )
    res = fragility.run(cfg, _scenario(), ["curved_base"])
    cells = res.tables["fragility_cells"]
    assert len(cells) == 4 and (cells["status"] == "ok").all()
    assert set(cells["variant"]) == {"rock.r=3.62", "rock.r=7.24"}
    serial = fragility.run(cfg.model_copy(update={"max_workers": 1}), _scenario(), ["curved_base"])
    np.testing.assert_allclose(cells["peak_com_disp_m"], serial.tables["fragility_cells"]["peak_com_disp_m"])
    fig = res.figures[0].figure
    assert len([a for a in fig.axes if a.get_title()]) == 2  # 2 variants × 1 engine


@pytest.mark.slow
@pytest.mark.skipif(importlib.util.find_spec("mujoco") is None, reason="mujoco not installed")
def test_mujoco_agrees_with_curved_base() -> None:
    cfg = fragility.FragilityConfig(**GRID)
    res = fragility.run(cfg, _scenario(), ["mujoco"])
    ag = res.tables["fragility_agreement"].set_index("engine")
    assert ag.loc["mujoco", "agreement"] >= 0.75
