"""The scenario's ``[uncertainty]`` table: validation, deterministic sampling, members' scenarios."""

from __future__ import annotations

import copy
import tomllib
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

from pbr_xval.scenario import ScenarioError, scenario_from_dict
from pbr_xval.uncertainty import apply_values, ensemble_spec, jeffreys_interval, member_scenario

HOUSNER = Path(__file__).parents[1] / "examples" / "housner_halfsine.toml"


def base() -> dict:
    return tomllib.loads(HOUSNER.read_text())


def with_unc(table: dict) -> dict:
    d = base()
    d["uncertainty"] = table
    return d


def scn_with(table: dict):
    return scenario_from_dict(with_unc(table), source=HOUSNER)


U = {"dist": "uniform", "low": 5.0, "high": 6.5}


# ------------------------------------------------------------------ validation
@pytest.mark.parametrize(
    ("table", "key", "words"),
    [
        ({"excitation.azimuth_dg": U}, "uncertainty.excitation.azimuth_dg", "not a scenario key"),
        ({"excitation": {"amplitud": U}}, "uncertainty.excitation.amplitud", "not a scenario key"),
        ({"rock": U}, "uncertainty.rock", "is a table"),
        (
            {"excitation.amplitude": {"dist": "uniform", "low": 3, "high": 1}},
            "uncertainty.excitation.amplitude",
            "low ≥ high",
        ),
        (
            {"contact.friction_static": {"dist": "uniform", "low": -1, "high": 1}},
            "uncertainty.contact.friction_static",
            "invalid",
        ),
        (
            {"contact.friction_static": {"dist": "gauss", "mean": 1}},
            "uncertainty.contact.friction_static",
            "unknown distribution",
        ),
        (
            {"contact.friction_static": {"dist": "normal", "mean": 1}},
            "uncertainty.contact.friction_static.sd",
            "missing",
        ),
        (
            {"contact.friction_static": {"dist": "normal", "mean": 1, "sd": -0.1}},
            "uncertainty.contact.friction_static",
            "sd ≤ 0",
        ),
        (
            {"rock.mass": {"dist": "lognormal", "median": 0, "beta": 0.1}},
            "uncertainty.rock.mass",
            "median ≤ 0",
        ),
        ({"contact.restitution": 0.5}, "uncertainty.contact.restitution", "not a distribution"),
        (
            {"model.collision": {"dist": "choice", "values": ["hull", "bad"]}},
            "uncertainty.model.collision",
            "invalid",
        ),
        (
            {"model.collision": {"dist": "choice", "values": ["hull"], "weights": [1, 2]}},
            "uncertainty.model.collision",
            "weights",
        ),
        ({"engines": ["mujoc"]}, "uncertainty.engines", "unknown engine"),
        ({"engines": ["housner"], "engine_weights": [1, 2]}, "uncertainty.engine_weights", "one weight"),
        ({"members": 0}, "uncertainty.members", "member count"),
        ({"sampling": "halton"}, "uncertainty.sampling", "unknown sampling"),
        ({"seed": -1}, "uncertainty.seed", "not a seed"),
        ({"engines.mujoco.timestp": U}, "uncertainty.engines.mujoco.timestp", "unknown setting"),
        ({"timestep": {"dist": "uniform", "low": -1e-3, "high": 1e-3}}, "uncertainty.timestep", "timestep"),
    ],
)
def test_bad_tables_are_one_line_naming_the_key(table: dict, key: str, words: str) -> None:
    with pytest.raises(ScenarioError) as ei:
        scn_with(table)
    msg = str(ei.value)
    assert len(msg.splitlines()) == 1, msg
    assert f"key '{key}'" in msg and words in msg and str(HOUSNER) in msg


