from __future__ import annotations

from pathlib import Path

import pytest

from pbr_xval.catalog import CatalogError, build_chunks, load_catalog, shard_chunks

ROOT = Path(__file__).resolve().parents[2]


def _load(tmp_path: Path, text: str) -> None:
    p = tmp_path / "c.toml"
    p.write_text(text)
    load_catalog(p)


BASE_MOTIONS = '\n[motions]\n[[motions.pulse]]\ntype = "half_sine"\namplitude = [2.0, 4.0]\n'


def test_examples_load():
    cat = load_catalog(ROOT / "examples" / "catalogs" / "demo.toml")
    assert len(cat.rocks) == 3 and len(cat.motions) == 16
    assert cat.rock("squat_block")["friction_min"] == 0.6


def test_toml_rock_error_names_index_key_found_expected(tmp_path):
    text = (
        '[[rock]]\nid = "a"\nshape = "box"\nhalf_extents = [0.2, 0.2, 0.6]\ndensity = 2400.0\n'
        '[[rock]]\nid = "b"\nshape = "box"\nhalf_extents = [0.2, 0.2, 0.6]\ndensity = -5.0\n' + BASE_MOTIONS
    )
    with pytest.raises(CatalogError) as ei:
        _load(tmp_path, text)
    msg = str(ei.value)
    assert len(ei.value.lines) == 1
    assert "c.toml: [[rock]] 2 (id 'b'): key 'density'" in msg and "-5.0" in msg and "expected" in msg


def test_csv_row_number_named(tmp_path):
    (tmp_path / "rocks.csv").write_text(
        "id,shape,half_extents,density,friction\n"
        "r1,box,0.2 0.2 0.6,2400,0.8\n"
        "r2,box,0.2 0.2,2400,0.8\n"
        "r3,box,0.2 0.2 0.6,abc,0.8\n"
    )
    with pytest.raises(CatalogError) as ei:
        _load(tmp_path, 'rocks_csv = "rocks.csv"\n' + BASE_MOTIONS)
    lines = ei.value.lines
    assert len(lines) == 2  # one error per bad row
    assert any("rocks.csv: row 2 (line 3)" in ln and "half_extents" in ln for ln in lines)
    assert any("rocks.csv: row 3 (line 4)" in ln and "key 'density'" in ln and "'abc'" in ln for ln in lines)


def test_shape_specific_and_motion_errors(tmp_path):
    text = (
        '[[rock]]\nid = "n"\nshape = "notched_block"\nhalf_extents = [0.2, 0.2, 0.6]\nnotch_width = 0.5\n'
        "notch_height = 0.3\ndensity = 2400.0\n"
        '[[rock]]\nid = "m"\nshape = "mesh"\npath = "missing.obj"\ndensity = 2400.0\n'
        '[[rock]]\nid = "s"\nshape = "synthetic"\nseed = 1\nfriction_min = 0.9\nfriction_max = 0.5\ndensity = 2400.0\n'
        '\n[motions]\n[[motions.pulse]]\ntype = "sawtooth"\npgv = [0.5, -1.0]\nperiod = 1.0\n'
    )
    with pytest.raises(CatalogError) as ei:
        _load(tmp_path, text)
    lines = ei.value.lines
    assert any("[[rock]] 1 (id 'n')" in ln and "notch_width" in ln for ln in lines)
    assert any("[[rock]] 2 (id 'm')" in ln and "file not found" in ln for ln in lines)
    assert any("[[rock]] 3 (id 's')" in ln and "friction_max" in ln for ln in lines)
    assert any("[[motions.pulse]] 1" in ln and "pgv" in ln and "-1.0" in ln for ln in lines)


def test_chunks_deterministic_and_shards_partition(tiny_catalog):
    cat = load_catalog(tiny_catalog)
    a = build_chunks(cat)
    b = build_chunks(load_catalog(tiny_catalog))
    assert [c.content_hash() for c in a] == [c.content_hash() for c in b]
    hs = [c.content_hash() for c in a]
    parts = [shard_chunks(a, f"{i}/3") for i in (1, 2, 3)]
    assert sorted(c.content_hash() for p in parts for c in p) == sorted(hs)
    with pytest.raises(ValueError, match="i/N"):
        shard_chunks(a, "4/3")


def test_mesh_rock_pose_as_in_a_scenario(tmp_path):
    """A catalog's mesh rock takes the scenario's pose vocabulary (scan | settle | stable); a bad
    pose is refused up front naming the rock and the key; the old key still reads, with a warning."""
    import warnings

    from pbr_xval.catalog.tasks import scenario_dict
    from pbr_xval.scenario import Scenario

    obj = ROOT / "examples" / "rocks" / "synthetic_pbr.obj"
    rock = f'[[rock]]\nid = "m"\nshape = "mesh"\npath = "{obj}"\ndensity = 2600.0\n'
    p = tmp_path / "c.toml"
    p.write_text(rock + 'pose = "stable"\n' + BASE_MOTIONS)
    cat = load_catalog(p)
    spec = build_chunks(cat)[0]
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no deprecation on the new key
        scn = Scenario.model_validate(scenario_dict(spec, spec.motions[0], 1.0, 0))
    assert scn.rock.pose == "stable"
    with pytest.raises(CatalogError) as ei:
        _load(tmp_path, rock + 'pose = "upright"\n' + BASE_MOTIONS)
    assert len(ei.value.lines) == 1 and "(id 'm')" in str(ei.value) and "pose" in str(ei.value)
    with pytest.warns(FutureWarning, match="pose"):
        p.write_text(rock + 'orientation = "as_scanned"\n' + BASE_MOTIONS)
        spec = build_chunks(load_catalog(p))[0]
        assert Scenario.model_validate(scenario_dict(spec, spec.motions[0], 1.0, 0)).rock.pose == "scan"
