from __future__ import annotations

import json

import pytest

from pbr_xval.cli.catalog_impl import choose_command, sweep_command


def test_choose_fast_engines(tmp_path):
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from conftest import write_catalog

    p = write_catalog(tmp_path, **{'engines = ["housner", "mujoco"]': 'engines = ["housner"]'})
    assert choose_command(p, 0.05, tmp_path / "out") == 0
    res = json.loads((tmp_path / "out" / "choose.json").read_text())
    # one engine only: what is checked is the metric chosen for a tiny catalog and the projection
    assert res["metric"] == "outcome_agreement"
    assert res["projection"]["n_simulations"] == 8


@pytest.mark.slow
def test_choose_recommends_on_tiny_catalog(tiny_catalog, tmp_path):
    from rich.console import Console

    con = Console(record=True, width=140)
    rc = choose_command(tiny_catalog, 0.05, tmp_path / "out", console=con)
    res = json.loads((tmp_path / "out" / "choose.json").read_text())
    assert rc == 0 and res["recommendation"] is not None
    assert res["metric"] == "outcome_agreement"  # 4 runs per rock: too few for a fit
    assert res["reference"] == "housner"
    engines = {c["engine"] for c in res["candidates"]}
    assert engines == {"housner", "mujoco"}
    assert res["projection"]["n_simulations"] == 8 and res["projection"]["core_hours"] > 0
    md = (tmp_path / "out" / "choose.md").read_text()
    assert "Recommendation" in md and "outcome_agreement" in md


def test_sweep_command_invalid_catalog(tmp_path):
    from rich.console import Console

    p = tmp_path / "bad.toml"
    p.write_text(
        '[[rock]]\nid = "x"\nshape = "cube"\ndensity = 1.0\n[motions]\n[[motions.pulse]]\ntype = "half_sine"\namplitude = 1.0\n'
    )
    con = Console(record=True, width=200)
    assert sweep_command(p, tmp_path / "o", None, None, "local", 1, None, None, 0, console=con) == 2
    text = con.export_text()
    assert "[[rock]] 1 (id 'x'): key 'shape'" in text and "'cube'" in text
    assert not (tmp_path / "o").exists()  # nothing ran
