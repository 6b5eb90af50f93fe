"""Per-process memos that ensemble members share (issue 23): same values, own copies, keyed on content."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from pbr_xval.geometry.stability import hull_vertices


def test_hull_vertices_memo_gives_fresh_equal_arrays() -> None:
    rng = np.random.default_rng(0)
    pts = rng.normal(size=(500, 3))
    a = hull_vertices(pts)
    a[:] = 0.0  # a caller's copy: mutating it does not touch the memo
    b = hull_vertices(pts)
    c = hull_vertices(pts.copy())
    assert np.array_equal(b, c) and not np.all(b == 0.0)
    moved = pts + 1.0  # other content: another hull
    assert np.array_equal(hull_vertices(moved), b + 1.0)


def test_record_read_memo_follows_the_file_content(tmp_path: Path) -> None:
    from pbr_xval.motion.processing import _read_cached
    from pbr_xval.motion.records import read_record

    f = tmp_path / "acc.txt"
    f.write_text("0.0\n1.0\n-1.0\n0.0\n")
    kw = {"dt": 0.01, "units": "m/s2", "column": None, "time_column": "auto"}
    r1 = _read_cached(f, "table", kw, read_record)
    r1.acc[:] = 9.0  # the caller's copy
    r2 = _read_cached(f, "table", kw, read_record)
    assert r2.acc.tolist() == [0.0, 1.0, -1.0, 0.0]
    f.write_text("0.0\n2.0\n-2.0\n0.0\n")
    assert _read_cached(f, "table", kw, read_record).acc.tolist() == [0.0, 2.0, -2.0, 0.0]


def _mesh_scenario(tmp_path: Path, *, yaw: float = 0.0, mass: float | None = 420.0) -> Path:
    rock = Path(__file__).resolve().parents[1] / "examples" / "rocks" / "synthetic_pbr.obj"
    spec = f"mass = {mass}" if mass is not None else "density = 2650.0"
    f = tmp_path / f"memo_{yaw:g}_{mass}.toml"
    f.write_text(
        f'name = "memo"\nduration = 1.0\n[rock]\nshape = "mesh"\npath = "{rock}"\n{spec}\nyaw_deg = {yaw}\n'
        '[excitation]\ntype = "none"\nazimuth_deg = 20.0\n'
    )
    return f


def test_mesh_rock_mass_properties_equal_trimeshs_own_bit_for_bit(tmp_path: Path) -> None:
    """The memoised mesh integrals (an ensemble's members share them) give exactly what trimesh computes
    on the posed mesh with the member's density — the computation compile_scene made before the memo —
    for a mass or a density, with and without a yaw, cold and warm."""
    import math

    from pbr_xval import scene as scene_mod
    from pbr_xval.geometry.interface import load_rock_mesh
    from pbr_xval.scenario import load_scenario

    scene_mod._MESH_CACHE.clear()
    for yaw, mass in ((0.0, 420.0), (30.0, 420.0), (30.0, 380.0), (0.0, None)):
        scn = load_scenario(_mesh_scenario(tmp_path, yaw=yaw, mass=mass))
        mesh, _ = load_rock_mesh(scn.resolve_path(scn.rock.path), units="m", pose="settle")
        if yaw:
            c, s = math.cos(math.radians(yaw)), math.sin(math.radians(yaw))
            rz = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
            mesh.apply_transform(np.block([[rz, np.zeros((3, 1))], [np.zeros((1, 3)), np.ones((1, 1))]]))
        density = scn.rock.density if mass is None else mass / float(mesh.volume)
        mesh.density = density
        mp = mesh.mass_properties
        shift = np.array([-mp["center_mass"][0], -mp["center_mass"][1], -mesh.bounds[0, 2]])
        for _ in ("first", "again"):  # the cache is cleared once: later cases meet earlier entries
            rock = scene_mod.compile_scene(scn).rock
            assert rock.mass == float(mp["mass"])
            assert np.array_equal(rock.inertia, mp["inertia"])
            assert np.array_equal(rock.com, np.asarray(mp["center_mass"]) + shift)
            assert np.array_equal(rock.mesh.vertices, mesh.vertices + shift)
            moved = mesh.copy()
            moved.apply_translation(shift)
            moved.density = density
            # the mesh carries the density, as before the memo
            assert rock.mesh.mass_properties["mass"] == moved.mass_properties["mass"]


def test_compiled_meshes_are_copies(tmp_path: Path) -> None:
    from pbr_xval.scenario import load_scenario
    from pbr_xval.scene import compile_scene, rock_hull

    scn = load_scenario(_mesh_scenario(tmp_path))
    a = compile_scene(scn).rock.mesh
    v = a.vertices.copy()
    hull = rock_hull(a)
    assert np.array_equal(hull.vertices, a.convex_hull.vertices)
    a.apply_translation([1.0, 0.0, 0.0])  # a caller changes its mesh and its hull
    hull.apply_translation([1.0, 0.0, 0.0])
    b = compile_scene(scn).rock.mesh
    assert np.array_equal(b.vertices, v)
    assert np.array_equal(rock_hull(b).vertices, b.convex_hull.vertices)


def test_scene_alpha_is_critical_tilt_per_direction(tmp_path: Path) -> None:
    from pbr_xval.geometry.stability import critical_tilt
    from pbr_xval.scenario import load_scenario
    from pbr_xval.scene import compile_scene

    scn = load_scenario(_mesh_scenario(tmp_path))
    for az in (20.0, 200.0, 20.0):
        sc = compile_scene(
            scn.model_copy(update={"excitation": scn.excitation.model_copy(update={"azimuth_deg": az})})
        )
        v, c, d = sc.rock.mesh.vertices, sc.rock.com, sc.direction
        assert sc.alpha == (critical_tilt(v, c, -d), critical_tilt(v, c, d))
