"""Figures several studies share: the rock with its contact patch, the ground motion, fragility curves.

Every function returns matplotlib objects in the report style (:mod:`pbr_xval.report.style`)
plus the data drawn, as a pandas DataFrame, so the report can link it under the figure.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from pbr_xval.report.style import axis_label, engine_colour, log_ticks, subplots

if TYPE_CHECKING:
    from pbr_xval.scene import Scene

__all__ = ["fragility_curves", "ground_motion_table", "plot_ground_motion", "rock_figure"]


def _hull2d(p: np.ndarray) -> np.ndarray:
    """Convex hull of 2-D points (n, 2) as a closed polygon (monotone chain)."""
    pts = np.unique(np.round(p, 12), axis=0)
    if len(pts) < 3:
        return np.vstack([pts, pts[:1]]) if len(pts) else pts
    pts = pts[np.lexsort((pts[:, 1], pts[:, 0]))]

    def cross(o: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
        return float((a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]))

    lower: list[np.ndarray] = []
    for q in pts:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], q) <= 0:
            lower.pop()
        lower.append(q)
    upper: list[np.ndarray] = []
    for q in pts[::-1]:
        while len(upper) >= 2 and cross(upper[-2], upper[-1], q) <= 0:
            upper.pop()
        upper.append(q)
    hull = np.array(lower[:-1] + upper[:-1])
    return np.vstack([hull, hull[:1]])


def rock_figure(scene: Scene, title: str = "") -> tuple[Any, Any]:
    """Side view (x–z) and plan view (x–y) of the rock at rest, contact patch and COM; equal axes.

    The contact patch is the set of vertices within 0.5 % of the rock's height of its lowest point
    (the basal nodes when the scene has them); the support polygon is their convex hull.

    Returns
    -------
    fig : matplotlib Figure; data : DataFrame of the contact-patch points and the COM (m).
    """
    import pandas as pd

    v = np.asarray(scene.rock.mesh.vertices, dtype=float)
    com = np.asarray(scene.rock.com, dtype=float)
    zmin, zmax = float(v[:, 2].min()), float(v[:, 2].max())
    eps = 5e-3 * (zmax - zmin)
    patch = v[v[:, 2] <= zmin + eps]
    nodes = np.asarray(getattr(scene, "basal_nodes", np.zeros((0, 3))), dtype=float)
    if nodes.size:
        low = nodes[nodes[:, 2] <= zmin + eps]
        if len(low) >= len(patch):
            patch = low
    fig, (a1, a2) = subplots(1, 2, figsize=(6.4, 3.4))
    side = _hull2d(v[:, [0, 2]])
    plan = _hull2d(v[:, [0, 1]])
    a1.fill(side[:, 0], side[:, 1], color="0.85", ec="0.4", lw=1, label="rock")
    a1.axhline(0.0, color="k", lw=1)
    a1.plot(patch[:, 0], patch[:, 2], "o", color="C3", ms=3, label="contact")
    a1.plot(com[0], com[2], "k+", ms=12, mew=2, label="COM")
    a1.set_aspect("equal", adjustable="datalim")
    a1.set_xlabel("x [m]")
    a1.set_ylabel("z [m]")
    a1.set_title("side view")
    a2.fill(plan[:, 0], plan[:, 1], color="0.9", ec="0.5", lw=1)
    if len(patch) >= 3:
        poly = _hull2d(patch[:, :2])
        a2.fill(poly[:, 0], poly[:, 1], color="C3", alpha=0.35, ec="C3", lw=1.2, label="support polygon")
    a2.plot(patch[:, 0], patch[:, 1], "o", color="C3", ms=2.5, label="contact points")
    a2.plot(com[0], com[1], "k+", ms=12, mew=2, label="COM")
    a2.set_aspect("equal", adjustable="datalim")
    a2.set_xlabel("x [m]")
    a2.set_ylabel("y [m]")
    a2.set_title("plan view, contact patch")
    a2.legend(loc="upper right", fontsize=7, framealpha=0.8)
    if title:
        fig.suptitle(title, fontsize=10)
    data = pd.DataFrame(
        {
            "kind": ["contact"] * len(patch) + ["com"],
            "x_m": [*patch[:, 0], com[0]],
            "y_m": [*patch[:, 1], com[1]],
            "z_m": [*patch[:, 2], com[2]],
        }
    )
    return fig, data


def ground_motion_table(scene: Scene, t_end: float | None = None, n: int = 1200) -> Any:
    """Ground acceleration, velocity, displacement along the shaking direction: columns t, a_m_s2, v_m_s, d_m."""
    import pandas as pd

    exc = scene.excitation
    end = float(t_end if t_end is not None else scene.duration)
    t = np.linspace(0.0, end, n)
    d = np.asarray(scene.direction, dtype=float)
    d = d / (np.linalg.norm(d) or 1.0)
    return pd.DataFrame(
        {
            "t": t,
            "a_m_s2": exc.acceleration(t) @ d,
            "v_m_s": exc.velocity(t) @ d,
            "d_m": exc.displacement(t) @ d,
        }
    )


def plot_ground_motion(axes: Any, gm: Any) -> None:
    """Plot a, v, d (a :func:`ground_motion_table`) on three stacked axes sharing t."""
    for ax, col, lab in zip(
        axes,
        ("a_m_s2", "v_m_s", "d_m"),
        ("ground accel. [m/s²]", "ground vel. [m/s]", "ground displ. [m]"),
        strict=True,
    ):
        ax.plot(gm["t"], gm[col], color="0.25", lw=1.2)
        ax.axhline(0.0, color="0.6", lw=0.6)
        ax.set_ylabel(lab, fontsize=9)
    axes[0].set_title("ground motion (shaking direction)")
    axes[-1].set_xlabel("t [s]")
    for ax in axes[:-1]:
        ax.tick_params(labelbottom=False)


def _fit(x: np.ndarray, z: np.ndarray, im: str = "IM") -> Any:
    """fit_lognormal with its start-value warnings silenced (resamples often have 2–3 levels;
    the MLE's status says whether the fit is usable)."""
    import warnings

    from pbr_xval.catalog.fragility import fit_lognormal

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        warnings.simplefilter("ignore", np.exceptions.RankWarning)
        return fit_lognormal(x, z, im_name=im)


def _bootstrap_band(
    x: np.ndarray, z: np.ndarray, grid: np.ndarray, n_boot: int, seed: int, level: float
) -> tuple[np.ndarray, np.ndarray, int]:
    """Percentile band of P(grid) over lognormal refits of runs resampled with replacement."""
    rng = np.random.default_rng(seed)
    curves = []
    for _ in range(n_boot):
        idx = rng.integers(0, len(x), len(x))
        f = _fit(x[idx], z[idx])
        if f.status == "ok" and np.isfinite(f.theta) and np.isfinite(f.beta) and f.beta > 0:
            curves.append(f.probability(grid))
    if len(curves) < 10:
        return np.full(grid.shape, np.nan), np.full(grid.shape, np.nan), len(curves)
    c = np.asarray(curves)
    lo = (1 - level) / 2
    return np.quantile(c, lo, axis=0), np.quantile(c, 1 - lo, axis=0), len(curves)


def fragility_curves(
    cells: Any,
    x_key: str,
    variants: list[str],
    engines: list[str],
    *,
    group_note: str = "",
    n_boot: int = 40,
    min_levels: int = 3,
    level: float = 0.9,
    seed: int = 0,
) -> tuple[Any, Any]:
    """P(topple | x) per variant and engine: observed fractions and lognormal MLE fits with a band.

    ``cells`` has columns variant, engine, x, status, toppled (one row per run). The fits are
    :func:`pbr_xval.catalog.fragility.fit_lognormal` (Baker 2015); the band is the ``level``
    percentile band of ``n_boot`` bootstrap refits (runs resampled with replacement). A fit that
    is degenerate (none/all toppled, complete separation) is drawn as its observed fractions only
    and named in the legend, and so is a fit on fewer than ``min_levels`` intensity levels.

    Returns
    -------
    fig, fits : the figure and a DataFrame (variant, engine, theta, beta, n_runs, n_toppled,
        status, message, band_level, n_boot_ok).
    """
    import pandas as pd

    nv = len(variants)
    ncol = min(nv, 3)
    nrow = (nv + ncol - 1) // ncol
    fig, axes = subplots(nrow, ncol, figsize=(4.2 * ncol + 0.8, 3.3 * nrow), squeeze=False)
    rows = []
    ok = cells[cells["status"] == "ok"]
    xs_all = ok["x"].astype(float)
    xmin = float(xs_all.min()) if len(xs_all) else 0.1
    xmax = float(xs_all.max()) if len(xs_all) else 1.0
    grid = np.geomspace(max(xmin * 0.6, 1e-9), xmax * 1.5, 200)
    for k, var in enumerate(variants):
        ax = axes[k // ncol, k % ncol]
        for j, eng in enumerate(engines):
            sub = ok[(ok["variant"] == var) & (ok["engine"] == eng)]
            if sub.empty:
                continue
            x = sub["x"].to_numpy(float)
            z = sub["toppled"].to_numpy(bool)
            colour = engine_colour(eng)
            levels = np.unique(x)
            frac = np.array([z[x == lv].mean() for lv in levels])
            off = 1.0 + 0.012 * (j - (len(engines) - 1) / 2)  # engines side by side, not on top
            ax.plot(levels * off, frac, "o", color=colour, ms=4, alpha=0.8)
            fit = _fit(x, z, x_key)
            if fit.status == "ok" and len(levels) < min_levels:
                fit.status = "too_few_levels"
                fit.message = f"{len(levels)} intensity levels; a fit needs at least {min_levels}"
            lo = hi = None
            nb = 0
            if fit.status == "ok":
                lo, hi, nb = _bootstrap_band(x, z, grid, n_boot, seed + 7919 * j + k, level)
                ax.plot(
                    grid,
                    fit.probability(grid),
                    color=colour,
                    lw=1.6,
                    label=f"{eng}: θ={fit.theta:.3g}, β={fit.beta:.2f}",
                )
                if np.isfinite(lo).all():
                    ax.fill_between(grid, lo, hi, color=colour, alpha=0.12, lw=0)
            else:
                ax.plot([], [], "o", color=colour, label=f"{eng}: no fit ({fit.status.replace('_', ' ')})")
            rows.append(
                {
                    "variant": var,
                    "engine": eng,
                    "im": x_key,
                    "theta": fit.theta if fit.status == "ok" else float("nan"),
                    "beta": fit.beta if fit.status == "ok" else float("nan"),
                    "n_runs": fit.n_runs,
                    "n_toppled": fit.n_toppled,
                    "status": fit.status,
                    "message": fit.message,
                    "band_level": level,
                    "n_boot_ok": nb,
                }
            )
        ax.set_xscale("log")
        ax.set_ylim(-0.03, 1.03)
        ax.set_xlabel(axis_label(x_key))
        if k % ncol == 0:
            ax.set_ylabel("P(topple)")
        ax.set_title(var if var != "base" else "fragility", fontsize=10)
        ax.legend(fontsize=7, loc="upper left", framealpha=0.85)
        log_ticks(ax.xaxis)
    for k in range(nv, nrow * ncol):
        axes[k // ncol, k % ncol].set_visible(False)
    if group_note:
        fig.suptitle(group_note, fontsize=9)
    return fig, pd.DataFrame(rows)
