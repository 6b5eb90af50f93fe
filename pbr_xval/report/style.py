"""One matplotlib style for every report figure: sizes, fonts, engine colours, unit labels.

Studies call :func:`subplots` instead of ``plt.subplots`` so every figure of a report has the
same fonts (panel titles 11 pt, labels 10 pt, ticks 9 pt at 100 dpi), the same colour per
engine across figures, and axis labels from the units registry (:mod:`pbr_xval.units`).

Examples
--------
>>> fig, ax = subplots(figsize=(6, 3))
>>> ax.set_xlabel(axis_label("excitation.pgv"))
>>> engine_colour("mujoco")
'#1f77b4'
"""

from __future__ import annotations

from typing import Any

from pbr_xval import units

__all__ = [
    "RC",
    "WIDTH",
    "axis_label",
    "engine_colour",
    "engine_style",
    "figure",
    "fmt_g",
    "fmt_pct",
    "log_ticks",
    "plt",
    "rc",
    "subplots",
    "unit_suffix_to_text",
]

#: figure width (inches) that fills the report's content column at 100 dpi
WIDTH = 12.0

RC: dict[str, Any] = {
    "figure.dpi": 100,
    "savefig.dpi": 100,
    "font.size": 10,
    "axes.titlesize": 11,
    "axes.titleweight": "bold",
    "axes.labelsize": 10,
    "xtick.labelsize": 9,
    "ytick.labelsize": 9,
    "legend.fontsize": 9,
    "figure.titlesize": 12,
    "axes.grid": True,
    "grid.alpha": 0.3,
    "grid.linewidth": 0.6,
    "axes.spines.top": False,
    "axes.spines.right": False,
    "lines.linewidth": 1.4,
    "axes.formatter.useoffset": False,
    "axes.formatter.limits": (-4, 5),
}

#: a fixed colour per engine name, so an engine looks the same in every figure
_ENGINE_COLOURS = {
    "housner": "#000000",
    "curved_base": "#000000",
    "mujoco": "#1f77b4",
    "pybullet": "#d62728",
    "dart": "#2ca02c",
    "reference": "#9467bd",
}
_SPARE = ["#ff7f0e", "#8c564b", "#e377c2", "#17becf", "#bcbd22", "#7f7f7f"]
_ANALYTICAL = ("housner", "curved_base")


def plt() -> Any:
    """``matplotlib.pyplot`` on the Agg backend (no display needed)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as pyplot

    return pyplot


def subplots(*args: Any, **kwargs: Any) -> tuple[Any, Any]:
    """``plt.subplots`` under the report style (:data:`RC`); constrained layout by default."""
    pyplot = plt()
    kwargs.setdefault("layout", "constrained")
    with pyplot.rc_context(RC):
        fig, axes = pyplot.subplots(*args, **kwargs)
    fig.set_dpi(RC["figure.dpi"])
    _restyle(fig)
    return fig, axes


def rc() -> Any:
    """Context manager applying :data:`RC` (wrap figures built axis by axis, e.g. with gridspec)."""
    return plt().rc_context(RC)


def figure(**kwargs: Any) -> Any:
    """An empty figure in the report style (constrained layout); add axes inside :func:`rc`."""
    kwargs.setdefault("layout", "constrained")
    with rc():
        return plt().figure(**kwargs)


def _restyle(fig: Any) -> None:
    """Apply the axes-level parts of :data:`RC` (rc_context only lasts while the axes are created)."""
    for ax in fig.get_axes():
        ax.grid(True, alpha=RC["grid.alpha"], lw=RC["grid.linewidth"])
        ax.spines["top"].set_visible(False)
        ax.spines["right"].set_visible(False)


def engine_colour(name: str) -> str:
    """The colour of an engine in every report figure (analytical references are black)."""
    base = str(name).split("[", 1)[0].split(" ", 1)[0]
    if base in _ENGINE_COLOURS:
        return _ENGINE_COLOURS[base]
    return _SPARE[sum(map(ord, base)) % len(_SPARE)]


def engine_style(name: str, reference: str | None = None) -> dict[str, Any]:
    """Line style of an engine: the reference solid black and thick, the others coloured, dashed."""
    if name == reference or (reference is None and name in _ANALYTICAL):
        return {"color": "k", "lw": 2.2, "ls": "-", "zorder": 2}
    return {"color": engine_colour(name), "lw": 1.3, "ls": "--", "zorder": 3}


def fmt_g(v: float, _pos: Any = None) -> str:
    """Tick label ``0.2``, ``5``, ``100`` (a picklable FuncFormatter target)."""
    return f"{v:g}"


def fmt_pct(v: float, _pos: Any = None) -> str:
    """Tick label of a fraction as percent: ``0.001`` → ``0.1 %``."""
    return f"{100 * v:g} %"


def log_ticks(axis: Any, *, percent: bool = False) -> None:
    """Labels on the 1-2-5 ticks of a log axis only (minor labels overlapped within a decade)."""
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

    axis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
    axis.set_major_formatter(FuncFormatter(fmt_pct if percent else fmt_g))
    axis.set_minor_formatter(NullFormatter())


def axis_label(key: str, fallback_unit: str = "") -> str:
    """Axis label of a dotted key from the units registry: ``"PGV [m/s]"``.

    An unregistered key is printed as given, with ``fallback_unit`` when one is known.
    """
    lab = units.label(key)
    if units.quantity(key) is None and fallback_unit:
        return f"{key} [{fallback_unit}]"
    return lab


def unit_suffix_to_text(suffix: str) -> str:
    """Column unit suffix back to the printed unit: ``m_s2`` → ``m/s²``."""
    for q in units.QUANTITIES.values():
        if q.suffix == suffix and suffix:
            return q.unit
    return {"1": ""}.get(suffix, suffix.replace("_", "/"))
