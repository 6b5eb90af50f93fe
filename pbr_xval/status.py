"""The outcome of one run, one enum for every layer (a foundation module: imports nothing).

A ``str`` enum: a member equals its value (``RunStatus.OK == "ok"``), prints as it, is written
as it to JSON, CSV and Parquet, and a value read back from a file converts with
``RunStatus(text)``; existing comparisons with ``"ok"``/``"failed"`` keep working.
"""

from __future__ import annotations

import enum

__all__ = ["RunStatus"]


class RunStatus(enum.StrEnum):
    """What became of one simulation (engine × scene × settings).

    Members
    -------
    OK : the run completed (the rock may have toppled or not; that is the result, not the status).
    FAILED : the engine ran and failed (a numerical blow-up, a solver failure); ``message`` says why.
    ERROR : an unexpected exception outside the engine's own failure reporting.
    NOT_APPLICABLE : the engine cannot represent the scene (:class:`pbr_xval.errors.NotApplicable`).
    UNAVAILABLE : the engine's package is not installed (:class:`pbr_xval.errors.EngineNotAvailable`).
    SKIPPED : not run, by choice (e.g. outside the engine's declared capabilities).
    TIMEOUT : stopped after the time limit of its worker.
    CRASH : its worker process died before answering (a segfault in an engine, killed).
    INTERRUPTED : stopped by the user (Ctrl-C) before it completed.
    """

    OK = "ok"
    FAILED = "failed"
    ERROR = "error"
    NOT_APPLICABLE = "not_applicable"
    UNAVAILABLE = "unavailable"
    SKIPPED = "skipped"
    TIMEOUT = "timeout"
    CRASH = "crash"
    INTERRUPTED = "interrupted"
