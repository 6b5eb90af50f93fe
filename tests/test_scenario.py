"""Scenario model: TOML round trip, content hash, and clear errors for bad input."""

from __future__ import annotations

import tomllib
from pathlib import Path

import pytest

from pbr_xval.scenario import ScenarioError, load_scenario, scenario_from_dict

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = sorted((ROOT / "examples").glob("*.toml"))

BASE = """
name = "t"
duration = 2.0

[rock]
shape = "box"
half_extents = [0.2, 0.2, 0.6]
density = 2400.0

[excitation]
type = "half_sine"
amplitude = 5.0
phase = "housner_uplift"
"""


def write(tmp_path: Path, text: str, name: str = "s.toml") -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


@pytest.mark.parametrize("path", EXAMPLES, ids=[p.name for p in EXAMPLES])
def test_examples_round_trip(path: Path, tmp_path: Path) -> None:
    scn = load_scenario(path)
    text = scn.to_toml()
    # TOML -> model -> TOML keeps exactly what the user wrote
    assert tomllib.loads(text) == tomllib.loads(path.read_text())
    again = load_scenario(write(tmp_path, text))
    assert again.model_dump() == scn.model_dump()
    assert again.to_toml() == text
    assert again.content_hash() == scn.content_hash()


def test_hash_ignores_written_defaults_but_not_values(tmp_path: Path) -> None:
    a = load_scenario(write(tmp_path, BASE, "a.toml"))
    b = load_scenario(write(tmp_path, BASE.replace('name = "t"', 'name = "t"\ngravity = 9.81'), "b.toml"))
    c = load_scenario(write(tmp_path, BASE.replace("amplitude = 5.0", "amplitude = 5.001"), "c.toml"))
    assert a.content_hash() == b.content_hash()
    assert a.content_hash() != c.content_hash()
    assert len(a.content_hash()) == 64


def test_hash_covers_referenced_files(tmp_path: Path) -> None:
    import trimesh

    mesh = tmp_path / "rock.obj"
    trimesh.creation.box(extents=(0.4, 0.4, 1.2)).export(mesh)
    text = BASE.replace('shape = "box"\nhalf_extents = [0.2, 0.2, 0.6]', 'shape = "mesh"\npath = "rock.obj"')
    h1 = load_scenario(write(tmp_path, text)).content_hash()
    trimesh.creation.box(extents=(0.4, 0.4, 1.3)).export(mesh)
    h2 = load_scenario(write(tmp_path, text)).content_hash()
    assert h1 != h2


@pytest.mark.parametrize(
    ("edit", "key", "expect"),
    [
        (
            lambda s: s.replace("density = 2400.0", "density = 2400.0\ncolour = 'red'"),
            "rock.colour",
            "unknown key",
        ),
        (lambda s: s.replace("density = 2400.0", "mass = -5.0"), "rock.mass", "greater than 0"),
        (
            lambda s: s + "\n[contact]\nfriction_static = -1.0\n",
            "contact.friction_static",
            "greater than or equal to 0",
        ),
        (lambda s: s.replace("amplitude = 5.0\n", ""), "excitation.amplitude", "missing"),
        (lambda s: s.replace('type = "half_sine"', 'type = "half_cosine"'), "excitation", "half_sine"),
        (lambda s: s.replace("duration = 2.0", "duration = 'long'"), "duration", "valid number"),
    ],
    ids=[
        "unknown-key",
        "negative-mass",
        "negative-friction",
        "pulse-without-amplitude",
        "unknown-pulse",
        "bad-type",
    ],
)
def test_bad_input_names_file_key_and_expectation(tmp_path: Path, edit, key: str, expect: str) -> None:
    path = write(tmp_path, edit(BASE), "bad.toml")
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    msg = str(info.value)
    assert "bad.toml" in msg
    assert f"'{key}'" in msg
    assert expect in msg


def test_unknown_key_lists_expected_keys(tmp_path: Path) -> None:
    path = write(tmp_path, BASE.replace("density = 2400.0", "density = 2400.0\nhalf_extent = 1"), "bad.toml")
    with pytest.raises(ScenarioError, match="expected one of: density, half_extents, mass"):
        load_scenario(path)


def test_missing_mesh_file(tmp_path: Path) -> None:
    text = BASE.replace(
        'shape = "box"\nhalf_extents = [0.2, 0.2, 0.6]', 'shape = "mesh"\npath = "nowhere.obj"'
    )
    with pytest.raises(ScenarioError, match=r"rock\.path.*file not found.*nowhere\.obj"):
        load_scenario(write(tmp_path, text, "m.toml"))


def test_missing_derived_file_names_the_script_that_writes_it(tmp_path: Path) -> None:
    """A mesh derived from shared data (SP2's) is not committed: the error names its maker, runs nothing."""
    text = BASE.replace(
        'shape = "box"\nhalf_extents = [0.2, 0.2, 0.6]', 'shape = "mesh"\npath = "rock.made.obj"'
    )
    scenario = write(tmp_path, text, "m.toml")
    (tmp_path / "other.py").write_text('"""Unrelated."""\n')
    with pytest.raises(ScenarioError) as plain:
        load_scenario(scenario)
    assert "not committed" not in str(plain.value) and "\n" not in str(plain.value)
    maker = tmp_path / "make_rock.py"
    maker.write_text(
        '"""Write ``rock.made.obj`` from the point cloud."""\nraise SystemExit("must not run")\n'
    )
    with pytest.raises(ScenarioError) as hinted:
        load_scenario(scenario)
    msg = str(hinted.value)
    assert "\n" not in msg and "rock.path" in msg and "file not found" in msg
    assert msg.endswith(f"it is derived, not committed: `python {maker}` writes it)")
    assert not (tmp_path / "rock.made.obj").exists()


def test_committed_sp2_scenario_names_its_mesh_maker(tmp_path: Path) -> None:
    """The judged SP2 command on a clone without the reconstructed mesh says how to make it."""
    import shutil

    repo = Path(__file__).resolve().parents[1] / "examples" / "validation"
    for name in ("sp2.toml", "make_sp2_mesh.py"):
        shutil.copy(repo / name, tmp_path / name)
    with pytest.raises(ScenarioError, match=r"sp2\.rock\.obj.*`python .*make_sp2_mesh\.py` writes it"):
        load_scenario(tmp_path / "sp2.toml")


def test_invalid_toml_and_missing_file(tmp_path: Path) -> None:
    with pytest.raises(ScenarioError, match="not valid TOML"):
        load_scenario(write(tmp_path, "name = ", "x.toml"))
    with pytest.raises(ScenarioError, match="cannot read"):
        load_scenario(tmp_path / "absent.toml")


def test_density_xor_mass() -> None:
    data = tomllib.loads(BASE)
    data["rock"]["mass"] = 10.0
    with pytest.raises(ScenarioError, match="either 'density' or 'mass'"):
        scenario_from_dict(data)
    del data["rock"]["mass"], data["rock"]["density"]
    with pytest.raises(ScenarioError, match=r"'density'.*or 'mass'"):
        scenario_from_dict(data)


def test_with_value_validates() -> None:
    scn = scenario_from_dict(tomllib.loads(BASE))
    assert scn.with_value("excitation.amplitude", 6.5).excitation.amplitude == 6.5
    with pytest.raises(ScenarioError, match=r"excitation\.amplitude"):
        scn.with_value("excitation.amplitude", -1.0)
