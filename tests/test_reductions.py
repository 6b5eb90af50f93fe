"""Scene reductions: the compiler records its modelling choices, and they do not change results."""

from __future__ import annotations

import numpy as np
import pytest

from pbr_xval.conformance import housner_scenario, notched_scenario
from pbr_xval.engine import EngineNotAvailable, get_engine
from pbr_xval.scene import compile_scene


def _choices(scene) -> dict[str, str]:
    return {r["what"]: r["choice"] for r in scene.reductions}


def test_auto_choices_are_recorded() -> None:
    box = compile_scene(housner_scenario())
    assert _choices(box)["rock collision"] == "primitive" and box.collision["kind"] == "primitive"
    assert _choices(box)["pedestal"] == "plane"
    assert len(box.basal_nodes) == 4 and np.allclose(box.basal_nodes[:, 2], 0)
    notched = compile_scene(notched_scenario())
    assert _choices(notched)["rock collision"] == "boxes"
    ped = compile_scene(housner_scenario(pedestal={"kind": "box", "half_extents": [2.0, 2.0, 0.5]}))
    assert (
        ped.pedestal["kind"] == "plane"
        and "footprint" in next(r for r in ped.reductions if r["what"] == "pedestal")["why"]
    )
    over = compile_scene(housner_scenario(pedestal={"kind": "box", "half_extents": [0.1, 2.0, 0.5]}))
    assert over.pedestal["kind"] == "box"


def test_basal_node_count_option() -> None:
    for n in (4, 16, 64, 256, 1024):
        scene = compile_scene(housner_scenario(model={"basal_nodes": n}))
        k = len(scene.basal_nodes)
        assert n <= k <= n + 4, (n, k)
        xy = scene.basal_nodes[:, :2]
        assert np.all(np.abs(xy) <= 0.2 + 1e-12)


def test_coacd_and_decimated_choices_record_what_they_cost() -> None:
    scene = compile_scene(notched_scenario(model={"collision": "coacd"}))
    rec = next(r for r in scene.reductions if r["what"] == "rock collision")
    assert scene.collision["kind"] == "coacd" and len(scene.collision["parts"]) == 3
    assert "volume error" in rec["why"]
    assert abs(scene.collision["report"]["rel_volume_error"]) < 1e-3
    dec = compile_scene(
        housner_scenario(
            rock={
                "shape": "curved_base",
                "H": 1.5,
                "r": 0.3,
                "h": 0.4,
                "depth": 0.4,
                "density": 2400.0,
                "arc_segments": 64,
            },
            model={"collision": "decimated"},
        )
    )
    ((v, f),) = dec.collision["parts"]
    assert len(f) < len(dec.rock.mesh.faces)
    base = dec.rock.mesh.vertices[dec.rock.mesh.vertices[:, 2] <= 1e-9]
    kept = v[v[:, 2] <= 1e-9]
    assert len(kept) == len(base)  # the basal patch keeps full resolution
    # mass properties always come from the full mesh
    full = compile_scene(housner_scenario(rock=dec.scenario.rock.model_dump()))
    assert dec.rock.mass == full.rock.mass and np.allclose(dec.rock.inertia, full.rock.inertia)


def test_primitive_on_a_mesh_rock_is_a_clear_error() -> None:
    from pbr_xval.scenario import ScenarioError

    with pytest.raises(ScenarioError, match=r"model\.collision"):
        compile_scene(notched_scenario(model={"collision": "primitive"}))


def test_reductions_keep_the_independent_references() -> None:
    """With each collision reduction a 3-D engine still meets the exact references.

    (The analytical engines ignore collision geometry, so they cannot test a reduction.)
    Measured with MuJoCo at dt 1e-3: notched block as boxes 5.1244, as CoACD parts 5.1231
    (notes), vs the exact two-pivot ODE's 5.1241 (≤ 0.02 %): ± 0.3 % is the conformance
    tolerance; the big box pedestal is reduced to the plane (Housner 5.6387 vs 5.638).
    """
    from pbr_xval.conformance import THRESHOLD_DURATION, notched_reference, threshold_bracket

    try:
        get_engine("mujoco")
    except EngineNotAvailable as exc:
        pytest.skip(str(exc))
    settings = {"timestep": 1e-3}
    ref = notched_reference()["threshold"]
    for collision in ("boxes", "coacd"):
        scn = notched_scenario(duration=THRESHOLD_DURATION, model={"collision": collision})
        threshold_bracket(scn, "mujoco", ref, 3e-3, settings, refine=0)
    ped = housner_scenario(
        duration=THRESHOLD_DURATION, pedestal={"kind": "box", "half_extents": [2.0, 2.0, 0.5]}
    )
    threshold_bracket(ped, "mujoco", 5.638, 2e-3, settings, refine=0)
