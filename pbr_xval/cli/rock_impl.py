"""``pbr-xval rock``: a scan (mesh or point cloud) → rock model, printed and written as a report.

The command itself is declared in :mod:`pbr_xval.cli.rock`, which calls :func:`rock_command`.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import numpy as np

from pbr_xval.atomic import write_text_atomic

__all__ = ["rock_command", "write_rock_scenario"]


def _picture(model: Any, path: Path) -> None:
    """Two orthographic views (x–z side, x–y plan) with the contact patch and the COM."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from pbr_xval.geometry.interface import _atomic_savefig

    v = model.mesh.vertices
    c = model.exact.com
    cp = model.contact.points
    fig, axes = plt.subplots(1, 2, figsize=(10, 5))
    for ax, (i, j, lab) in zip(axes, [(0, 2, ("x [m]", "z [m]")), (0, 1, ("x [m]", "y [m]"))], strict=True):
        ax.scatter(v[:, i], v[:, j], s=0.3, c="0.6", label="rock surface")
        ax.scatter(cp[:, i], cp[:, j], s=3, c="C3", label="contact patch")
        ax.plot(c[i], c[j], "k+", ms=12, mew=2, label="COM")
        ax.set_xlabel(lab[0])
        ax.set_ylabel(lab[1])
        ax.set_aspect("equal")
    if len(model.contact.polygon) >= 3:
        poly = model.contact.polygon
        basis = model.contact.basis
        xyz = model.contact.plane_point + poly @ basis
        xyz = np.vstack([xyz, xyz[:1]])
        axes[1].plot(xyz[:, 0], xyz[:, 1], "C3-", lw=1, label="support polygon")
    axes[0].axhline(0.0, color="k", lw=0.8)
    axes[0].set_title("side view (x–z)")
    axes[1].set_title("plan view (x–y)")
    axes[1].legend(loc="upper right", fontsize=7)
    fig.suptitle(f"rock {model.name}: {model.exact.mass:.1f} kg")
    fig.tight_layout()
    _atomic_savefig(fig, path, dpi=110)
    plt.close(fig)


def _scan_repairs(model: Any) -> list[str]:
    """What the scan's loading repaired (and the bodies it dropped)."""
    return [str(r) for r in model.info.get("scan", {}).get("repairs", [])]


