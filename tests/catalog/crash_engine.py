"""Test-only engine: the housner engine, except that it aborts the process (a real crash, like
a segfault in a C engine) for any rock whose id starts with ``crash``."""

from __future__ import annotations

import os
from typing import Any, ClassVar

from pbr_xval.analytical.adapters import HousnerEngine


class CrashEngine(HousnerEngine):
    name: ClassVar[str] = "crash_housner"

    def simulate(self, scene: Any, settings: Any = None) -> Any:
        if scene.name.startswith("crash"):
            os.abort()
        return super().simulate(scene, settings)