def test_candidate_keys_are_accepted() -> None:
    scn = scn_with(
        {
            "excitation": {"azimuth_deg": {"dist": "uniform", "low": 0.0, "high": 360.0}},
            "contact.friction_static": {"dist": "normal", "mean": 1.0, "sd": 0.3, "low": 0.5, "high": 2.0},
            "contact.restitution": {"dist": "uniform", "low": 0.0, "high": 0.2},
            "rock.mass": {"dist": "lognormal", "median": 300.0, "beta": 0.1},
            "initial.theta": {"dist": "uniform", "low": -0.005, "high": 0.005},
            "timestep": {"dist": "choice", "values": [1e-3, 5e-4]},
            "engines": ["housner", "mujoco"],
            "engine_weights": [3, 1],
        }
    )
    spec = ensemble_spec(scn)
    assert spec is not None and spec.members == 16 and spec.sampling == "sobol"
    for m in spec.sample():
        ms = member_scenario(scn, m)
        assert ms.uncertainty is None and ms.rock.mass == m.values["rock.mass"] and ms.rock.density is None
        assert ms.contact.friction_static == m.values["contact.friction_static"]
        assert ms.initial.theta == m.values["initial.theta"]
        assert ms.excitation.azimuth_deg == m.values["excitation.azimuth_deg"]
        # the engine-neutral timestep reaches engines that have one; the analytical ones have none
        if m.engine == "mujoco":
            assert ms.engines["mujoco"]["timestep"] == m.values["timestep"]
        else:
            assert "housner" not in ms.engines


def test_hashes() -> None:
    plain = scenario_from_dict(base(), source=HOUSNER)
    a = scn_with({"excitation.amplitude": U})
    nested = scn_with({"excitation": {"amplitude": U}})
    assert a.content_hash() != plain.content_hash()
    assert a.content_hash() == nested.content_hash()  # one content, two TOML spellings
    assert scn_with({"excitation.amplitude": U, "seed": 1}).content_hash() != a.content_hash()
    spec = ensemble_spec(a)
    assert spec is not None
    m0, m1 = spec.sample(members=2)
    h0, h1 = member_scenario(a, m0).content_hash(), member_scenario(a, m1).content_hash()
    assert len({h0, h1, a.content_hash(), plain.content_hash()}) == 4
    # a scenario without [uncertainty] hashes as before the table existed
    assert "uncertainty" not in plain.normalised()


# ------------------------------------------------------------------ sampling
def test_members_are_deterministic_and_sobol_is_a_sequence() -> None:
    scn = scn_with(
        {
            "excitation.amplitude": U,
            "contact.restitution": {"dist": "uniform", "low": 0, "high": 0.5},
            "seed": 7,
        }
    )
    spec = ensemble_spec(scn)
    assert spec is not None
    a = [m.values for m in spec.sample(members=16)]
    b = [m.values for m in ensemble_spec(scn_with(copy.deepcopy(scn.uncertainty or {}))).sample(members=16)]  # type: ignore[union-attr]
    assert a == b
    assert [m.values for m in spec.sample(members=8)] == a[:8]  # adding members keeps the first ones
    assert spec.member(11, members=16).values == a[11]
    other = ensemble_spec(scn_with({**(scn.uncertainty or {}), "seed": 8}))
    assert other is not None and [m.values for m in other.sample(members=16)] != a
    for sampling in ("lhs", "random"):
        s1 = ensemble_spec(scn_with({**(scn.uncertainty or {}), "sampling": sampling}))
        assert s1 is not None
        assert [m.values for m in s1.sample()] == [m.values for m in s1.sample()]
        assert s1.member(5).values == s1.sample()[5].values


def test_uniform_sobol_members_match_the_distribution() -> None:
    spec = ensemble_spec(scn_with({"excitation.amplitude": U, "members": 64}))
    assert spec is not None
    x = np.array([m.values["excitation.amplitude"] for m in spec.sample()])
    assert x.min() >= 5.0 and x.max() <= 6.5
    assert x.mean() == pytest.approx(5.75, abs=0.01)
    # Sobol: one point in each of the 64 equal strata of the range
    assert sorted(np.floor((x - 5.0) / 1.5 * 64).astype(int)) == list(range(64))
    for q in (0.1, 0.5, 0.9):
        assert np.quantile(x, q) == pytest.approx(5.0 + 1.5 * q, abs=1.5 / 32)