def rock_command(
    scan: Path,
    pedestal: Path | None,
    density: float,
    units: str,
    out: Path | None,
    *,
    mass: float | None = None,
    pose: str = "settle",
    scenario: Path | None = None,
    cut_z: float | None = None,
    alpha_multiple: float | None = None,
    grid_spacing: float | None = None,
    eps: float | None = None,
    n_directions: int = 72,
    gravity: float = 9.81,
    console: Any = None,
    overwrite: bool = False,
) -> int:
    """Build the rock model of ``scan``, print it with rich, write ``out`` (default
    ``reports/rock_<name>/``: rock.json, rock.png, polar.png). Returns 0, or 2 on a geometry error.

    ``mass`` (kg), when given, overrides ``density``. ``pose`` is ``scan``, ``settle`` or
    ``stable`` (:data:`pbr_xval.geometry.interface.POSES`). ``scenario``: also write a ready,
    validated scenario TOML for the rock there (:func:`write_rock_scenario`); an existing file
    there is replaced only with ``overwrite``. Every option and output location is checked before
    the scan is read.
    """
    import math

    from rich.markup import escape

    from pbr_xval.atomic import check_output_dir, check_output_file
    from pbr_xval.console import make_console
    from pbr_xval.errors import OutputPathError
    from pbr_xval.geometry.interface import plot_stability_polar
    from pbr_xval.geometry.mesh import MeshError
    from pbr_xval.geometry.rockmodel import build_rock_model

    con = make_console(console)

    def fail(msg: str) -> int:
        con.print(f"[red]error:[/red] {escape(msg)}", soft_wrap=True, highlight=False)
        return 2

    if scenario is not None and (pedestal is not None or cut_z is not None):
        return fail(
            "--scenario writes a rock on a flat pedestal; a scanned pedestal "
            "(--pedestal or --cut-z) cannot be carried into a scenario yet — drop --scenario or the pedestal"
        )
    for opt, v in (("--grid-spacing", grid_spacing), ("--alpha-multiple", alpha_multiple)):
        if v is not None and not (math.isfinite(v) and v > 0):
            return fail(f"{opt} {v!r}: expected a positive number")
    if cut_z is not None and not math.isfinite(cut_z):
        return fail(f"--cut-z {cut_z!r}: expected a finite height in the scan's units")
    for opt, v in (("--density", None if mass is not None else density), ("--mass", mass)):
        if v is not None and not (math.isfinite(v) and v > 0):
            return fail(f"{opt} {v!r}: expected a positive number")
    # every output is checked before the model is built
    out_dir = Path(out) if out is not None else Path("reports") / f"rock_{Path(scan).stem}"
    try:
        check_output_dir(out_dir, "--out")
        if scenario is not None:
            scenario = check_output_file(scenario, "--scenario", overwrite=overwrite)
            if scenario.suffix.lower() != ".toml":
                return fail(f"--scenario {scenario}: expected a .toml file name")
            if _is_point_cloud(Path(scan)):  # its surface is written beside the scenario
                check_output_file(
                    scenario.with_name(f"{scenario.stem}.rock.obj"),
                    "--scenario (the point cloud's surface)",
                    overwrite=overwrite,
                )
    except OutputPathError as exc:
        return fail(str(exc))
    try:
        model = build_rock_model(
            Path(scan),
            Path(pedestal) if pedestal is not None else None,
            density=None if mass is not None else density,
            mass=mass,
            units=units,
            pose=pose,
            cut_z=cut_z,
            alpha_multiple=alpha_multiple,
            grid_spacing=grid_spacing,
            eps=eps,
            n_directions=n_directions,
            gravity=gravity,
        )
    except (MeshError, ValueError, FileNotFoundError) as exc:
        return fail(str(exc))
    for r in _scan_repairs(model):
        if "disjoint bodies" in r:
            con.print(
                f"[yellow]warning:[/yellow] {escape(str(scan))}: {escape(r)}", soft_wrap=True, highlight=False
            )
    d = model.to_dict()
    ct = d["critical_tilt"]
    if ct["at_rest"] and ct["min_deg"] is not None:
        # the table's 5° grid can miss a narrow dip of α(φ) (SP1: 4.6° at 336°, 10.0° at 335°)
        step = 0.25
        a_min, phi_min = model.stability.minimum(step_deg=step)
        ct.update(
            refined_min_deg=math.degrees(a_min),
            refined_min_at_phi_deg=math.degrees(phi_min),
            refined_step_deg=step,
        )
    t = _rock_table(model, d)
    con.print(t)
    write_text_atomic(out_dir / "rock.json", json.dumps(d, indent=2, default=float))
    _picture(model, out_dir / "rock.png")
    plot_stability_polar(model.stability, out_dir / "polar.png", g=gravity, title=model.name)
    con.print(f"wrote {out_dir}/rock.json, rock.png, polar.png")
    if scenario is not None:
        try:
            write_rock_scenario(
                model, Path(scan), Path(scenario), units=units, pose=pose, density=density, mass=mass
            )
        except ValueError as exc:
            return fail(str(exc))
        con.print(
            f"wrote scenario {scenario} (check it with: pbr-xval check {scenario}; "
            f"find its toppling amplitude with: pbr-xval threshold {scenario} --engine mujoco)"
        )
    return 0


