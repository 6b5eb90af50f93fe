"""Test engines that misbehave, for worker-isolation tests (loaded in workers as "file.py:Class")."""

from __future__ import annotations

import ctypes
import os
import time
from typing import Any, ClassVar

import numpy as np

from pbr_xval.engine import Capabilities, EngineBase, Event, Trajectory


class _Base(EngineBase):
    capabilities: ClassVar[Capabilities] = Capabilities()

    def profiles(self) -> dict[str, dict[str, Any]]:
        return {"faithful": {"timestep": 1e-3}, "engine-default": {"timestep": 1e-2}}


class SegfaultEngine(_Base):
    """Dereferences NULL: the process dies with SIGSEGV."""

    name = "segfault"

    def simulate(self, scene, settings=None):
        ctypes.string_at(0)
        raise AssertionError("unreachable")


class AbortEngine(_Base):
    name = "abort"

    def simulate(self, scene, settings=None):
        os.abort()


class HangEngine(_Base):
    name = "hang"

    def simulate(self, scene, settings=None):
        time.sleep(3600)


class RaiseEngine(_Base):
    name = "raiser"

    def simulate(self, scene, settings=None):
        raise RuntimeError("solver exploded politely")


class NaNEngine(_Base):
    name = "nan"

    def simulate(self, scene, settings=None):
        return Trajectory.failed(self.name, "NaN in state at t = 0.1 s (explosion)")


class StillEngine(_Base):
    """Returns a rock that never moves (a cheap well-behaved engine)."""

    name = "still"

    def simulate(self, scene, settings=None):
        n = 11
        t = np.linspace(0, scene.duration, n)
        com = np.tile(scene.rock.com, (n, 1))
        quat = np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))
        return Trajectory(
            self.name,
            t,
            com,
            quat,
            np.zeros((n, 3)),
            events=[Event("rest", 0.0)],
            diagnostics={"max_penetration_m": 0.0},
            settings=dict(settings or {}),
        )