def test_normal_lognormal_choice_and_engine_weights() -> None:
    spec = ensemble_spec(
        scn_with(
            {
                "members": 256,
                "contact.friction_static": {"dist": "normal", "mean": 1.0, "sd": 0.2, "low": 0.8},
                "rock.density": {"dist": "lognormal", "median": 2600.0, "beta": 0.1},
                "model.collision": {
                    "dist": "choice",
                    "values": ["hull", "coacd", "auto"],
                    "weights": [2, 1, 1],
                },
                "engines": ["housner", "mujoco"],
                "engine_weights": [3, 1],
            }
        )
    )
    assert spec is not None
    ms = spec.sample()
    mu = np.array([m.values["contact.friction_static"] for m in ms])
    assert mu.min() >= 0.8
    assert mu.mean() == pytest.approx(stats.truncnorm.mean(-1.0, np.inf, loc=1.0, scale=0.2), abs=0.01)
    rho = np.array([m.values["rock.density"] for m in ms])
    assert np.median(rho) == pytest.approx(2600.0, rel=0.01)
    assert np.std(np.log(rho)) == pytest.approx(0.1, rel=0.05)
    coll = [m.values["model.collision"] for m in ms]
    assert [coll.count(v) for v in ("hull", "coacd", "auto")] == [128, 64, 64]
    engines = [m.engine for m in ms]
    assert engines.count("housner") == 192 and engines.count("mujoco") == 64
    # --engine restricts the mixture (the other columns do not move)
    only = spec.sample(engines=["mujoco"])
    assert {m.engine for m in only} == {"mujoco"} and [m.values for m in only] == [m.values for m in ms]


def test_lhs_stratifies_every_column() -> None:
    spec = ensemble_spec(scn_with({"excitation.amplitude": U, "sampling": "lhs", "members": 20}))
    assert spec is not None
    x = np.array([m.values["excitation.amplitude"] for m in spec.sample()])
    assert sorted(np.floor((x - 5.0) / 1.5 * 20).astype(int)) == list(range(20))


def test_apply_values_mass_replaces_density() -> None:
    d = {"rock": {"shape": "box", "density": 2400.0, "mass": None}}
    apply_values(d, {"rock.mass": 300.0})
    assert d["rock"] == {"shape": "box", "mass": 300.0}
    apply_values(d, {"rock.density": 2000.0})
    assert d["rock"] == {"shape": "box", "density": 2000.0}


@pytest.mark.parametrize(("k", "n"), [(0, 10), (1, 10), (5, 10), (9, 10), (10, 10), (37, 100), (0, 1)])
def test_jeffreys_interval_against_scipy(k: int, n: int) -> None:
    lo, hi = jeffreys_interval(k, n)
    b = stats.beta(k + 0.5, n - k + 0.5)
    assert lo == (0.0 if k == 0 else pytest.approx(b.ppf(0.025), abs=1e-12))
    assert hi == (1.0 if k == n else pytest.approx(b.ppf(0.975), abs=1e-12))
    assert jeffreys_interval(0, 0) == (0.0, 1.0)


def test_per_test_designs() -> None:
    spec = ensemble_spec(scn_with({"excitation.amplitude": U, "per_test": True}))
    assert spec is not None and spec.per_test
    a, b = spec.for_test("12"), spec.for_test("13")
    assert a.seed != b.seed and a.sample()[0].values != b.sample()[0].values
    assert spec.for_test("12").sample() == a.sample() and a.sample()[0].seed == a.seed
    shared = ensemble_spec(scn_with({"excitation.amplitude": U}))
    assert shared is not None and shared.for_test("12") is shared
    with pytest.raises(ScenarioError, match=r"uncertainty\.per_test"):
        scn_with({"excitation.amplitude": U, "per_test": "yes"})