def _rock_table(model: Any, d: dict[str, Any]) -> Any:
    """The rich table ``pbr-xval rock`` prints for ``model`` (``d``: its ``to_dict()``, with the
    refined critical-tilt minimum when the rock is at rest)."""
    from rich.table import Table

    ct = d["critical_tilt"]
    f3 = lambda a: "(" + ", ".join(f"{x:.4f}" for x in a) + ")"  # noqa: E731
    t = Table(title=f"rock model: {model.name}", show_header=False)
    t.add_row("mass", f"{d['mass_kg']:.2f} kg  (density {d['density_kg_m3']:.1f} kg/m³)")
    t.add_row(
        "volume",
        f"{d['volume_m3']:.6f} m³  (nodes: {d['node_estimate']['volume_m3']:.6f} m³, "
        f"{d['node_estimate']['rel_volume_vs_exact']:+.2%} at h = {d['node_estimate']['spacing_m']:.4f} m)",
    )
    t.add_row("pose", str(d["info"].get("pose_kind")))
    t.add_row("COM (rest frame)", f3(d["com_rest_m"]) + " m")
    t.add_row("COM (scan coords)", f3(d["com_scan_m"]) + " m")
    t.add_row("COM height", f"{d['com_height_m']:.4f} m")
    inert = np.asarray(d["inertia_kg_m2"])
    t.add_row("inertia about COM", "\n".join(f3(r) for r in inert) + " kg·m²")
    t.add_row("principal moments", f3(d["principal_moments_kg_m2"]) + " kg·m²")
    c = d["contact"]
    t.add_row(
        "contact patch",
        f"{c['n_points']} points within {c['eps_m']:.4f} m; support polygon area {c['area_m2']:.5f} m²; "
        f"min rectangle {c['min_rectangle']['extents'][0]:.3f} × {c['min_rectangle']['extents'][1]:.3f} m",
    )
    t.add_row("direction φ", "φ = 0 along +x, counter-clockwise seen from above (+x toward +y)")
    if not ct["at_rest"] or ct["min_deg"] is None:
        t.add_row(
            "[yellow]critical tilt α[/yellow]",
            f"undefined: the rock is not at rest in this pose (its COM's vertical passes "
            f"{-ct['rest_margin_m'] * 1e3:.3g} mm outside its support); use --pose settle",
        )
    else:
        n_dir = len(ct["phi_deg"])
        t.add_row(
            "critical tilt α",
            f"min {ct['refined_min_deg']:.2f}° (at φ = {ct['refined_min_at_phi_deg']:.1f}°; searched on a "
            f"{ct['refined_step_deg']:g}° grid: the {360 / n_dir:g}° table's smallest is {ct['min_deg']:.2f}° at "
            f"{ct['min_at_phi_deg']:.0f}°), max {ct['max_deg']:.2f}° on the table "
            "(turned about the horizontal axis ⟂ φ)",
        )
        phis = np.asarray(ct["phi_deg"])
        alphas = np.asarray(ct["alpha_deg"], dtype=float)
        ups = np.asarray(ct["uplift_angle_deg"], dtype=float)
        per30 = [f"{p:.0f}°: {alphas[np.argmin(np.abs(phis - p))]:.1f}°" for p in range(0, 360, 30)]
        t.add_row("α per 30°", ", ".join(per30))
        t.add_row(
            "tilt-table angle α_u",
            f"min {np.nanmin(ups):.2f}°, max {np.nanmax(ups):.2f}° (atan of the COM's distance to the "
            "support edge along φ over its height)",
        )
        t.add_row(
            "uplift g·tan α_u",
            f"{ct['toppling_accel_min_m_s2']:.3f} – {ct['toppling_accel_max_m_s2']:.3f} m/s² "
            "(quasi-static uplift: a lower bound on the toppling PGA)",
        )
    for w in d["info"].get("reconstruction", {}).get("warnings", []):
        t.add_row("[yellow]reconstruction[/yellow]", w)
    for r in d["info"]["scan"].get("repairs", []):
        t.add_row("repair", r)
    return t


def _is_point_cloud(scan: Path) -> bool:
    """Whether ``scan`` is a point cloud, from its name and (PLY) its header only, before it is read.

    A PLY file is a mesh when its header declares faces (``element face N``, N > 0), as
    :func:`pbr_xval.geometry.io.load_scan` reads it; an unreadable file counts as a mesh (reading
    it reports the error).
    """
    from pbr_xval.geometry.io import CLOUD_FORMATS, MESH_FORMATS

    ext = scan.suffix.lower()
    if ext != ".ply":
        return ext in CLOUD_FORMATS - MESH_FORMATS
    try:
        with open(scan, "rb") as fh:
            head = fh.read(65536)
    except OSError:
        return False
    for line in head.split(b"end_header", 1)[0].splitlines():
        words = line.split()
        if len(words) == 3 and words[0] == b"element" and words[1] == b"face":
            return not (words[2].isdigit() and int(words[2]) > 0)
    return True


