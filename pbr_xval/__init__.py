"""pbr-xval: cross-validation of physics engines on precariously balanced rocks.

One backend-neutral :class:`~pbr_xval.scenario.Scenario` is compiled into a
:class:`~pbr_xval.scene.Scene` and simulated by every registered engine (analytical Housner
and curved-base solutions, the LCP reference solver, PyBullet, MuJoCo, DART); the
:class:`~pbr_xval.engine.Trajectory` objects they return are compared by the studies.

Importing this package imports no physics engine; engines load on first use.
"""

from __future__ import annotations

from pbr_xval.engine import Trajectory, get_engine, list_engines
from pbr_xval.scenario import Scenario, ScenarioError, load_scenario
from pbr_xval.version import __version__

__all__ = [
    "Scenario",
    "ScenarioError",
    "Trajectory",
    "__version__",
    "compile_scene",
    "get_engine",
    "list_engines",
    "load_scenario",
    "simulate",
]


def compile_scene(scenario):
    """Compile a scenario into a Scene (see :func:`pbr_xval.scene.compile_scene`)."""
    from pbr_xval.scene import compile_scene as _compile

    return _compile(scenario)


def simulate(scenario, engine: str, settings=None):
    """Compile ``scenario`` and simulate it with ``engine``; returns a Trajectory.

    ``settings`` overrides the scenario's ``[engines.<engine>]`` table, which overrides the
    engine's default profile.
    """
    from pbr_xval.runner import run_scenario

    return run_scenario(scenario, engine, settings)
