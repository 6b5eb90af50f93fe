"""``pbr-xval rock``: a scan (mesh or point cloud) → rock model, printed and written as a report.

The lead wires :func:`rock_command` into ``pbr_xval.cli``.
"""

from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["rock_command"]


def _atomic_write_text(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    with os.fdopen(fd, "w", encoding="utf-8") as fh:
        fh.write(text)
    os.replace(tmp, path)


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


def rock_command(
    scan: Path,
    pedestal: Path | None,
    density: float,
    units: str,
    out: Path | None,
    *,
    mass: float | None = None,
    orientation: str = "settle",
    cut_z: float | None = None,
    alpha_multiple: float | None = None,
    grid_spacing: float | None = None,
    eps: float | None = None,
    n_directions: int = 72,
    gravity: float = 9.81,
    console: Any = None,
) -> int:
    """Build the rock model of ``scan``, print it with rich, write ``out`` (default
    ``reports/rock_<name>/``: rock.json, rock.png, polar.png). Returns 0, or 2 on a geometry error.

    ``mass`` (kg), when given, overrides ``density``.
    """
    from rich.console import Console
    from rich.table import Table

    from pbr_xval.geometry.interface import plot_stability_polar
    from pbr_xval.geometry.mesh import MeshError
    from pbr_xval.geometry.rockmodel import build_rock_model

    con = console or Console()
    try:
        model = build_rock_model(
            Path(scan),
            Path(pedestal) if pedestal is not None else None,
            density=None if mass is not None else density,
            mass=mass,
            units=units,
            orientation=orientation,
            cut_z=cut_z,
            alpha_multiple=alpha_multiple,
            grid_spacing=grid_spacing,
            eps=eps,
            n_directions=n_directions,
            gravity=gravity,
        )
    except (MeshError, ValueError, FileNotFoundError) as exc:
        con.print(f"[red]error:[/red] {exc}")
        return 2
    d = model.to_dict()
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
    t.add_row(
        "critical tilt α",
        f"min {ct['min_deg']:.2f}° (at φ = {ct['min_at_phi_deg']:.0f}°), max {ct['max_deg']:.2f}°",
    )
    phis = np.asarray(ct["phi_deg"])
    alphas = np.asarray(ct["alpha_deg"])
    per30 = [
        f"{p:.0f}°: {np.interp(p, np.append(phis, 360), np.append(alphas, alphas[0])):.1f}°"
        for p in range(0, 360, 30)
    ]
    t.add_row("α per 30°", ", ".join(per30))
    t.add_row(
        "toppling g·tan α", f"{ct['toppling_accel_min_m_s2']:.3f} – {ct['toppling_accel_max_m_s2']:.3f} m/s²"
    )
    for w in d["info"].get("reconstruction", {}).get("warnings", []):
        t.add_row("[yellow]reconstruction[/yellow]", w)
    for r in d["info"]["scan"].get("repairs", []):
        t.add_row("repair", r)
    con.print(t)
    out_dir = Path(out) if out is not None else Path("reports") / f"rock_{model.name}"
    _atomic_write_text(out_dir / "rock.json", json.dumps(d, indent=2, default=float))
    _picture(model, out_dir / "rock.png")
    plot_stability_polar(model.stability, out_dir / "polar.png", g=gravity, title=model.name)
    con.print(f"wrote {out_dir}/rock.json, rock.png, polar.png")
    return 0
