"""What every study returns, so one report writer can render any of them.

A study (threshold search, rocking histories, fragility maps, speed–accuracy trade,
stability at the extremes, ...) produces a :class:`StudyResult`:

* ``tables``: named pandas DataFrames — the figures' data (written as CSV beside the HTML
  and as Parquet for machines);
* ``figures``: :class:`Figure` objects — a matplotlib figure plus the name of the table that
  holds its data and a caption;
* ``summary``: short Markdown lines for ``summary.md`` (CI logs, pull requests);
* ``headline``: a few key numbers (JSON-serialisable) for regression and comparison;
* ``provenance``: scenario hashes, engine versions and settings.

Studies never write files themselves; :mod:`pbr_xval.report` does, atomically.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import pandas as pd
    from matplotlib.figure import Figure as MplFigure

__all__ = ["ANALYTICAL_ENGINES", "Figure", "StudyResult", "clamped_progress", "reference_candidates"]


@dataclass
class Figure:
    """A rendered figure and where its data lives.

    Attributes
    ----------
    name : file stem (``<name>.png`` / ``<name>.csv``).
    figure : the matplotlib figure (Agg backend).
    table : key into ``StudyResult.tables`` of the data plotted.
    caption : one or two sentences a reader needs to read the plot.
    """

    name: str
    figure: MplFigure
    table: str
    caption: str = ""


@dataclass
class StudyResult:
    """Output of one study; see the module docstring."""

    kind: str
    title: str
    tables: dict[str, pd.DataFrame] = field(default_factory=dict)
    figures: list[Figure] = field(default_factory=list)
    summary: list[str] = field(default_factory=list)
    headline: dict[str, Any] = field(default_factory=dict)
    provenance: dict[str, Any] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    wall_time: float = 0.0


#: the analytical engines, in the order a study falls back to them for its reference
ANALYTICAL_ENGINES = ("housner", "curved_base")


def reference_candidates(ref_name: str | None) -> list[str]:
    """The engines a study tries, in order, for its analytical reference: the one asked for,
    then the other analytical engines (none when no reference is asked for)."""
    return [ref_name] + [a for a in ANALYTICAL_ENGINES if a != ref_name] if ref_name else []


def clamped_progress(progress: Callable[[str, float], None] | None) -> Callable[[str, float], None]:
    """A study's progress callback that takes any fraction (clamped to [0, 1]); a no-op without one."""

    def say(msg: str, frac: float) -> None:
        if progress is not None:
            progress(msg, min(1.0, max(0.0, frac)))

    return say
