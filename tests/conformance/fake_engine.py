"""The example adapter of ``docs/adding_an_engine.md``: one file, one entry point, one check.

``planar_rocking`` is a small engine built on a solver that is not an engine:
:func:`pbr_xval.analytical.rocking.simulate_rocking` (the planar two-pivot rocking equation,
integrated with event location) plays the third-party simulator. The adapter does what every
adapter does, and nothing else:

1. declare what it can model (:class:`~pbr_xval.engine.Capabilities`) and its settings
   (``profiles``);
2. refuse a scene it cannot represent with :class:`~pbr_xval.engine.NotApplicable`;
3. build its model from the :class:`~pbr_xval.scene.Scene` (here: mass, inertia and the two
   pivots of ``scene.planar_model()``), drive it with the scene's ground motion, run it;
4. return a :class:`~pbr_xval.engine.Trajectory` in the pedestal frame: COM (n, 3) m,
   orientation quaternions (n, 4) relative to rest, angular velocity (n, 3) rad/s, events
   (``impact``, ``toppled``), SI units.

It is registered by ``tests/conformance/test_fake_engine.py`` through an entry point, like a
plugin's ``pyproject.toml`` would:

.. code-block:: toml

    [project.entry-points."pbr_xval.engines"]
    planar_rocking = "fake_engine:PlanarRockingEngine"
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from pbr_xval.engine import Capabilities, EngineBase, Event, NotApplicable, Trajectory, axis_angle_quat

if TYPE_CHECKING:
    from pbr_xval.scene import Scene


class PlanarRockingEngine(EngineBase):
    """Planar rocking on two pivots, without bounce or sliding (the example adapter).

    A mesh rock is accepted: ``scene.planar_model()`` finds its two pivots (a box given as a
    mesh rocks like the box); a rock with no two-pivot section raises NotApplicable there.
    """

    name: ClassVar[str] = "planar_rocking"
    capabilities: ClassVar[Capabilities] = Capabilities(
        dims=2,
        shapes=frozenset({"box", "notched_block", "mesh"}),
        sliding=False,
        restitution=False,
        analytical=False,  # judged with the time-steppers' tolerances
    )

    def profiles(self) -> dict[str, dict[str, Any]]:
        # one profile; every key is a setting the user may override (checked centrally)
        return {"faithful": {"rtol": 1e-10, "atol": 1e-12}}

    def simulate(self, scene: Scene, settings: Mapping[str, Any] | None = None) -> Trajectory:
        from pbr_xval.analytical.rocking import TwoPivotBody, simulate_rocking

        s = self.resolve_settings(settings)
        if scene.rock.shape not in self.capabilities.shapes:
            raise NotApplicable(f"{self.name}: rock shape {scene.rock.shape!r} is not a two-pivot body")
        if scene.restitution != 0.0:
            raise NotApplicable(f"{self.name}: impacts do not bounce; set contact.restitution = 0")
        crit = scene.toppling
        if crit.criterion not in ("physical", "critical_tilt"):
            raise NotApplicable(f"{self.name}: toppling criterion {crit.criterion!r} is not supported")

        # build the model from the scene
        pm = scene.planar_model()
        body = TwoPivotBody(pm.mass, pm.inertia, pm.left, pm.right)
        exc = scene.excitation
        sol = simulate_rocking(
            body,
            exc.horizontal.acceleration,
            scene.duration,
            g=scene.gravity,
            accel_v=exc.vertical.acceleration if exc.vertical is not None else None,
            breakpoints=tuple(sorted(set(exc.breakpoints))),
            theta0=scene.theta0,
            omega0=scene.omega0,
            rtol=s["rtol"],
            atol=s["atol"],
            dense_dt=scene.output_dt,
            topple_factor=crit.factor if crit.criterion == "critical_tilt" else 1.0,
            decision="physical" if crit.criterion == "physical" else "first_crossing",
            down_angle=math.radians(crit.down_angle_deg),
            free_after=scene.excitation_end,
        )

        # back to 3-D, pedestal frame: rotation θ about the rocking axis e, pivot on the
        # side the rock leans to
        d, e, ez = scene.direction, scene.rocking_axis, np.array([0.0, 0.0, 1.0])
        theta, omega = sol.theta, sol.omega
        px = np.where(theta >= 0, body.right[0], body.left[0])
        pz = np.where(theta >= 0, body.right[1], body.left[1])
        c, sn = np.cos(theta), np.sin(theta)
        rd, rz = -px * c - pz * sn, px * sn - pz * c  # pivot → COM, rotated by θ
        com = scene.rock.com[None, :] + (px + rd)[:, None] * d + (pz + rz)[:, None] * ez
        events = [
            Event(ev["kind"], float(ev["t"]), {k: v for k, v in ev.items() if k not in ("kind", "t")})
            for ev in sol.events
        ]
        return Trajectory(
            engine=self.name,
            t=sol.t,
            com=com,
            quat=axis_angle_quat(e, theta),
            omega=omega[:, None] * e[None, :],
            events=events,
            diagnostics={"max_penetration_m": 0.0},  # rigid contact: no penetration
            scene_info=scene.info(),
            excitation_axis=np.asarray(d, dtype=float),
        )