def write_rock_scenario(
    model: Any,
    scan: Path,
    path: Path,
    *,
    units: str = "m",
    pose: str = "settle",
    density: float = 2700.0,
    mass: float | None = None,
    frequency: float = 1.0,
    duration: float = 4.0,
) -> Any:
    """Write a ready scenario for the rock ``model`` (a :class:`ScannedRock` of ``scan``) to ``path``.

    The rock is the scan itself (a mesh file, referenced relative to the scenario) or, for a
    point cloud, its reconstructed closed surface written beside the scenario as
    ``<stem>.rock.obj``; the same ``units`` and ``pose`` as the model; mass properties from the
    closed mesh at ``density`` (or scaled to ``mass``); a flat pedestal; and a one-sine pulse
    of ``frequency`` Hz along φ = 0 (+x) whose amplitude is 2·g·tan α with α the smaller
    critical tilt toward ±x (at most 60°): the default threshold search (from the uplift bound
    min(g·tan α_u(0°), g·tan α_u(180°)) to twice the amplitude) then spans the quasi-static
    toppling level several times over. The scenario is validated and compiled before it is
    written (atomically).

    Returns the :class:`~pbr_xval.scenario.Scenario`.
    """
    import math
    import re

    from pbr_xval.atomic import write_text_atomic as atomic_write_text
    from pbr_xval.geometry.io import MESH_FORMATS, load_scan
    from pbr_xval.scenario import scenario_from_dict
    from pbr_xval.scene import compile_scene

    path = Path(path)
    scan = Path(scan)
    path.parent.mkdir(parents=True, exist_ok=True)
    is_mesh = scan.suffix.lower() in MESH_FORMATS and load_scan(scan, units=units).kind == "mesh"
    if is_mesh:
        rock_file = Path(os.path.relpath(scan.resolve(), path.parent.resolve())).as_posix()
        rock_units = units
        source = f"the scan {scan.name}"
    else:
        obj = path.with_name(f"{path.stem}.rock.obj")
        local = model.mesh.copy()
        local.apply_transform(np.linalg.inv(model.transform))  # back to the (re-centred) scan orientation
        atomic_write_text(obj, local.export(file_type="obj"))
        rock_file, rock_units = obj.name, "m"
        source = f"the closed surface reconstructed from the point cloud {scan.name} ({obj.name})"
    bound = float(model.stability.shaking_bound(0.0, model.gravity))
    alpha_x = float(min(model.stability.alpha_at(0.0), model.stability.alpha_at(math.pi)))
    if not (math.isfinite(bound) and math.isfinite(alpha_x)):
        raise ValueError(f"{scan}: the rock is not at rest in pose {pose!r}; use --pose settle")
    amplitude = 2.0 * model.gravity * math.tan(min(alpha_x, math.radians(60.0)))
    name = re.sub(r"[^A-Za-z0-9_.\-]", "_", scan.stem)
    rock: dict[str, Any] = {"shape": "mesh", "path": rock_file, "units": rock_units, "pose": pose}
    rock.update({"mass": float(mass)} if mass is not None else {"density": float(density)})
    data = {
        "name": name,
        "description": (
            f"{scan.name} on a flat pedestal, written by pbr-xval rock: mass properties from {source} "
            + (f"scaled to {mass} kg" if mass is not None else f"at {density} kg/m³")
            + f", pose {pose!r}; one-sine pulse along +x at 2·g·tan α = {amplitude:.4g} m/s² "
            f"(α = {math.degrees(alpha_x):.3g}°, the smaller critical tilt toward ±x)"
        ),
        "duration": float(duration),
        "gravity": float(model.gravity),
        "rock": rock,
        "pedestal": {"kind": "plane"},
        "excitation": {
            "type": "one_sine",
            "amplitude": round(amplitude, 6),
            "frequency": float(frequency),
            "azimuth_deg": 0.0,
        },
    }
    scn = scenario_from_dict(data, source=path)
    compile_scene(scn)  # everything check/run/threshold need (mesh, pose, stability) works
    header = (
        f"# Scenario for {scan.name}, written by `pbr-xval rock --scenario` (pose {pose!r}).\n"
        "# Directions: azimuth_deg = 0 along +x of the scan, counter-clockwise seen from above.\n"
        f"# Quasi-static uplift bound along ±x: {bound:.6g} m/s² (g·tan α_u: a lower bound on the toppling PGA);\n"
        f"# critical tilt toward ±x: {math.degrees(alpha_x):.4g}° (g·tan α = {model.gravity * math.tan(alpha_x):.6g} m/s²).\n"
        "# Edit [excitation] for your ground motion (see docs/scenarios.md).\n"
    )
    atomic_write_text(path, header + scn.to_toml())
    return scn
