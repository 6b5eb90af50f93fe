"""The package's exception types, in one low module every layer may import.

They are re-exported where they were first defined (``pbr_xval.engine.NotApplicable``,
``pbr_xval.scenario.ScenarioError``, …), so existing imports keep working; new code should
import them from here. Each message names the file or field, what was found and what was
expected.
"""

from __future__ import annotations

__all__ = ["EngineNotAvailable", "EngineSettingsError", "NotApplicable", "OutputPathError", "ScenarioError"]


class ScenarioError(ValueError):
    """A scenario file is invalid; the message names the file, the key and what was expected."""


class EngineNotAvailable(ImportError):
    """An engine is unknown or its third-party package is not installed."""


class EngineSettingsError(ValueError):
    """A settings dictionary names a key the engine does not have, or a bad value."""


class NotApplicable(ValueError):
    """The engine cannot represent this scene (e.g. a 2-D model asked for 3-D shaking)."""


class OutputPathError(ValueError):
    """An output location cannot be written (a file where a folder is expected, or the reverse,
    an existing file without ``--overwrite``, a read-only folder); the message names the option."""
