"""The rich consoles the commands write to: one place that says how a line reaches a terminal or a log.

A console that is not a terminal (a pipe, a log file, a batch job) is 80 columns wide, and rich hard-wraps a
longer line there, which split log lines in two (``… ETA 710`` / ``s``). Every console the commands build
soft-wraps instead: a line is one line, however narrow the console.
"""

from __future__ import annotations

from typing import Any

__all__ = ["make_console"]


def make_console(console: Any = None, *, stderr: bool = False) -> Any:
    """``console`` when given (a caller's own), else a soft-wrapping :class:`rich.console.Console` on stdout
    (``stderr=True``: on stderr). rich is imported here, on first use, not with :mod:`pbr_xval`."""
    if console is not None:
        return console
    from rich.console import Console

    return Console(stderr=stderr, soft_wrap=True)
